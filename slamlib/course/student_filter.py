"""The student's own EKF SLAM over a recorded run (chapter 05).

:func:`drive` runs the equations the student wrote in the exercises
(``predict_covariance``, ``stacked_jacobian``, ``joint_update``, ``augment``:
the signatures of :mod:`slamlib.ekf_textbook` and of the checkers in
:mod:`slamlib.course.filter_checkers`) over a run's events, as
:func:`slamlib.runner.slam` runs :class:`slamlib.ekf.EKFSLAM`: the same
events, Q, P0, per-reading R and gate. Each student function is first put
through its checker (silently); one that does not pass yet (a stub, not
written, or not right) is replaced by the textbook's, and the driver says so,
so that the chapter runs top to bottom in the student edition.
:func:`difference` gives the largest difference to the library's filter.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .. import ekf_textbook as tb
from ..ekf import gate_threshold
from ..models import motion_jacobians, motion_model
from ..runner import DEFAULT_P0, Trace, TraceRecorder, reading_covariances, sensor_noise
from ..runs import Run
from .filter_checkers import (
    check_augment,
    check_joint_update,
    check_predict_covariance,
    check_stacked_jacobian,
)

__all__ = ["StudentSLAM", "drive", "difference", "choose"]

_PARTS = (("predict_covariance", check_predict_covariance),
          ("stacked_jacobian", check_stacked_jacobian),
          ("joint_update", check_joint_update),
          ("augment", check_augment))


class StudentSLAM:
    """The state of the student's filter: ``x``, ``P`` and the id -> slot map, read like
    :class:`slamlib.ekf.EKFSLAM` (``pose``, ``pose_cov``, ``landmarks``, ``landmark_cov``)."""

    def __init__(self, x: np.ndarray, P: np.ndarray):
        self.x = np.array(x, dtype=float)
        self.P = np.array(P, dtype=float)
        self.index: dict[int, int] = {}
        self.functions: dict[str, Callable] = {}

    @property
    def pose(self) -> np.ndarray:
        return self.x[:3].copy()

    @property
    def pose_cov(self) -> np.ndarray:
        return self.P[:3, :3].copy()

    @property
    def landmark_ids(self) -> list[int]:
        return list(self.index)

    @property
    def n_landmarks(self) -> int:
        return len(self.index)

    @property
    def landmarks(self) -> dict[int, np.ndarray]:
        return {mid: self.x[s:s + 2].copy() for mid, s in self.index.items()}

    def landmark_cov(self, marker_id: int) -> np.ndarray:
        s = self.index[int(marker_id)]
        return self.P[s:s + 2, s:s + 2].copy()


def choose(verbose: bool = True, **functions) -> dict[str, Callable]:
    """The functions the drive uses: each student function that passes its checker, else
    the textbook's (:mod:`slamlib.ekf_textbook`), with one line saying which.

    Keyword arguments: ``predict_covariance``, ``stacked_jacobian``, ``joint_update``,
    ``augment`` (None: the textbook's).
    """
    unknown = set(functions) - {p for p, _ in _PARTS}
    if unknown:
        raise ValueError(f"functions: expected some of {[p for p, _ in _PARTS]}, "
                         f"got {sorted(unknown)}")
    out = {}
    for part, checker in _PARTS:
        fn = functions.get(part)
        name = getattr(fn, "__name__", part)
        if fn is not None and checker(fn, verbose=False):
            out[part] = fn
            line = f"{part:19s} yours ({name}, passes {checker.__name__})"
        else:
            out[part] = getattr(tb, part)
            why = "not given" if fn is None else (f"{name} does not pass {checker.__name__} yet "
                                                  "(not written yet, or not right)")
            line = f"{part:19s} slamlib.ekf_textbook.{part}: {why}"
        if verbose:
            print(line)
    return out


def _update(f: StudentSLAM, ids, z, R, threshold: float, fn: dict) -> None:
    """One camera frame: :func:`slamlib.ekf_textbook.update` with the chosen functions."""
    x, P, f.index, _ = tb.update(f.x, f.P, f.index, ids, z, R, threshold,
                                 stacked_jacobian=fn["stacked_jacobian"],
                                 joint_update=fn["joint_update"], augment=fn["augment"])
    f.x, f.P = np.asarray(x, dtype=float), np.asarray(P, dtype=float)


def drive(run: Run, *, predict_covariance=None, stacked_jacobian=None, joint_update=None,
          augment=None, gate: float | None = 0.95, max_time: float | None = None,
          verbose: bool = True) -> Trace:
    """Run the student's EKF SLAM over ``run`` (chapter 05) and record its :class:`Trace`.

    Same events (capture time), Q (``run.Q()``), P0 and per-reading R
    (``sensor.R(range)``) as :func:`slamlib.runner.slam`; the prediction is
    ``x_B <- f(x_B, u)`` with ``P`` by ``predict_covariance(P, A, W, Q)``, each
    frame as :func:`slamlib.ekf_textbook.update` with ``stacked_jacobian``,
    ``joint_update`` and ``augment``. Functions that do not pass their checker
    are replaced by the textbook's (:func:`choose`, which prints the choice).

    Returns
    -------
    Trace
        ``trace.filter`` is the final :class:`StudentSLAM` (its ``functions``:
        what was used); ``trace.reports`` is empty.
    """
    fn = choose(verbose, predict_covariance=predict_covariance, stacked_jacobian=stacked_jacobian,
                joint_update=joint_update, augment=augment)
    Q, wb = run.Q(), run.wheel_base
    threshold = gate_threshold(gate)
    sensor = sensor_noise(run)
    f = StudentSLAM(run.start_pose, DEFAULT_P0)
    f.functions = fn
    rec = TraceRecorder(run.enc_t[0], f)
    for kind, t, obs, ctl in run._merged_events("capture"):
        if max_time is not None and t > max_time:
            break
        if kind == 0:
            u, dt = ctl
            A, W = motion_jacobians(f.x[:3], u, dt, wb)
            x = f.x.copy()
            x[:3] = motion_model(x[:3], u, dt, wb)
            f.x, f.P = x, np.asarray(fn["predict_covariance"](f.P, A, W, Q), dtype=float)
        else:
            if len(obs) == 0:
                continue
            z = np.asarray(obs.z, dtype=float).reshape(-1, 2)
            R = np.broadcast_to(reading_covariances(sensor, z), (len(z), 2, 2))
            _update(f, obs.ids, z, R, threshold, fn)
        rec.record(t, "predict" if kind == 0 else "update", f)
    return rec.trace(run, f)


def difference(mine: Trace, library: Trace) -> dict[str, float]:
    """The largest differences between two SLAM traces of the same run: the pose after every
    event, the final state (landmarks in the same order) and the final covariance."""
    if mine.t.shape != library.t.shape or not np.array_equal(mine.t, library.t):
        raise ValueError("mine, library: expected traces of the same events "
                         f"({mine.t.size} and {library.t.size} events)")
    a, b = mine.filter, library.filter
    if list(a.landmark_ids) != list(b.landmark_ids):
        raise ValueError(f"mine, library: the maps differ ({a.landmark_ids} vs {b.landmark_ids})")
    return {"pose": float(np.max(np.abs(mine.x - library.x))),
            "pose_cov": float(np.max(np.abs(mine.P - library.P))),
            "state": float(np.max(np.abs(a.x - b.x))),
            "cov": float(np.max(np.abs(a.P - b.P)))}
