"""The course's own machinery: chapter studies, exercise checkers and chapter plots.

It imports the library (:mod:`slamlib`); the library never imports it.

- ``graph_study``     chapter 11: EKF SLAM against batch and iSAM2 smoothing over 100 seeds
- ``graph_plots``     chapter 11's figures (the factor graph, sparsity, NEES, cost per step)
- ``graph_exercise``  chapter 11's exercise checker (a covariance into GTSAM's frame)
"""
