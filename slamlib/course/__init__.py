"""slamlib.course: the course's own machinery; it imports the library, never the reverse.

The chapters' exercise checkers and figures, one module per chapter, in chapter order:

- ``harness``            the harness every exercise checker shares (call, shapes, verdicts, hints)
- ``checkers_ch00`` ... ``checkers_ch11``, ``checkers_appendix_a``
                         each chapter's exercise checker (chapter 09: the joint distance;
                         10: wheel speeds from commands; 11: a covariance into GTSAM's frame)
- ``filter_checkers``    checkers for the filter the student writes (chapters 03-05, 08)
- ``predictions``        predict, then measure: the student commits to a number, the cell measures
- ``plots``              the figure primitives every chapter shares (top views z-down seen from
                         above, ellipses, a filter's trace and its errors)
- ``plots_ch00`` ... ``plots_ch11``
                         each chapter's figures
- ``widgets``            interactive figures that also leave their default figure as an output
- ``figures``            ``python -m slamlib.course.figures OUT``: every figure as files
- ``errata``             the report's equations as printed, and the checks that expose its errors

Studies and chapter helpers:

- ``evidence``           the 100-seed studies behind chapters 02, 03, 05, 07 (``data/evidence``)
- ``stored``             reading the stored studies (one loader, naming the make target)
- ``studies_ch06``       chapter 06's studies: marker density, the stored Monte-Carlo, observability
- ``association_study``  chapter 09's study of ids / NN / JCBB (``data/studies``)
- ``ch10``               chapter 10's helpers: noise identified from the MRCLAM logs, logs loaded
                         with it
- ``graph_study``        chapter 11's study of EKF against batch and iSAM2 (``data/studies``)
- ``graph_mrclam``       chapter 11's EKF / iSAM2 / batch on the MRCLAM robots (``data/studies``)
- ``trace_readings``     a trace's readings end to end in flat arrays, by status, and their counts
- ``tables``             aligned tables of results (headers, rows, one format per column)
- ``listings``           library source as a chapter prints it: the running code minus its docstring
- ``inline_figures``     a notebook's figures as pixel-doubled PNGs (called on import, below)
"""

from slamlib.course.inline_figures import sharp_inline_figures

sharp_inline_figures()
