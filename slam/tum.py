"""TUM trajectory files: ``timestamp x y z qx qy qz qw`` per line (readable by evo)."""

from __future__ import annotations

import math
from pathlib import Path

import gtsam
import numpy as np

from slam.atomic import write_text_atomic


def write_tum(path: str | Path, stamps, poses: list[gtsam.Pose2]) -> None:
    """Write planar poses (z = 0, rotation about z), atomically."""
    stamps = np.asarray(stamps, dtype=float)
    if stamps.shape != (len(poses),):
        raise ValueError(f"{path}: {stamps.size} timestamps for {len(poses)} poses")
    rows = [f"{t:.6f} {p.x():.6f} {p.y():.6f} 0 0 0 {math.sin(p.theta() / 2):.9f} "
            f"{math.cos(p.theta() / 2):.9f}" for t, p in zip(stamps, poses)]
    write_text_atomic(path, "".join(r + "\n" for r in rows))


def read_tum(path: str | Path) -> tuple[np.ndarray, list[gtsam.Pose2]]:
    """(stamps (n,), poses) from a TUM file; the yaw is taken from the quaternion."""
    stamps, poses = [], []
    for number, line in enumerate(Path(path).read_text().splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        fields = line.split()
        if len(fields) != 8:
            raise ValueError(f"{path}:{number}: TUM line has {len(fields)} fields, expected 8")
        try:
            t, x, y, _, qx, qy, qz, qw = (float(f) for f in fields)
        except ValueError:
            raise ValueError(f"{path}:{number}: TUM line has a non-numeric field") from None
        yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
        stamps.append(t)
        poses.append(gtsam.Pose2(x, y, yaw))
    return np.array(stamps), poses
