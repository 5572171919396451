"""Running a filter over a recorded run, and what comes out (chapters 01, 03, 05, 06, 08).

Every chapter and the figure script drive the filters the same way: start at
the run's first true pose, predict with the encoders' wheel speeds, update
with each camera frame, and record the robot's estimate and covariance after
every event next to the truth. This module does exactly that, once.

- :func:`dead_reckoning` predicts only (the report's Fig. 4);
- :func:`localization` runs the map-based EKF on the world's true map (Figs. 5, 6);
- :func:`slam` runs EKF SLAM (Figs. 7, 8);
- :func:`run_filter` is the loop they share, for any filter built by hand; with
  ``until=t`` it stops just before the first camera frame at or after ``t`` and
  hands that frame back (:class:`PendingFrame`), so that a chapter can look at
  one update in detail (chapter 05).

Each returns a :class:`Trace`, whose :meth:`Trace.metrics` gives the numbers
the figure script prints (ATE, mean NEES, landmarks mapped, map error).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .ekf import EKFSLAM, FEJEKFSLAM, EKFLocalization, IdealEKFSLAM, UpdateReport
from .metrics import ate, nees, pose_error
from .models import wrap_angle
from .runs import Run

__all__ = ["Trace", "PendingFrame", "TraceRecorder", "reading_covariances", "run_filter",
           "make_filter", "default_R",
           "dead_reckoning", "localization", "slam", "fej_slam", "ideal_slam", "truth_function",
           "sensor_noise", "map_error", "DEFAULT_P0", "DEFAULT_R"]

#: Initial pose covariance: the robot starts where the map's frame is defined.
DEFAULT_P0 = np.diag([1e-6, 1e-6, 1e-6])
#: The filter's R slot when no reading is ever fused (dead reckoning, a run without readings);
#: never a silent default for readings (5 cm, 2 deg).
DEFAULT_R = np.diag([0.05**2, np.radians(2.0) ** 2])


@dataclass(frozen=True)
class PendingFrame:
    """The camera frame at which :func:`run_filter` stopped (``until``), not yet fused.

    Attributes
    ----------
    t : float
        Its time (capture or arrival, as the run was driven).
    obs : slamlib.sensors.Observations
        Its readings (``obs.ids``, ``obs.z``...).
    R : numpy.ndarray (k, 2, 2) or None
        Each reading's covariance as :func:`run_filter` would have passed it to
        ``update`` (None when the filter's own R is used).
    """

    t: float
    obs: object
    R: np.ndarray | None


@dataclass
class Trace:
    """The robot's estimate after every event of a run, with the truth beside it.

    Attributes
    ----------
    t : numpy.ndarray (N,)
        Event times (s): the start, then each prediction and each update.
    kind : numpy.ndarray of str (N,)
        ``"start"``, ``"predict"`` or ``"update"``.
    x : numpy.ndarray (N, 3)
        Estimated pose after the event.
    P : numpy.ndarray (N, 3, 3)
        Its covariance.
    truth : numpy.ndarray (N, 3)
        True pose at the event's time.
    reports : list of (float, UpdateReport)
        Every update's report with its time.
    filter : EKFLocalization or EKFSLAM
        The filter in its final state.
    pending : PendingFrame or None
        With ``run_filter(..., until=t)``: the frame it stopped before (None
        when the run ended first, or without ``until``).
    """

    t: np.ndarray
    kind: np.ndarray
    x: np.ndarray
    P: np.ndarray
    truth: np.ndarray
    reports: list = field(default_factory=list)
    filter: object = None
    pending: PendingFrame | None = None

    @property
    def error(self) -> np.ndarray:
        """Estimate minus truth, heading wrapped, shape (N, 3)."""
        return pose_error(self.x, self.truth)

    @property
    def sigma(self) -> np.ndarray:
        """Standard deviations of x, y, theta, shape (N, 3)."""
        return np.sqrt(np.maximum(np.diagonal(self.P, axis1=1, axis2=2), 0.0))

    @property
    def nees(self) -> np.ndarray:
        """NEES of the pose after every event, shape (N,) (3 degrees of freedom)."""
        return nees(self.error, self.P)

    def nis(self) -> tuple[np.ndarray, np.ndarray]:
        """The joint NIS of every update that fused something, and its degrees of freedom."""
        vals, dofs = [], []
        for _, rep in self.reports:
            if rep.n_accepted:
                vals.append(rep.joint_nis)
                dofs.append(2 * rep.n_accepted)
        return np.array(vals), np.array(dofs, dtype=int)

    def counts(self) -> dict[str, int]:
        """How many readings ended in each status (accepted, rejected, new...)."""
        out: dict[str, int] = {}
        for _, rep in self.reports:
            for s in rep.status:
                out[s] = out.get(s, 0) + 1
        return out

    def metrics(self, world=None) -> dict[str, float]:
        """ATE (m, rad), mean pose NEES and, for SLAM with a world, the map's figures."""
        a = ate(self.x, self.truth)
        out = {"ate_xy": float(a.position), "ate_theta": float(a.heading),
               "mean_nees": float(np.mean(self.nees)),
               "final_xy_error": float(np.hypot(*self.error[-1, :2]))}
        if isinstance(self.filter, EKFSLAM):
            out["landmarks"] = float(self.filter.n_landmarks)
            if world is not None:
                out["map_rmse"] = map_error(self.filter, world)[0]
        return out


def reading_covariances(sensor, z) -> np.ndarray | None:
    """Each reading's covariance ``sensor.R(range)``, stacked (k, 2, 2); None without a sensor."""
    if sensor is None:
        return None
    rho = np.asarray(z, dtype=float)[:, 0]
    batch = getattr(sensor, "R_batch", None)
    if batch is not None:
        return batch(rho)
    return np.stack([sensor.R(r) for r in rho])


class TraceRecorder:
    """Collects a filter's pose estimate and covariance after each event, then makes the
    :class:`Trace` (one place for what every driver of a filter records).

    The poses and covariances go into arrays that double when full (as the filter's own
    storage does): a run of thousands of events keeps three arrays, not thousands of small
    ones."""

    def __init__(self, t0: float, filt, capacity: int = 1024):
        self._n, capacity = 0, max(1, int(capacity))
        self._t, self._x, self._P = (np.empty(capacity), np.empty((capacity, 3)),
                                     np.empty((capacity, 3, 3)))
        self.kind: list[str] = []
        self.reports: list[tuple[float, UpdateReport]] = []
        self.record(t0, "start", filt)

    def record(self, t: float, kind: str, filt, report: UpdateReport | None = None) -> None:
        """Log the filter's pose after an event at time ``t`` (and the update's report)."""
        i = self._n
        if i == self._t.shape[0]:                                   # full: double the storage
            self._t, self._x, self._P = (np.concatenate([a, np.empty_like(a)])
                                         for a in (self._t, self._x, self._P))
        self._t[i], self._x[i], self._P[i] = t, filt.pose, filt.pose_cov
        self._n = i + 1
        self.kind.append(kind)
        if report is not None:
            self.reports.append((float(t), report))

    def trace(self, run: Run, filt, **extra) -> Trace:
        """The :class:`Trace`, with the run's truth at the logged times."""
        n = self._n
        t = self._t[:n].copy()
        return Trace(t=t, kind=np.array(self.kind), x=self._x[:n].copy(), P=self._P[:n].copy(),
                     truth=run.truth_at(t), reports=self.reports, filter=filt, **extra)


def run_filter(run: Run, filt, *, by: str = "capture", use_sensor_R: bool = True,
               use_run_Q_steps: bool = True, max_time: float | None = None,
               until: float | None = None) -> Trace:
    """Drive ``filt`` through ``run``'s events and record a :class:`Trace`.

    Parameters
    ----------
    run : Run
        The recorded run.
    filt : EKFLocalization or EKFSLAM
        The filter, already initialised (usually at ``run.start_pose``).
    by : {"capture", "arrival"}
        When camera frames reach the filter (:meth:`Run.events`).
    use_sensor_R : bool
        Give each reading the covariance ``sensor.R(range)`` of the run's
        sensor (it grows with range); otherwise the filter's own R.
    use_run_Q_steps : bool
        Give each step the covariance of ``u`` the run gives it
        (:meth:`Run.Q_steps`: a real log's noise density, chapter 10), when
        it gives one (then ``filt.predict`` is called as ``predict(u, dt, Q)``);
        otherwise the filter's own Q at every step (``predict(u, dt)``).
    max_time : float, optional
        Stop after this time (s).
    until : float, optional
        Stop just BEFORE the first camera frame with readings at or after this
        time (s): the filter holds the prior of that frame, which is returned
        unfused in ``trace.pending`` (with the R it would have been given), so
        that ``trace.filter.update(p.obs.ids, p.obs.z, R=p.R)`` is the next step.
    """
    sensor = sensor_noise(run) if use_sensor_R else None
    pending = None
    rec = TraceRecorder(run.enc_t[0], filt)
    u_all, dt_all, events = run._event_blocks(by)      # the events of run.events(by)
    Q_all = run.Q_steps(dt_all) if use_run_Q_steps else None   # None: the filter's own Q
    dt_all = dt_all.tolist()
    # each reading's R = sensor.R(range), for all the run's readings at once
    cam = run.camera
    R_rows = reading_covariances(sensor, np.column_stack([cam.rho, cam.bearing]))
    for event in events:
        if event[0] == 0:                               # the predictions up to the next frame
            _, j0, j1, times = event
            for j, t in zip(range(j0, j1), times):
                if max_time is not None and t > max_time:
                    return rec.trace(run, filt, pending=pending)
                if Q_all is None:                     # the filter's own Q
                    filt.predict(u_all[j], dt_all[j])
                else:                                 # this step's own Q (chapter 10)
                    filt.predict(u_all[j], dt_all[j], Q_all[j])
                rec.record(t, "predict", filt)
            continue
        _, t, obs, r0 = event
        if max_time is not None and t > max_time:
            break
        if len(obs) == 0:
            continue
        R = None if R_rows is None else R_rows[r0:r0 + len(obs)]
        if until is not None and t >= until - 1e-9:
            pending = PendingFrame(float(t), obs, R)
            break
        rec.record(t, "update", filt, filt.update(obs.ids, obs.z, R=R))
    return rec.trace(run, filt, pending=pending)


def sensor_noise(run: Run):
    """The noise model of the sensor that made ``run``'s readings (an object with ``R(rho)``),
    rebuilt from the run's meta; None when the meta does not say.

    The analytic sensor (:meth:`Run.sensor`), or for a run recorded through the
    camera pipeline (``vision.CameraMarkerSensor``) the noise model it was
    given (:class:`slamlib.vision.NoiseModel`, whose ``R(rho)`` the sensor uses).
    """
    sensor = run.sensor()
    if sensor is not None:
        return sensor
    d = run.meta.get("sensor") or {}
    if d.get("type") == "CameraMarkerSensor" and isinstance(d.get("noise_model"), dict):
        from .vision import NoiseModel

        return NoiseModel(**d["noise_model"])
    return None


def default_R(run: Run, *, needed: bool = True) -> np.ndarray:
    """The filter's default reading covariance for ``run``: its sensor's ``R`` at 2 m.

    A run whose readings come from a sensor the meta does not describe gets
    no silent default (issue 9): ValueError, saying what to pass. Without
    readings (or when ``needed`` is False, dead reckoning) no R is ever used;
    :data:`DEFAULT_R` fills the filter's slot.
    """
    noise = sensor_noise(run)
    if noise is not None:
        return noise.R(2.0)
    if not needed or len(run.camera) == 0:
        return DEFAULT_R
    kind = (run.meta.get("sensor") or {}).get("type", "not recorded")
    raise ValueError(f"R: run {run.name!r} has {len(run.camera)} readings from a sensor whose "
                     f"noise model the run does not give (sensor type: {kind}); pass R=<2x2 "
                     f"covariance of a reading [range, bearing]> (it is then used for every "
                     f"reading)")


def make_filter(cls, run: Run, *, Q=None, P0=DEFAULT_P0, R=None, gate: float | None = 0.95,
                **options):
    """The course's one way to build a filter for ``run``: ``cls`` at the run's first true pose.

    ``cls(run.start_pose, P0, Q, R, wheel_base=run.wheel_base, gate=gate, **options)``
    with the run's own ``Q`` (:meth:`Run.Q`, its simulated slip) and the R of
    its sensor at 2 m (:func:`default_R`: a ValueError when the run has readings
    from a sensor it does not describe) unless ``Q`` or ``R`` are given.
    ``options`` go to the class (``landmarks=`` for the map-based EKF,
    ``association=``, ``n_confirm=``...). Every runner of this module, chapter
    08's delayed filters and chapter 09's study build their filters here.
    """
    return cls(run.start_pose, P0, run.Q() if Q is None else Q,
               default_R(run) if R is None else R, wheel_base=run.wheel_base, gate=gate,
               **options)


def dead_reckoning(run: Run, *, Q=None, P0=DEFAULT_P0, max_time: float | None = None) -> Trace:
    """Prediction only, from the run's first true pose (chapter 01, the report's Fig. 4)."""
    filt = make_filter(EKFLocalization, run, Q=Q, P0=P0, R=default_R(run, needed=False),
                       landmarks={})
    rec = TraceRecorder(run.enc_t[0], filt)
    u, dt = run.controls()
    Q_all = run.Q_steps(dt) if Q is None else None     # a density's Q_c / dt_k, or None
    for k in range(dt.shape[0]):
        if max_time is not None and run.enc_t[k + 1] > max_time:
            break
        if Q_all is None:
            filt.predict(u[k], dt[k])
        else:
            filt.predict(u[k], dt[k], Q_all[k])
        rec.record(run.enc_t[k + 1], "predict", filt)
    return rec.trace(run, filt)


def localization(run: Run, *, gate: float | None = 0.95, Q=None, P0=DEFAULT_P0, R=None,
                 by: str = "capture", landmarks=None, use_sensor_R: bool = True) -> Trace:
    """The map-based EKF on the run's world (chapter 03, the report's Figs. 5 and 6)."""
    lm = run.world().landmarks() if landmarks is None else landmarks
    filt = make_filter(EKFLocalization, run, Q=Q, P0=P0, R=R, gate=gate, landmarks=lm)
    return run_filter(run, filt, by=by, use_sensor_R=use_sensor_R and R is None,
                      use_run_Q_steps=Q is None)


def slam(run: Run, *, gate: float | None = 0.95, Q=None, P0=DEFAULT_P0, R=None,
         by: str = "capture", use_sensor_R: bool = True, max_time: float | None = None,
         until: float | None = None) -> Trace:
    """EKF SLAM from the run's first true pose (chapter 05, the report's Figs. 7 and 8).

    ``max_time`` and ``until`` are passed to :func:`run_filter`.
    """
    return _slam_with(EKFSLAM, run, {}, gate=gate, Q=Q, P0=P0, R=R, by=by,
                      use_sensor_R=use_sensor_R, max_time=max_time, until=until)


def fej_slam(run: Run, **kwargs) -> Trace:
    """:func:`slam` with :class:`~slamlib.ekf.FEJEKFSLAM` (First-Estimates Jacobians, ch. 06)."""
    return _slam_with(FEJEKFSLAM, run, {}, **kwargs)


def ideal_slam(run: Run, *, innovation: str = "truth", landmark_init: str = "estimate",
               **kwargs) -> Trace:
    """:func:`slam` with :class:`~slamlib.ekf.IdealEKFSLAM`: Jacobians at the run's truth (ch. 06).

    The filter is given the run's true trajectory (:func:`truth_function`) and
    its world's true map: a diagnostic only a simulated run allows.
    ``innovation`` and ``landmark_init`` go to the filter.
    """
    extra = {"truth": truth_function(run), "landmarks": run.world().landmarks(),
             "t0": float(run.enc_t[0]), "innovation": innovation,
             "landmark_init": landmark_init}
    return _slam_with(IdealEKFSLAM, run, extra, **kwargs)


def _slam_with(cls, run: Run, extra: dict, *, gate: float | None = 0.95, Q=None,
               P0=DEFAULT_P0, R=None, by: str = "capture", use_sensor_R: bool = True,
               max_time: float | None = None, until: float | None = None) -> Trace:
    filt = make_filter(cls, run, Q=Q, P0=P0, R=R, gate=gate, **extra)
    return run_filter(run, filt, by=by, use_sensor_R=use_sensor_R and R is None,
                      use_run_Q_steps=Q is None, max_time=max_time, until=until)


def truth_function(run: Run):
    """A fast ``t -> true pose`` of ``run``: :meth:`Run.truth_at` for one time at a time.

    Exact at the recorded truth times (a filter's clock, a sum of encoder
    periods, lands within 1e-9 s of them), linear in between (heading
    unwrapped), clamped outside; the unwrapping is done once, not per call.
    """
    t, X = run.truth_t, run.truth
    th = np.unwrap(X[:, 2])
    n = t.size

    def pose_at(time: float) -> np.ndarray:
        i = int(np.searchsorted(t, time))
        for j in (i - 1, i):
            if 0 <= j < n and abs(t[j] - time) <= 1e-9:
                return X[j].copy()
        return np.array([np.interp(time, t, X[:, 0]), np.interp(time, t, X[:, 1]),
                         wrap_angle(float(np.interp(time, t, th)))])

    return pose_at


def map_error(filt: EKFSLAM, world) -> tuple[float, dict[int, float]]:
    """RMS distance (m) between mapped landmarks and the true markers with the same id.

    Returns the RMS over the ids the world knows, and each id's error. A mapped
    id that is not in the world (a misread that made it into the map) is
    reported with error ``inf`` and left out of the RMS.
    """
    true = world.landmarks()
    errs = {}
    for i, p in filt.landmarks.items():
        errs[int(i)] = float(np.hypot(*(p - true[i]))) if i in true else float("inf")
    finite = [e for e in errs.values() if np.isfinite(e)]
    rms = float(np.sqrt(np.mean(np.square(finite)))) if finite else float("nan")
    return rms, errs
