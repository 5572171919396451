"""slamlib.course: the course's own machinery; it imports the library, never the reverse.

- ``widgets``  interactive figures that also leave their default figure as a static output
"""
