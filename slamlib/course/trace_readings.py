"""Every reading of a trace in flat arrays, by status (chapters 03, 05, 09).

A :class:`slamlib.runner.Trace` keeps one :class:`slamlib.ekf.UpdateReport`
per camera frame (``trace.reports``, a list of ``(t, report)``). The chapters
ask questions across all frames at once (how many readings were rejected, the
d2 of every gated reading against time, when a marker was seen): instead of a
loop over the reports in every cell, :func:`trace_readings` lays the readings
end to end, one entry per reading, in the order the filter got them::

    rd = trace_readings(trace)
    rd.d2[rd.gated]            # every gated reading's d2
    rd.t[rd.accepted]          # when a reading was fused
    rd.ids[rd.new]             # the ids in the order they were mapped
    rd.counts()                # {"accepted": ..., "rejected": ..., "new": ...}
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..ekf import STATUSES

__all__ = ["TraceReadings", "trace_readings"]


@dataclass(frozen=True)
class TraceReadings:
    """The readings of all the frames of a trace, one entry each (M readings, F frames).

    Attributes
    ----------
    t : numpy.ndarray, shape (M,)
        Time of the frame the reading came in.
    frame : numpy.ndarray of int, shape (M,)
        Index of that frame in ``trace.reports``.
    ids : numpy.ndarray of int, shape (M,)
        The marker id as read (-1 for readings without ids, chapter 09).
    z : numpy.ndarray, shape (M, 2)
        The reading ``[range, bearing]``.
    status : numpy.ndarray of str, shape (M,)
        ``"accepted"``, ``"rejected"``, ``"new"``... (:data:`slamlib.ekf.STATUSES`,
        and ``"candidate"`` for the confirmed filter of chapter 05).
    d2 : numpy.ndarray, shape (M,)
        Squared Mahalanobis distance against the prior; NaN where not gated.
    matched : numpy.ndarray of int, shape (M,)
        The map id the reading was fused into or added as, -1 when not used.
    frame_t : numpy.ndarray, shape (F,)
        The time of every frame (with or without readings).
    """

    t: np.ndarray
    frame: np.ndarray
    ids: np.ndarray
    z: np.ndarray
    status: np.ndarray
    d2: np.ndarray
    matched: np.ndarray
    frame_t: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    def is_(self, status: str) -> np.ndarray:
        """bool (M,): the readings with that status."""
        return self.status == status

    @property
    def accepted(self) -> np.ndarray:
        """bool (M,): fused in their frame's joint update."""
        return self.is_("accepted")

    @property
    def rejected(self) -> np.ndarray:
        """bool (M,): failed the gate."""
        return self.is_("rejected")

    @property
    def new(self) -> np.ndarray:
        """bool (M,): added a landmark."""
        return self.is_("new")

    @property
    def gated(self) -> np.ndarray:
        """bool (M,): went through the gate (have a d2): accepted or rejected."""
        return np.isfinite(self.d2)

    def counts(self) -> dict[str, int]:
        """How many readings have each status that occurs, in the order of ``STATUSES``."""
        order = list(STATUSES) + sorted(set(self.status.tolist()) - set(STATUSES))
        return {s: int(np.count_nonzero(self.status == s)) for s in order
                if np.any(self.status == s)}

    def frames_with(self, status: str) -> np.ndarray:
        """Times of the frames with at least one reading of that status, in order."""
        return self.frame_t[np.unique(self.frame[self.is_(status)])]


def trace_readings(trace) -> TraceReadings:
    """Lay the readings of every frame of a trace end to end (chapters 03, 05, 09).

    Parameters
    ----------
    trace : slamlib.runner.Trace or list of (t, UpdateReport)
        A trace, or its ``reports``.

    Returns
    -------
    TraceReadings
    """
    reports = getattr(trace, "reports", trace)
    try:
        pairs = [(float(t), rep) for t, rep in reports]
    except (TypeError, ValueError) as exc:
        raise ValueError("trace: expected a Trace or a list of (t, UpdateReport)") from exc
    sizes = np.array([len(rep) for _, rep in pairs], dtype=np.int64)
    frame_t = np.array([t for t, _ in pairs], dtype=float)
    if sizes.sum() == 0:
        return TraceReadings(t=np.zeros(0), frame=np.zeros(0, dtype=np.int64),
                             ids=np.zeros(0, dtype=np.int64), z=np.zeros((0, 2)),
                             status=np.zeros(0, dtype="<U10"), d2=np.zeros(0),
                             matched=np.zeros(0, dtype=np.int64), frame_t=frame_t)
    full = [rep for _, rep in pairs if len(rep)]
    return TraceReadings(
        t=np.repeat(frame_t, sizes), frame=np.repeat(np.arange(len(pairs)), sizes),
        ids=np.concatenate([np.asarray(r.ids, dtype=np.int64) for r in full]),
        z=np.concatenate([np.asarray(r.z, dtype=float).reshape(-1, 2) for r in full]),
        status=np.concatenate([np.asarray(r.status, dtype=str) for r in full]),
        d2=np.concatenate([np.asarray(r.d2, dtype=float) for r in full]),
        matched=np.concatenate([np.asarray(r.matched, dtype=np.int64) for r in full]),
        frame_t=frame_t)
