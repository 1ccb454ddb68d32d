"""Pose SLAM: scan-matching odometry, keyframes, loop closures and a GTSAM pose graph."""
