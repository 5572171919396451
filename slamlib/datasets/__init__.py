"""Real data sets in their original formats (chapter 10).

- ``mrclam``  the UTIAS Multi-Robot Cooperative Localization and Mapping
  Dataset (Leung et al., IJRR 2011): odometry, barcode readings and Vicon
  truth, brought into the course's z-down frame as a :class:`~slamlib.runs.Run`.
"""
