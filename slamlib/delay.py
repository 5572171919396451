"""Late camera frames: fuse each one at the time it was captured (chapter 08).

A real camera's frame reaches the filter some time after it was taken (image
transfer, detection, the messaging between processes). A filter that fuses
it on arrival *as if it were current* compares a reading taken from where the
robot was ``delay`` seconds ago with a prediction made from where it is now:
while the robot turns at ``w`` rad/s, every bearing is off by about
``w * delay``, and while it drives at ``v`` m/s every range by about
``v cos(beta) * delay``. The report's robot did this and its map and
trajectory came apart (its section VI.B).

:class:`DelayedEKF` wraps a filter (:class:`~slamlib.ekf.EKFLocalization`,
:class:`~slamlib.ekf.EKFSLAM` or anything with the same ``predict``/``update``)
and fuses every frame *at its capture time*, by re-prediction:

1. it keeps a log of the last ``max_delay`` seconds: every prediction
   ``(u, dt)`` and every fused frame, in time order, each with a snapshot of
   the filter's state after it;
2. a frame stamped ``t_capture`` goes into the log after every event with a
   time ``<= t_capture`` (a prediction at the same instant comes first, as in
   :meth:`slamlib.runs.Run.events`); the filter goes back to the snapshot just
   before that place, applies the update there, and re-applies every event
   after it (predictions and any later frames) with fresh snapshots.

Because the events are then applied in exactly the order, and with exactly
the numbers, that a filter with a zero-latency camera would have seen, the
result is the same filter, bit for bit: the predictions after the late frame
are re-linearised at the corrected states, just as the zero-latency filter
linearised them. Nothing is approximated; what the delay costs is only time
(the estimate *at* time t cannot yet contain frames captured in the last
``delay`` seconds) and work.

Cost: one late frame re-applies the events of its delay, O(L) events for a
history of L events (each O(n) for a prediction, O(n^2) for a snapshot of the
covariance); memory is O(L n^2). The history is bounded: events older than
``max_delay`` seconds leave it, and a frame captured more than ``max_delay``
before the filter's time is not fused (status ``"too_old"``).

A frame stamped later than the filter's clock (``t_capture > t``: the
camera's clock runs ahead of the odometry's) is not fused either (status
``"future"``): fix the clocks or deliver the frame after the prediction
that reaches its time.

:func:`run_delayed` drives a wrapped filter through a run and records two
traces: the estimate *as known at each moment* (real time, what a controller
would use) and the *settled* one (each state once no late frame can change
it any more), which equals :func:`slamlib.runner.run_filter` with
``by="capture"``.
"""

from __future__ import annotations

import bisect
import copy
import math
from dataclasses import dataclass

import numpy as np

from .ekf import UpdateReport
from .models import inverse_observe, motion_model, observe
from .runner import Trace, TraceRecorder, reading_covariances, sensor_noise
from .runs import Run
from .validate import as_finite_scalar, as_positive

__all__ = ["DelayedEKF", "DelayedUpdate", "DelayedTraces", "run_delayed", "history_index",
           "late_reading_error", "compensate_readings", "run_compensated", "delayed_run",
           "make_filter", "run_method", "latency_study", "METHODS", "DELAY_STATUSES",
           "TIME_TOLERANCE"]

#: Slack (s) on the ``max_delay`` comparison, so that a delay of exactly ``max_delay``
#: computed from rounded clock times (12.3 - 12.0 = 0.30000000000000071) still counts.
TIME_TOLERANCE = 1e-9

#: What :meth:`DelayedEKF.update` can do with a frame.
DELAY_STATUSES = ("fused", "too_old", "future", "empty")


def history_index(times, t_capture: float) -> int:
    """Where a frame captured at ``t_capture`` goes in a log of event times (chapter 08).

    ``times`` is non-decreasing. The frame goes after every event at a time
    ``<= t_capture`` (a prediction at the same instant, and a frame of the
    same instant that arrived earlier, come first), so the index is the
    number of such events: ``bisect_right``.
    """
    return bisect.bisect_right(times, t_capture)


