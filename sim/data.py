"""Where the shared real data lives: ``$GPEXPLORE_DATA`` or ``../shared/data`` beside the repository."""

from __future__ import annotations

import os
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path | None:
    """The data folder, or None when neither ``$GPEXPLORE_DATA`` nor ``../shared/data`` exists.

    ``$GPEXPLORE_DATA``, when set, must name an existing folder.
    """
    env = os.environ.get("GPEXPLORE_DATA")
    if env:
        path = Path(env)
        if not path.is_dir():
            raise FileNotFoundError(f"GPEXPLORE_DATA={env} is not a folder")
        return path
    for base in (Path.cwd(), REPOSITORY):
        candidate = base.parent / "shared" / "data"
        if candidate.is_dir():
            return candidate
    return None


def benchmark_data_dir() -> Path:
    """For a benchmark: the data folder (exit with a message when there is none), after a warning
    when BLAS may run more than one thread (two threads on two cores slow the COM 9-16x)."""
    if os.environ.get("OPENBLAS_NUM_THREADS") != "1":
        print("warning: set OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 (BLAS threads slow this 9-16x)")
    try:
        data = shared_data_dir()
    except FileNotFoundError as err:
        raise SystemExit(str(err)) from None
    if data is None:
        raise SystemExit("shared data not found: set GPEXPLORE_DATA")
    return data
