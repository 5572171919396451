"""slamlib: the library of the course on feature-based EKF SLAM with ArUco markers.

Modules (one idea each):

- ``validate``  input checks that name the bad argument
- ``models``    wheels, motion, direct and inverse observation, compounding, with Jacobians
- ``frames``    z-up (ROS) data into the course's z-down frame
"""

__version__ = "0.1.0"