def late_reading_error(v: float, w: float, rho: float, beta: float, delay: float
                       ) -> tuple[float, float]:
    """How much a reading ``delay`` seconds old differs from a current one, to first order.

    A marker at range ``rho`` and bearing ``beta`` from a robot moving at
    ``v`` (m/s) and turning at ``w`` (rad/s, z-down) moves in the robot frame
    as ``rho' = -v cos(beta)``, ``beta' = -w + v sin(beta) / rho``. The late
    reading is the current one minus ``delay`` times these rates.

    Returns
    -------
    (float, float)
        ``(z_late - z_now)`` for range (m) and bearing (rad):
        ``(v cos(beta) delay, (w - v sin(beta) / rho) delay)``.
    """
    return (float(v * math.cos(beta) * delay), float((w - v * math.sin(beta) / rho) * delay))


@dataclass(frozen=True)
class DelayedUpdate:
    """What :meth:`DelayedEKF.update` did with one frame.

    Attributes
    ----------
    t_capture : float
        When the frame was taken (s).
    t_filter : float
        The filter's time when it arrived (the time of the latest prediction).
    delay : float
        ``t_filter - t_capture`` (s).
    status : str
        ``"fused"`` (applied at its capture time), ``"too_old"`` (delay beyond
        ``max_delay``: not used), ``"future"`` (captured after the filter's
        time: not used) or ``"empty"`` (no readings: nothing to do).
    replayed : int
        How many logged events were re-applied after it.
    report : UpdateReport or None
        The filter's report of the update at the capture time (None unless fused).
    """

    t_capture: float
    t_filter: float
    delay: float
    status: str
    replayed: int
    report: UpdateReport | None


_SCALARS = (int, float, complex, str, bool, type(None), np.integer, np.floating, np.bool_)


def _copy_value(v):
    if isinstance(v, np.ndarray):
        return v.copy()
    if isinstance(v, _SCALARS):
        return v
    if isinstance(v, list) and all(isinstance(e, _SCALARS) for e in v):
        return list(v)
    if isinstance(v, dict) and all(isinstance(k, _SCALARS) for k in v):
        if all(isinstance(e, _SCALARS) for e in v.values()):
            return dict(v)
        if all(isinstance(e, np.ndarray) for e in v.values()):
            return {k: e.copy() for k, e in v.items()}
    return copy.deepcopy(v)


def _snapshot(filt):
    """An independent copy of a filter's state: ``copy.deepcopy``, made quicker for the
    course's filters (numpy arrays, lists and dicts of numbers copied one level deep)."""
    cls = type(filt)
    if hasattr(cls, "__deepcopy__") or hasattr(cls, "__slots__") or not hasattr(filt, "__dict__"):
        return copy.deepcopy(filt)
    new = object.__new__(cls)
    new.__dict__.update({k: _copy_value(v) for k, v in vars(filt).items()})
    return new


class _Entry:
    __slots__ = ("t", "kind", "args", "state", "report")

    def __init__(self, t, kind, args, state, report=None):
        self.t, self.kind, self.args, self.state, self.report = t, kind, args, state, report


def _apply(filt, entry: _Entry):
    if entry.kind == "predict":
        filt.predict(*entry.args)
        return None
    ids, z, R = entry.args
    return filt.update(ids, z, R=R)


