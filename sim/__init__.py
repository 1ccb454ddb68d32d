"""Worlds, lidar and robot simulation, closed-loop runs and the `gpexplore` command line."""
