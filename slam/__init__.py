"""Pose SLAM: scan-matching odometry, keyframes, loop closures and a GTSAM pose graph.

Modules, in the order a scan flows through them:

- ``scan``: the ``LaserScan`` type.            - ``carmen``: CARMEN log reader and corrected-log writer.
- ``registration``: KISS-ICP coarse to fine + point-to-line refinement, covariance, degeneracy.
- ``front_end``: scan-to-submap odometry with the wheel odometry as prior.
- ``loop_closure``: Pose SLAM candidate gates, verification, pairwise consistency.
- ``back_end``: the iSAM2 pose graph.            - ``pose_slam``: ``PoseSlam.step(odometry, scan)``.
- ``config``: typed configuration.              - ``replay``: a log through Pose SLAM to files.
- ``g2o``: 2-D g2o graphs, χ², optimisation.    - ``evaluation``: Kümmerle et al.'s relation error.
- ``tum``, ``atomic``: output formats and atomic writes.
"""
