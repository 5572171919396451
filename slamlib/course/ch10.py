"""Chapter 10's helpers (real robots): the readings' statuses of a trace. The identification
itself is the library's (:func:`slamlib.datasets.identify.identify`, applied by
``mrclam.load(..., calibration=cal)``); its held-out test is
:mod:`slamlib.course.mrclam_heldout`, its checker :mod:`slamlib.course.checkers_ch10`, its
figures :mod:`slamlib.course.plots_ch10`.

:func:`identify_from` and :func:`load_identified` are the names chapter 11's notebook used
before the library had the API; they call it (nothing of their own).
"""

from __future__ import annotations

import numpy as np

__all__ = ["identify_from", "load_identified", "reading_statuses"]


def identify_from(logs):
    """``(cal, fit, res)``: :func:`identify.identify` of ``logs``, the pooled reading fit and
    its residuals (the old name of the library's API; chapter 11 calls it)."""
    from ..datasets import identify

    logs = list(logs)
    res = identify.ReadingResiduals.concatenate(identify.reading_residuals(lg) for lg in logs)
    return identify.identify(logs), identify.fit_reading_noise(res), res


def load_identified(folder, robot: int, cal, noise=None, wheel_base: float = 0.23):
    """``mrclam.load(folder, robot, calibration=cal)`` (the old name; ``noise`` is ignored:
    the calibration carries it)."""
    from ..datasets import mrclam

    return mrclam.load(folder, robot, calibration=cal, wheel_base=wheel_base)


def reading_statuses(trace) -> np.ndarray:
    """Every reading's status in the order of the log's readings (one update per frame)."""
    return np.array([s for _, rep in trace.reports for s in rep.status])
