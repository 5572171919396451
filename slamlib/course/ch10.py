"""Chapter 10's helpers (real robots): noise identified from the MRCLAM logs, the logs
loaded with it, the readings' statuses of a trace. Its checker is in
:mod:`slamlib.course.checkers_ch10`, its figures in :mod:`slamlib.course.plots_ch10`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["identify_from", "load_identified", "reading_statuses"]


def identify_from(logs):
    """Odometry calibration and reading noise identified from ``logs`` (pooled)."""
    from ..datasets import identify

    logs = list(logs)
    cal = identify.calibrate_odometry(logs)
    res = identify.ReadingResiduals.concatenate(identify.reading_residuals(lg) for lg in logs)
    return cal, identify.fit_reading_noise(res), res

def load_identified(folder, robot: int, cal, noise, wheel_base: float = 0.23):
    """Robot ``robot``'s log with the commands calibrated and the identified Q and R(rho)."""
    from ..datasets import mrclam

    return mrclam.load(folder, robot, unknown_barcodes="drop", wheel_base=wheel_base,
                       command_scale=(cal.scale_v, cal.scale_w), command_delay=cal.delay,
                       noise={"Q": cal.Q(wheel_base), **noise.params()})

def reading_statuses(trace) -> np.ndarray:
    """Every reading's status in the order of the log's readings (one update per frame)."""
    return np.array([s for _, rep in trace.reports for s in rep.status])
