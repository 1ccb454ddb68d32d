"""The continuous occupancy map (COM) learned by two Gaussian processes, and its baselines."""