class DelayedEKF:
    """A filter that fuses late frames at their capture time by re-prediction (chapter 08).

    Parameters
    ----------
    filt : EKFLocalization, EKFSLAM or similar
        The filter, initialised at time ``t0``. It is used (and changed) in
        place until the first late frame; after that :attr:`filter` is the
        live one (snapshots are independent copies of it).
    max_delay : float
        How far back (s) a frame may have been captured and still be fused;
        also how much history is kept.
    t0 : float
        The filter's time at the start (s).
    record : bool
        Keep the settled states (see :meth:`settled`).

    Use ``predict(u, dt, t)`` with the time ``t`` the prediction reaches and
    ``update(ids, z, R, t_capture=...)`` for a frame; read the current
    estimate through :attr:`pose`, :attr:`pose_cov`, :attr:`x`, :attr:`P`
    or :attr:`filter`.
    """

    def __init__(self, filt, max_delay: float = 1.0, t0: float = 0.0, record: bool = False):
        for name in ("predict", "update", "pose", "pose_cov"):
            if not hasattr(filt, name):
                raise ValueError(f"filt: expected a filter with predict, update, pose and "
                                 f"pose_cov (EKFLocalization, EKFSLAM), got "
                                 f"{type(filt).__name__} without {name}")
        self.max_delay = as_positive("max_delay", max_delay)
        self._t = as_finite_scalar("t0", t0)
        self._filt = filt
        self._log: list[_Entry] = []
        self._times: list[float] = []
        self._base = _snapshot(filt)        # the state before the first logged event
        self._base_t = self._t             # ... and its time
        self._record = bool(record)
        self._settled: list[tuple[float, str, np.ndarray, np.ndarray, UpdateReport | None]] = []
        if self._record:
            self._settled.append((self._t, "start", filt.pose.copy(), filt.pose_cov.copy(), None))
        self.replays = 0                   # events re-applied so far (the work the delay costs)

    # ------------------------------------------------------------------ read-out
    @property
    def filter(self):
        """The live filter (its state is the current estimate)."""
        return self._filt

    @property
    def t(self) -> float:
        """The filter's time: the time the latest prediction reached (s)."""
        return self._t

    @property
    def pose(self) -> np.ndarray:
        return self._filt.pose

    @property
    def pose_cov(self) -> np.ndarray:
        return self._filt.pose_cov

    @property
    def x(self) -> np.ndarray:
        return self._filt.x

    @property
    def P(self) -> np.ndarray:
        return self._filt.P

    @property
    def history_length(self) -> int:
        """Number of events in the history."""
        return len(self._log)

    @property
    def history_start(self) -> float:
        """Time of the oldest state the filter can go back to (s)."""
        return self._base_t

    # ------------------------------------------------------------------ events
    def predict(self, u, dt: float, t: float | None = None, Q=None) -> None:
        """Predict with wheel speeds ``u`` over ``dt`` up to time ``t`` (default ``t + dt``),
        with this step's covariance ``Q`` of ``u`` (default the filter's own).

        ``t`` must not be earlier than the filter's time. Bad ``u`` or ``dt``
        raise ValueError (from the filter) before anything changes.
        """
        if t is None:
            t = self._t + as_positive("dt", dt)
        t = as_finite_scalar("t", t)
        if t < self._t:
            raise ValueError(f"t: expected a time >= the filter's time {self._t}, got {t}")
        args = (u, dt) if Q is None else (u, dt, Q)
        self._filt.predict(*args)            # checks u, dt (and Q) before anything changes
        u = np.array(u, dtype=float, copy=True)
        args = (u, dt) if Q is None else (u, dt, np.array(Q, dtype=float))
        self._append(_Entry(t, "predict", args, None))
        self._t = t
        self._prune()

    def update(self, ids, z, R=None, *, t_capture: float) -> DelayedUpdate:
        """Fuse the frame ``(ids, z, R)`` captured at ``t_capture`` at that time.

        See the module docstring. Bad input (NaN time, wrong shapes, ...)
        raises ValueError before anything changes.
        """
        tc = as_finite_scalar("t_capture", t_capture)
        delay = self._t - tc
        ids = np.array(ids, copy=True)
        z = np.array(z, dtype=float, copy=True)
        R = None if R is None else np.array(R, dtype=float, copy=True)
        if ids.size == 0:
            if z.size:
                raise ValueError(f"z: expected no readings for no ids, got shape {z.shape}")
            return DelayedUpdate(tc, self._t, delay, "empty", 0, None)
        if tc > self._t:
            return DelayedUpdate(tc, self._t, delay, "future", 0, None)
        if delay > self.max_delay + TIME_TOLERANCE or tc < self._base_t:
            return DelayedUpdate(tc, self._t, delay, "too_old", 0, None)
        i = history_index(self._times, tc)
        entry = _Entry(tc, "update", (ids, z, R), None)
        if i == len(self._log):                      # the newest event: the usual update
            entry.report = _apply(self._filt, entry)  # raises before any change on bad input
            self._append(entry)
            return DelayedUpdate(tc, self._t, delay, "fused", 0, entry.report)
        # Go back to the state just before the frame's place, on a copy: if the update
        # raises, nothing has changed.
        filt = _snapshot(self._log[i - 1].state if i > 0 else self._base)
        entry.report = _apply(filt, entry)
        entry.state = _snapshot(filt)
        later = self._log[i:]
        redone = []
        for e in later:                              # re-apply what came after, in order
            r = _apply(filt, e)
            redone.append((_snapshot(filt), r))
        for e, (state, r) in zip(later, redone):
            e.state = state
            if e.kind == "update":
                e.report = r
        self._log.insert(i, entry)
        self._times.insert(i, tc)
        self._filt = filt
        self.replays += len(later)
        return DelayedUpdate(tc, self._t, delay, "fused", len(later), entry.report)

    def settled(self) -> list[tuple[float, str, np.ndarray, np.ndarray, UpdateReport | None]]:
        """The states that no late frame can change any more (``record=True``).

        One ``(t, kind, pose, pose_cov, report)`` per event, in capture-time
        order, starting with ``(t0, "start", ...)``; an update's ``t`` is its
        capture time. Call :meth:`finish` at the end of a run to settle the rest.
        """
        if not self._record:
            raise ValueError("record: this DelayedEKF was made with record=False")
        return list(self._settled)

    def finish(self) -> None:
        """Settle every event still in the history (no more frames will come)."""
        while self._log:
            self._pop()

    # ------------------------------------------------------------------ internals
    def _append(self, entry: _Entry) -> None:
        entry.state = _snapshot(self._filt)
        self._log.append(entry)
        self._times.append(entry.t)

    def _pop(self) -> None:
        e = self._log.pop(0)
        self._times.pop(0)
        self._base, self._base_t = e.state, e.t
        if self._record:
            self._settled.append((e.t, e.kind, e.state.pose, e.state.pose_cov, e.report))

    def _prune(self) -> None:
        # keep every event at a time >= t - max_delay: a frame captured then can still be
        # inserted after the base state (the state after the last dropped event)
        limit = self._t - self.max_delay - TIME_TOLERANCE
        while self._log and self._log[0].t < limit:
            self._pop()


