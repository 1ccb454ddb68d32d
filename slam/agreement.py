"""Agreement of a trajectory with a reference trajectory of the same scans (GMapping's poses in a
corrected log: not ground truth, but a good map): the errors left after the best rigid planar
alignment of the whole trajectory, matched by scan order, so that broken stamps do not matter.
A mean hides local failures: the p95 and the largest error are reported beside the RMSE. The
best similarity alignment's scale and what it leaves tell a difference of scale (one trajectory
longer than the other throughout: the distance along a featureless corridor is the wheels') from
one of shape.
"""

from __future__ import annotations

from collections.abc import Sequence

import gtsam
import numpy as np

from slam.poses import pose_array


def se2_alignment(source: np.ndarray, target: np.ndarray) -> tuple[float, np.ndarray]:
    """The rotation angle (rad) and translation (2,) that move ``source`` (n, 2) onto ``target``
    (n, 2) with the least squared error (Umeyama / Kabsch without scale)."""
    ms, mt = source.mean(axis=0), target.mean(axis=0)
    h = (source - ms).T @ (target - mt)
    angle = float(np.arctan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1]))
    c, s = np.cos(angle), np.sin(angle)
    rotation = np.array([[c, -s], [s, c]])
    return angle, mt - rotation @ ms


def agreement(estimate: Sequence[gtsam.Pose2], reference: Sequence[gtsam.Pose2]) -> dict:
    """Position errors (m) after aligning ``estimate`` to ``reference`` (one pose per scan, in
    the same order): RMSE, 95th percentile and maximum; heading errors (deg): RMSE and maximum;
    the scale of the best similarity alignment (how much longer the reference is) and the
    position RMSE it leaves."""
    est, ref = pose_array(estimate), pose_array(reference)
    if len(est) != len(ref) or len(est) == 0:
        raise ValueError(f"agreement: {len(est)} estimated poses for {len(ref)} reference poses")
    angle, shift = se2_alignment(est[:, :2], ref[:, :2])
    c, s = np.cos(angle), np.sin(angle)
    rotated = est[:, :2] @ np.array([[c, s], [-s, c]])
    error = np.linalg.norm(rotated + shift - ref[:, :2], axis=1)
    heading = np.degrees(np.abs(np.angle(np.exp(1j * (est[:, 2] + angle - ref[:, 2])))))
    # the similarity's scale (Umeyama): the rotation is the rigid one's, the scale the least-squares
    # fit of the centred, rotated estimate to the centred reference
    centred, target = rotated - rotated.mean(axis=0), ref[:, :2] - ref[:, :2].mean(axis=0)
    spread = float(np.sum(centred ** 2))
    scale = float(np.sum(centred * target) / spread) if spread > 0 else 1.0
    similar = np.linalg.norm(scale * centred - target, axis=1)
    return {"rmse_m": float(np.sqrt(np.mean(error ** 2))), "p95_m": float(np.percentile(error, 95)),
            "max_m": float(error.max()), "rot_rmse_deg": float(np.sqrt(np.mean(heading ** 2))),
            "rot_max_deg": float(heading.max()), "scale": scale,
            "similarity_rmse_m": float(np.sqrt(np.mean(similar ** 2))), "poses": len(est)}
