"""slamlib.course: the course's own machinery; it imports the library, never the reverse.

- ``widgets``            interactive figures that also leave their default figure as an output
- ``predictions``        predict, then measure: the student commits to a number, the cell measures
- ``filter_checkers``    checkers for the filter the student writes (chapters 03-05, 08)
- ``evidence``           the 100-seed studies behind chapters 02, 03, 05, 07 (``data/evidence``)
- ``plots``              their figures
- ``association_study``  chapter 09's study of ids / NN / JCBB (``data/studies``)
- ``checkers_ch09``      chapter 09's exercise checker (the joint distance)
- ``plots_ch09``         chapter 09's figures
- ``ch10``               chapter 10's exercise checker and helpers (the MRCLAM robots)
- ``graph_study``        chapter 11's study of EKF against batch and iSAM2 (``data/studies``)
- ``graph_mrclam``       chapter 11's EKF / iSAM2 / batch on the MRCLAM robots (``data/studies``)
- ``graph_plots``        chapter 11's figures
- ``graph_exercise``     chapter 11's exercise checker (a covariance into GTSAM's frame)
- ``trace_readings``     a trace's readings end to end in flat arrays, by status, and their counts
- ``update_preview``     an update's innovations, S, d2 and verdicts without applying it
- ``tables``             aligned tables of results (headers, rows, one format per column)
"""