@dataclass
class DelayedTraces:
    """What :func:`run_delayed` records.

    Attributes
    ----------
    realtime : Trace
        The estimate after every delivered event, as known at that moment
        (frames at their arrival times).
    settled : Trace
        Every state once final, in capture-time order (equals the filter run
        with ``by="capture"`` when no frame was too old).
    updates : list of DelayedUpdate
        What happened to each non-empty frame.
    wrapper : DelayedEKF
        The wrapper in its final state.
    """

    realtime: Trace
    settled: Trace
    updates: list
    wrapper: DelayedEKF

    def statuses(self) -> dict[str, int]:
        """How many frames ended in each status."""
        out: dict[str, int] = {}
        for u in self.updates:
            out[u.status] = out.get(u.status, 0) + 1
        return out


def run_delayed(run: Run, filt, *, max_delay: float = 1.0, by: str = "arrival",
                use_sensor_R: bool = True) -> DelayedTraces:
    """Drive ``filt`` wrapped in a :class:`DelayedEKF` through ``run`` (chapter 08).

    Frames are delivered at their arrival time (``by="arrival"``, the real
    robot) or capture time and stamped with their capture time; each reading
    gets ``sensor.R(range)`` as in :func:`slamlib.runner.run_filter`.
    """
    sensor = sensor_noise(run) if use_sensor_R else None
    t0 = float(run.enc_t[0])
    w = DelayedEKF(filt, max_delay=max_delay, t0=t0, record=True)
    rec = TraceRecorder(t0, w)
    updates = []
    for ev in run.events(by=by):
        report = None
        if ev.kind == "predict":
            w.predict(ev.u, ev.dt, ev.t, _step_Q(run, ev.dt))
        else:
            obs = ev.obs
            if len(obs) == 0:
                continue
            res = w.update(obs.ids, obs.z, R=reading_covariances(sensor, obs.z),
                           t_capture=obs.t)
            updates.append(res)
            report = res.report
        rec.record(ev.t, ev.kind, w, report)
    realtime = rec.trace(run, w.filter)
    w.finish()
    st = w.settled()
    ts = np.array([s[0] for s in st])
    settled = Trace(t=ts, kind=np.array([s[1] for s in st]), x=np.array([s[2] for s in st]),
                    P=np.array([s[3] for s in st]), truth=run.truth_at(ts),
                    reports=[(s[0], s[4]) for s in st if s[4] is not None], filter=w.filter)
    return DelayedTraces(realtime=realtime, settled=settled, updates=updates, wrapper=w)


