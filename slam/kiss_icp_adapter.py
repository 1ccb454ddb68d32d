"""The one place gpexplore touches KISS-ICP's C++ core: planar wrappers around the private
``kiss_icp.pybind.kiss_icp_pybind`` symbols ``_Vector3dVector``, ``_VoxelHashMap`` (with
``_add_points`` and ``_point_cloud``), ``_voxel_down_sample`` and ``_Registration`` (with
``_align_points_to_map``).

Planar points go in and come out as (n, 2) NumPy arrays (z = 0 inside KISS-ICP); poses are
``gtsam.Pose2`` or KISS-ICP's own 4×4 homogeneous matrices. Those private names are not KISS-ICP's
public API and may change between releases; if an upgrade breaks them, this file is the only one
to fix. Tested with kiss-icp 1.3.0 (pyproject pins ``kiss-icp>=1.0,<2``).
"""

from __future__ import annotations

import gtsam
import numpy as np
from kiss_icp.pybind import kiss_icp_pybind


def pose_matrix(pose: gtsam.Pose2) -> np.ndarray:
    """The 4×4 homogeneous matrix of a planar pose (KISS-ICP's pose type)."""
    c, s = np.cos(pose.theta()), np.sin(pose.theta())
    m = np.eye(4)
    m[:2, :2] = [[c, -s], [s, c]]
    m[:2, 3] = pose.x(), pose.y()
    return m


def matrix_pose(m: np.ndarray) -> gtsam.Pose2:
    """The planar pose (x, y, yaw) of a 4×4 homogeneous matrix."""
    return gtsam.Pose2(m[0, 3], m[1, 3], np.arctan2(m[1, 0], m[0, 0]))


def _xyz(points: np.ndarray) -> kiss_icp_pybind._Vector3dVector:
    """(n, 2) planar points as KISS-ICP's 3-D point vector, z = 0."""
    return kiss_icp_pybind._Vector3dVector(np.column_stack([points, np.zeros(len(points))]))


def voxel_down_sample(points: np.ndarray, size: float) -> np.ndarray:
    """(m, 2) of the (n, 2) ``points``: the first point falling in each voxel of ``size`` m, an
    exact copy, one per occupied voxel (in KISS-ICP's hash order, not the input order)."""
    return np.asarray(kiss_icp_pybind._voxel_down_sample(_xyz(points), size))[:, :2].reshape(-1, 2)


class VoxelMap:
    """KISS-ICP's voxel hash map of planar points: at most ``max_points_per_voxel`` points per
    voxel of ``voxel_size`` m, and (kiss-icp 1.x) a point closer than voxel_size / √max_points_per_voxel
    to one already in its voxel is dropped; nothing is ever removed for being far away."""

    def __init__(self, voxel_size: float, max_points_per_voxel: int):
        self.voxel_size = voxel_size
        self._map = kiss_icp_pybind._VoxelHashMap(voxel_size=voxel_size, max_distance=1e9,
                                                 max_points_per_voxel=max_points_per_voxel)

    def add(self, points: np.ndarray) -> None:
        """Insert (n, 2) points (a full voxel ignores further points)."""
        self._map._add_points(_xyz(points))

    def points(self) -> np.ndarray:
        """(m, 2) points held by the map."""
        return np.asarray(self._map._point_cloud())[:, :2].reshape(-1, 2)


class Icp:
    """KISS-ICP's point-to-point ICP with a Geman–McClure kernel, single-threaded.

    Args:
        max_iterations: Gauss–Newton iterations at most per alignment.
        convergence: stop when a step's norm is below this.
        threads: KISS-ICP worker threads (1 keeps the results deterministic and cheap).
    """

    def __init__(self, max_iterations: int, convergence: float, threads: int = 1):
        self._registration = kiss_icp_pybind._Registration(max_num_iterations=max_iterations,
                                                           convergence_criterion=convergence,
                                                           max_num_threads=threads)

    def align_matrix(self, points: np.ndarray, voxel_map: VoxelMap, initial: np.ndarray | gtsam.Pose2,
                     max_correspondence: float, kernel: float) -> np.ndarray:
        """The 4×4 pose of the (n, 2) ``points`` (their frame) in the map frame, from ``initial``.
        Chain levels with this one: a 4×4 estimate passed on unchanged is not rounded through
        a yaw angle between levels."""
        if isinstance(initial, gtsam.Pose2):
            initial = pose_matrix(initial)
        return self._registration._align_points_to_map(
            points=_xyz(points), voxel_map=voxel_map._map, initial_guess=initial,
            max_correspondance_distance=max_correspondence, kernel=kernel)

    def align(self, points: np.ndarray, voxel_map: VoxelMap, initial: np.ndarray | gtsam.Pose2,
              max_correspondence: float, kernel: float) -> gtsam.Pose2:
        """The planar pose of the (n, 2) ``points`` in the map frame, from ``initial`` (a Pose2
        or 4×4); correspondences farther than ``max_correspondence`` m are ignored and ``kernel``
        (m) is the robust kernel's scale."""
        return matrix_pose(self.align_matrix(points, voxel_map, initial, max_correspondence, kernel))
