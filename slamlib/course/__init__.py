"""slamlib.course: the course's own machinery; it imports the library, never the reverse.

- ``widgets``  interactive figures that also leave their default figure as a static output
- ``filter_checkers``  checkers of the filter the student writes: block prediction, stacked H,
  joint update, augmentation, NEES of a trace, the verdict over N runs
- ``predictions``  predict, then measure: a committed expectation against a measurement
"""