def _step_Q(run: Run, dt: float):
    """The step's own covariance of ``u`` that :func:`slamlib.runner.run_filter` gives it
    (:meth:`Run.Q_steps`, a real log's density), or None (the filter's own)."""
    Q = run.Q_steps(np.array([dt], dtype=float))
    return None if Q is None else Q[0]


# --------------------------------------------------------------------------- the cheap alternative
def compensate_readings(z, odo_capture, odo_now) -> np.ndarray:
    """Move readings taken at ``odo_capture`` to ``odo_now`` with odometry (chapter 08).

    Each reading is turned into a point with the pose at capture time and
    observed again from the current pose: ``observe(odo_now,
    inverse_observe(odo_capture, z))``. Only the *relative* motion between the
    two poses matters, so dead-reckoning poses do (their drift over a fraction
    of a second is small). The result is an approximation: the odometry's
    error over the delay is neither corrected nor added to R.
    """
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    out = np.empty_like(z)
    for i in range(z.shape[0]):
        out[i] = observe(odo_now, inverse_observe(odo_capture, z[i]))
    return out


def run_compensated(run: Run, filt, *, max_delay: float = 1.0, use_sensor_R: bool = True
                    ) -> Trace:
    """Fuse each frame on arrival after moving its readings to the current pose (chapter 08).

    A dead-reckoning pose is kept at every encoder time of the last
    ``max_delay`` seconds; a frame is compensated with
    :func:`compensate_readings` from the odometry pose at the last encoder
    time ``<= t_capture`` to the current one, then fused by the plain filter.
    Frames older than ``max_delay`` are dropped. O(log L) per frame, no replay.
    """
    as_positive("max_delay", max_delay)
    sensor = sensor_noise(run) if use_sensor_R else None
    t0 = float(run.enc_t[0])
    odo = run.start_pose.copy()
    times, poses = [t0], [odo.copy()]
    rec = TraceRecorder(t0, filt)
    for ev in run.events(by="arrival"):
        report = None
        if ev.kind == "predict":
            Q = _step_Q(run, ev.dt)
            if Q is None:
                filt.predict(ev.u, ev.dt)
            else:
                filt.predict(ev.u, ev.dt, Q)
            odo = motion_model(odo, ev.u, ev.dt, run.wheel_base)
            times.append(ev.t)
            poses.append(odo)
            while len(times) > 1 and times[1] < ev.t - max_delay:
                times.pop(0)
                poses.pop(0)
        else:
            obs = ev.obs
            if len(obs) == 0 or times[-1] - obs.t > max_delay:
                continue
            i = max(history_index(times, obs.t) - 1, 0)
            z = compensate_readings(obs.z, poses[i], poses[-1])
            report = filt.update(obs.ids, z, R=reading_covariances(sensor, z))
        rec.record(ev.t, ev.kind, filt, report)
    return rec.trace(run, filt)


