"""slamlib.course: the course's own machinery; it imports the library, never the reverse.

- ``harness``            the harness every exercise checker shares (call, shapes, verdicts, hints)
- ``checkers_ch00`` ... ``checkers_ch08``, ``checkers_appendix_a``
                         the chapters' exercise checkers, one module per chapter
- ``plots``              the figure primitives every chapter shares (top views z-down seen from
                         above, ellipses, a filter's trace and its errors)
- ``plots_ch00`` ... ``plots_ch08``
                         the chapters' figures, one module per chapter (none for 01)
- ``figures``            ``python -m slamlib.course.figures OUT``: every figure as files
- ``errata``             the report's equations as printed, and the checks that expose its errors
- ``widgets``            interactive figures that also leave their default figure as an output
- ``predictions``        predict, then measure: the student commits to a number, the cell measures
- ``filter_checkers``    checkers for the filter the student writes (chapters 03-05, 08)
- ``evidence``           the 100-seed studies behind chapters 02, 03, 05, 07 (``data/evidence``)
- ``association_study``  chapter 09's study of ids / NN / JCBB (``data/studies``)
- ``checkers_ch09``      chapter 09's exercise checker (the joint distance)
- ``plots_ch09``         chapter 09's figures
- ``ch10``               chapter 10's exercise checker and helpers (the MRCLAM robots)
- ``graph_study``        chapter 11's study of EKF against batch and iSAM2 (``data/studies``)
- ``graph_mrclam``       chapter 11's EKF / iSAM2 / batch on the MRCLAM robots (``data/studies``)
- ``plots_ch11``         chapter 11's figures
- ``graph_exercise``     chapter 11's exercise checker (a covariance into GTSAM's frame)
"""
