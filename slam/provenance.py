"""What software a result was computed with, for its metrics.json.

The runs are chaotic: decisions at hard thresholds flip on differences in the last bits and
cascade, so the same commit and seed on two machines can end differently (office_g's seed-0 runs
after a reinstall, 2026-11-24; lab_e's GP seed 1, the same code, at 64.9 % on one machine on
2026-12-01 and at 99.9 % on another the next day). A result therefore names the commit, the versions of the libraries whose arithmetic
it rests on, and the processor.
"""

from __future__ import annotations

import functools
import platform
import subprocess
from importlib import metadata
from pathlib import Path

#: The distributions whose versions a result records: this one, and those it computes with.
PACKAGES = ("gpexplore", "numpy", "scipy", "scikit-learn", "numba", "llvmlite", "gtsam", "kiss-icp")
#: The processor's vector instructions that change which kernels numpy, BLAS and numba run, and so
#: their rounding.
VECTOR_FLAGS = ("fma", "avx2", "avx512f")


@functools.cache
def software() -> dict:
    """{"commit", "python", "machine", "processor", "vector_flags", "packages": {name: version}}:
    ``commit`` is the checkout's (with ``-dirty`` when tracked files differ from it), None when
    the code does not run from a git checkout; ``processor`` and ``vector_flags`` (those of
    ``VECTOR_FLAGS`` it has) are read from Linux's /proc/cpuinfo (elsewhere ``platform``'s name
    and None); a package that is not installed has the version None."""
    packages = {}
    for name in PACKAGES:
        try:
            packages[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            packages[name] = None
    processor, flags = _cpu()
    return {"commit": _commit(Path(__file__).resolve().parents[1]), "python": platform.python_version(),
            "machine": platform.machine(), "processor": processor, "vector_flags": flags,
            "packages": packages}


def _commit(root: Path) -> str | None:
    """HEAD of the git checkout at ``root`` (``-dirty`` with tracked changes), or None. An
    installed copy inside another repository (a virtual environment in a checkout) is not that
    repository's code: only ``root`` itself is asked."""
    if not (root / ".git").exists():
        return None
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"],
                              capture_output=True, text=True, timeout=10)
        status = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                                capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    if head.returncode != 0:
        return None
    return head.stdout.strip() + ("-dirty" if status.returncode == 0 and status.stdout.strip() else "")


def _cpu() -> tuple[str | None, list[str] | None]:
    """The CPU's model name and its ``VECTOR_FLAGS`` from /proc/cpuinfo's first processor, or
    (``platform``'s name or None, None) where that file cannot be read."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return platform.processor() or None, None
    fields = {}
    for line in lines:
        key, _, value = line.partition(":")
        fields.setdefault(key.strip(), value.strip())
    flags = fields.get("flags", "").split()
    return fields.get("model name") or platform.processor() or None, [f for f in VECTOR_FLAGS if f in flags]