# --------------------------------------------------------------------------- studies
#: The ways of handling late frames that :func:`latency_study` compares.
METHODS = {
    "naive": "fused on arrival as if current (the report's robot)",
    "fixed": "fused at the capture time by re-prediction (DelayedEKF), estimate in real time",
    "compensated": "fused on arrival, readings moved to the current pose by odometry",
}


def delayed_run(latency: float, *, scenario: str = "arena_loop", seed: int | None = None):
    """A scenario re-simulated with a camera latency (s): the same motion and readings as
    the recorded run, only the arrival times differ."""
    from .sim import scenario as simulate_scenario

    return simulate_scenario(scenario, seed=seed, latency=float(latency))


def make_filter(run: Run, kind: str = "slam", gate: float | None = 0.95):
    """The filter the course runs on ``run``: EKF SLAM or the map-based EKF on the true map
    (:func:`slamlib.runner.make_filter`: the first true pose, the run's Q, its
    sensor's R at 2 m)."""
    from .ekf import EKFSLAM, EKFLocalization
    from .runner import make_filter as make

    if kind == "slam":
        return make(EKFSLAM, run, gate=gate)
    if kind == "localization":
        return make(EKFLocalization, run, gate=gate, landmarks=run.world().landmarks())
    raise ValueError(f"kind: expected 'slam' or 'localization', got {kind!r}")


def run_method(run: Run, method: str, kind: str = "slam", *, max_delay: float = 1.0) -> Trace:
    """Run one of :data:`METHODS` on ``run`` and return its real-time trace."""
    filt = make_filter(run, kind)
    if method == "naive":
        from .runner import run_filter

        return run_filter(run, filt, by="arrival")
    if method == "fixed":
        return run_delayed(run, filt, max_delay=max_delay).realtime
    if method == "compensated":
        return run_compensated(run, filt, max_delay=max_delay)
    raise ValueError(f"method: expected one of {list(METHODS)}, got {method!r}")


def latency_study(latencies=(0.0, 0.1, 0.2, 0.3, 0.5), *, kind: str = "slam",
                  methods=("naive", "fixed"), seed: int | None = None,
                  scenario: str = "arena_loop", max_delay: float = 1.0,
                  cache: dict | None = None) -> list[dict]:
    """Each method's errors against the camera latency (chapter 08).

    For every latency the scenario is re-simulated (same motion and readings,
    later arrivals) and each method run on it. Returns one dict per
    (latency, method): ``latency``, ``method``, ``kind`` and the trace's
    metrics (``ate_xy``, ``ate_theta``, ``mean_nees``, ``final_xy_error``,
    and for SLAM ``map_rmse``, ``landmarks``) plus ``rejected``, the readings
    the gate refused.

    ``cache``, a dict, keeps the traces under ``(latency, method, kind)``
    (latency rounded to 1 us): traces already in it are used, not recomputed,
    and the new ones are added (a chapter that has run a case already, or
    wants to draw one afterwards, passes the same dict). Only for the default
    ``seed``, ``scenario`` and ``max_delay``: the key does not hold them.
    """
    from .sim import SCENARIOS
    from .worlds import load_world

    for m in methods:
        if m not in METHODS:
            raise ValueError(f"methods: expected names from {list(METHODS)}, got {m!r}")
    if scenario not in SCENARIOS:
        raise ValueError(f"scenario: expected one of {sorted(SCENARIOS)}, got {scenario!r}")
    world = load_world(SCENARIOS[scenario][0])
    rows = []
    for lat in latencies:
        lat = float(lat)
        if not math.isfinite(lat) or lat < 0.0:
            raise ValueError(f"latencies: expected times >= 0 s, got {lat}")
        run = None
        for m in methods:
            key = (round(lat, 6), m, kind)
            tr = None if cache is None else cache.get(key)
            if tr is None:
                run = run or delayed_run(lat, scenario=scenario, seed=seed)
                tr = run_method(run, m, kind, max_delay=max_delay)
                if cache is not None:
                    cache[key] = tr
            rows.append({"latency": lat, "method": m, "kind": kind, **tr.metrics(world),
                         "rejected": tr.counts().get("rejected", 0)})
    return rows
