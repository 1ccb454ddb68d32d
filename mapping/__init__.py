"""The continuous occupancy map (COM) learned by two Gaussian processes, and its baselines.

    com.py       ContinuousOccupancyMap: update(pose, scan) (Algorithm 1, lines 1-17),
                 regenerate(keyframes) (Section VII); Λ, Λo, Λf and their variances
    config.py    COMConfig, typed and grouped (kernels, training, query, squash, drift)
    training.py  a keyframe's hits and free points along the beams (Section IV-A)
    kernels.py   Matérn (eq. 5), squared exponential (eq. 6)
    gp.py        exact GP (eqs. 3-4), marginal-likelihood fit of the hyperparameters
    localgp.py   the hot path: many small local GPs in one compiled pass
    squash.py    logistic squashing with confidence weights (eq. 7)
    fusion.py    Bayesian Committee Machine fusion (eqs. 8-9)
    drift.py     Jensen-Shannon divergence (eqs. 12-13), cumulated drift monitor
    grid.py      the frame of a growing map grid
    logodds.py   the log-odds occupancy grid baseline
    metrics.py   ROC AUC, coverage, map entropy (defined once, for runs, maps and tests)
    holdout.py   held-out evaluation protocols on real logs
    export.py    com.npz and ROS map_server PGM + YAML
    measured.py  a COM that keeps its test points and timings (log mapping)
    occupancy.py the map interface the stack and the explorer use (MapSnapshot)
    figure.py    the paper's Fig. 2 panels
"""
