"""slamlib: the library of the course on feature-based EKF SLAM with ArUco markers.

One module per idea:

- ``validate``     input checks whose errors name the bad argument
- ``models``       wheels, motion, direct and inverse observation, compounding, with Jacobians
- ``frames``       z-up (ROS) data into the course's z-down frame
- ``checks``       finite-difference Jacobians and entry-by-entry comparison
- ``worlds``       marker worlds (JSON): the report's arena and random ones
- ``sim``          the simulated Kobuki: controller, wheels, encoders (its loop compiled)
- ``sensors``      the analytic marker sensor and the readings' type
- ``vision``       the camera (a package): ``camera`` and calibration, ``markers``, ``render`` a
                   view, ``detect`` markers and their pose, the ``noise`` model, the ``sensor``
- ``runs``         recorded runs (CSV + JSON) and their events
- ``ekf``          the EKF, one step per function (predict, stacked H, gate, joint update,
                   augment) and the filters over them: localisation, SLAM, FEJ, ideal (ch. 03-06)
- ``metrics``      NEES, NIS, chi-square bands, trajectory error
- ``runner``       runs a filter over a recorded run: its trace, and the one way to build it
- ``confirmation`` EKF SLAM that maps a new id only after a second consistent sighting (ch. 05)
- ``association``  readings without ids: individual compatibility, nearest neighbour, JCBB (ch. 09)
- ``studies``      Monte-Carlo NEES over seeded runs and the loop closure's re-observation
- ``delay``        late camera frames fused at their capture time by re-prediction (ch. 08)
- ``explore``      closed-loop exploration steered by the SLAM estimate (chapter 07)
- ``graph``        the same runs as a factor graph, smoothed with GTSAM (batch, iSAM2; ch. 11)
- ``datasets``     real data in its original format: the UTIAS MRCLAM robots (``mrclam``) and
                   noise identified against their ground truth (``identify``), chapter 10
- ``course``       the course's own machinery (exercise checkers by chapter and their harness,
                   the report's errata (``errata``), the chapters' figures,
                   ``python -m slamlib.course.figures OUT``, 100-seed studies
                   in ``data/evidence``); the library never imports it
"""

__version__ = "0.1.0"
