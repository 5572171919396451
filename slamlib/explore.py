"""Exploring an unknown marker world, steered by the SLAM estimate (chapter 07, report VIII).

Every chapter before this one drove the robot along a fixed path, steered by
its *true* pose. Here the robot decides where to go from what its EKF SLAM
believes. One encoder period of the closed loop (:func:`run_closed_loop`):

1. the **policy** looks at the filter's *estimate* (pose, covariance, map) and
   commands the wheels ``(V_R, V_L)``;
2. the simulated Kobuki (:class:`slamlib.sim.KobukiSim`) moves its *true*
   pose with those commands plus wheel slip, counts encoder ticks, and its
   camera reads the markers from the *true* pose;
3. the filter fuses the camera frames captured during the period, then
   predicts with the wheel speeds it computes from the ticks.

The order of step 3 is the order of :func:`slamlib.runner.run_filter`
(by capture time), so replaying the recorded run through
:func:`slamlib.runner.slam` gives the same estimates.

The exploration policy (:class:`Explorer`) is deliberately simple:

- **coverage**: the world's bounds are cut into square cells; a cell is
  *seen* once its centre was inside the camera's field of view and within
  ``view_range`` of the *estimated* pose (:func:`in_field_of_view`);
- **frontier**: the robot drives towards the nearest unseen cell that
  borders a seen one, where a turn counts as distance (``turn_cost`` metres
  per radian of heading change, so that it does not zig-zag); goals are kept
  ``margin`` inside the bounds; a goal reached without its cell being seen is
  abandoned;
- **return to a known landmark**: when the position uncertainty
  ``sigma_xy = sqrt(P_xx + P_yy)`` exceeds ``sigma_return``, the robot drives
  back to a landmark that is known much better than the robot knows itself
  and has been seen in at least ``min_sightings`` frames (the *anchor*: the
  nearest such landmark whose own sigma is below ``anchor_ratio * sigma_xy``,
  else the best-known one, usually the first mapped). It goes to a point
  ``return_distance`` in front of it, on the side it has been seen from (the
  mean direction from the landmark to the robot over its sightings: a marker
  is visible from its printed side only), and approaches it. Re-observing
  it closes a loop and pulls the pose back (the report's observation in
  section VIII). The return ends when ``sigma_xy`` falls below
  ``hysteresis * sigma_return`` or the approach is finished;
- it stops when the coverage reaches ``coverage_target``, when no frontier is
  left, or when the time is up.

Markers are thin posts: the simulation has no obstacles and no occlusion.
Everything is seeded; the same arguments give the same run, bit for bit.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, replace

import numpy as np

from .ekf import EKFSLAM
from .models import range_bearing, tick_difference, wheel_speeds_from_ticks
from .runner import DEFAULT_P0, Trace, TraceRecorder, reading_covariances
from .runs import Run
from .sensors import DEFAULT_FOV_HALF_ANGLE, AnalyticMarkerSensor
from .sim import KobukiParams, KobukiSim, WaypointController
from .validate import as_positive, as_vector
from .worlds import World, random_world

__all__ = ["in_field_of_view", "CoverageGrid", "Explorer", "Exploration", "run_closed_loop",
           "explore", "position_sigma", "exploration_world"]


def exploration_world(seed: int = 5, count: int = 15,
                      extent: tuple[float, float, float, float] = (0.0, 8.0, -4.0, 4.0)) -> World:
    """The chapter's random world: ``count`` markers in ``extent``, start at (1, 0) heading +x."""
    w = random_world(extent=extent, count=count, min_spacing=0.5, seed=seed)
    return replace(w, start_pose=(extent[0] + 1.0, 0.5 * (extent[2] + extent[3]), 0.0))


# --------------------------------------------------------------------------- geometry
def in_field_of_view(pose, points, fov_half_angle: float = DEFAULT_FOV_HALF_ANGLE,
                     max_range: float = 2.0) -> np.ndarray:
    """Which ``points`` lie inside the camera's field of view from ``pose`` (chapter 07).

    A point is inside when its distance from the robot is at most
    ``max_range`` and its bearing ``atan2(dy, dx) - theta``, wrapped to
    [-pi, pi), is at most ``fov_half_angle`` in size. Measured from the
    robot's origin: for a coarse coverage grid the camera's 12 cm offset does
    not matter (the sensor itself uses it, :func:`slamlib.sensors.visible_markers`).

    Parameters
    ----------
    pose : array_like (3,)
        ``[x, y, theta]`` in N (z-down: the bearing is positive to the right).
    points : array_like (n, 2)
        Points in N.

    Returns
    -------
    numpy.ndarray of bool, shape (n,)
    """
    pose = as_vector("pose", pose, 3)
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    rho, bearing = range_bearing(p[:, 0] - pose[0], p[:, 1] - pose[1], pose[2])
    return (rho <= max_range) & (np.abs(bearing) <= fov_half_angle)


def position_sigma(P) -> float:
    """``sqrt(P_xx + P_yy)`` (m): the size of the position uncertainty, from a covariance."""
    P = np.asarray(P, dtype=float)
    return math.sqrt(max(P[0, 0] + P[1, 1], 0.0))


# --------------------------------------------------------------------------- coverage
@dataclass
class CoverageGrid:
    """Square cells over ``bounds``; each is seen or not yet (chapter 07).

    Attributes
    ----------
    bounds : tuple (xmin, xmax, ymin, ymax)
    cell : float
        Side of a cell (m); the grid has ``ceil(width / cell)`` columns.
    seen : numpy.ndarray of bool, shape (rows, cols)
        Row ``i`` is y, column ``j`` is x.
    """

    bounds: tuple
    cell: float = 0.3
    seen: np.ndarray = field(default=None, repr=False)

    def __post_init__(self):
        xmin, xmax, ymin, ymax = (float(v) for v in self.bounds)
        self.bounds = (xmin, xmax, ymin, ymax)
        as_positive("cell", self.cell)
        self.shape = (max(1, math.ceil((ymax - ymin) / self.cell - 1e-9)),
                      max(1, math.ceil((xmax - xmin) / self.cell - 1e-9)))
        if self.seen is None:
            self.seen = np.zeros(self.shape, dtype=bool)
        ys = ymin + self.cell * (np.arange(self.shape[0]) + 0.5)
        xs = xmin + self.cell * (np.arange(self.shape[1]) + 0.5)
        gx, gy = np.meshgrid(xs, ys)
        #: Cell centres, shape (rows * cols, 2), row-major (index ``i * cols + j``).
        self.centres = np.column_stack([gx.ravel(), gy.ravel()])

    @property
    def coverage(self) -> float:
        """Fraction of the cells seen."""
        return float(self.seen.mean())

    def mark(self, pose, fov_half_angle: float = DEFAULT_FOV_HALF_ANGLE,
             view_range: float = 2.0) -> int:
        """Mark the cells in view from ``pose`` as seen; return how many were new."""
        inside = in_field_of_view(pose, self.centres, fov_half_angle, view_range)
        flat = self.seen.reshape(-1)
        new = inside & ~flat
        flat |= inside
        return int(new.sum())

    def frontier(self) -> np.ndarray:
        """Unseen cells with a seen neighbour (4-connected), as a bool array like ``seen``."""
        s = self.seen
        near = np.zeros_like(s)
        near[1:, :] |= s[:-1, :]
        near[:-1, :] |= s[1:, :]
        near[:, 1:] |= s[:, :-1]
        near[:, :-1] |= s[:, 1:]
        return near & ~s


# --------------------------------------------------------------------------- the policy
@dataclass
class Explorer:
    """Frontier exploration with a return to a known landmark (see the module docstring).

    Parameters
    ----------
    cell : float
        Coverage grid cell (m).
    view_range : float
        A cell counts as seen within this distance (m), inside the field of view.
    fov_half_angle : float
        Half field of view (rad), the camera's by default.
    margin : float
        Goals stay this far inside the world's bounds (m).
    turn_cost : float
        Metres of extra distance per radian of turn, when choosing the frontier cell.
    sigma_return : float or None
        Start a return when ``sigma_xy`` exceeds it (m); None: never return.
    hysteresis : float
        The return ends once ``sigma_xy < hysteresis * sigma_return``.
    cooldown : float
        Seconds after a return before the next one may start.
    anchor_ratio : float
        A landmark can be the anchor of a return if its position sigma is below
        ``anchor_ratio * sigma_xy``...
    min_sightings : int
        ...and it was seen in at least this many frames (a landmark glimpsed
        once, at the edge of its viewing angle, is hard to find again).
    return_distance : float
        The return goes to this distance (m) in front of the anchor...
    approach : float
        ...then drives this far (m) towards it.
    coverage_target : float
        Stop when this fraction of the cells is seen.
    v_max, w_max : float
        Speed limits handed to the :class:`~slamlib.sim.WaypointController`.
    """

    cell: float = 0.3
    view_range: float = 2.0
    fov_half_angle: float = DEFAULT_FOV_HALF_ANGLE
    margin: float = 0.5
    turn_cost: float = 0.5
    sigma_return: float | None = 0.15
    hysteresis: float = 0.5
    cooldown: float = 20.0
    anchor_ratio: float = 0.5
    min_sightings: int = 10
    return_distance: float = 1.5
    approach: float = 0.3
    coverage_target: float = 0.95
    v_max: float = 0.2
    w_max: float = 0.7

    def params(self) -> dict:
        """The parameters as a JSON-ready dict (for the run's meta)."""
        return {"type": type(self).__name__, "cell": self.cell, "view_range": self.view_range,
                "fov_half_angle": self.fov_half_angle, "margin": self.margin,
                "turn_cost": self.turn_cost,
                "sigma_return": self.sigma_return, "hysteresis": self.hysteresis,
                "cooldown": self.cooldown, "anchor_ratio": self.anchor_ratio,
                "min_sightings": self.min_sightings,
                "return_distance": self.return_distance, "approach": self.approach,
                "coverage_target": self.coverage_target, "v_max": self.v_max,
                "w_max": self.w_max}

    # ------------------------------------------------------------------ state
    def reset(self, world) -> None:
        """Start a new exploration of ``world`` (only its bounds are used: the map is unknown)."""
        self.grid = CoverageGrid(world.bounds, self.cell)
        self.inner = (self.grid.bounds[0] + self.margin, self.grid.bounds[1] - self.margin,
                      self.grid.bounds[2] + self.margin, self.grid.bounds[3] - self.margin)
        if self.inner[0] >= self.inner[1] or self.inner[2] >= self.inner[3]:
            raise ValueError(f"margin: {self.margin} m leaves no room inside {world.bounds}")
        self.ctl = WaypointController(np.zeros((1, 2)), v_max=self.v_max, w_max=self.w_max)
        self.ctl.index = 1                      # no goal yet: stand still
        self.mode = "explore"                   # "explore", "return" or "done"
        self.target: int | None = None          # index of the frontier cell driven to
        self.abandoned: set[int] = set()
        #: landmark id -> unit vectors from the landmark to the robot, one per sighting
        self.sightings: dict[int, list[np.ndarray]] = {}
        self.anchor: int | None = None
        self._t_return = 0.0
        self._t_last_return = -math.inf
        #: (t_start, t_end, anchor id, sigma_xy at the start, at the end) of every return.
        self.returns: list[tuple[float, float, int, float, float]] = []
        #: (t, goal x, goal y, mode) every time the goal changes.
        self.goals: list[tuple[float, float, float, str]] = []
        #: Sampled at every camera frame: t, coverage, landmarks, sigma_xy, mode.
        self.history: dict[str, list] = {"t": [], "coverage": [], "landmarks": [],
                                         "sigma_xy": [], "mode": []}

    @property
    def finished(self) -> bool:
        """True once the policy has decided to stop and the robot stands still."""
        return self.mode == "done" and self.ctl.done

    # ------------------------------------------------------------------ decisions
    def _clamp(self, p) -> np.ndarray:
        x0, x1, y0, y1 = self.inner
        return np.array([min(max(p[0], x0), x1), min(max(p[1], y0), y1)])

    def _go(self, t: float, waypoints) -> None:
        wp = np.atleast_2d(np.asarray(waypoints, dtype=float))
        self.ctl.set_waypoints(wp)
        self.goals.append((t, float(wp[-1, 0]), float(wp[-1, 1]), self.mode))

    def choose_frontier(self, pose) -> int | None:
        """Index of the frontier cell (not abandoned) with the smallest cost from ``pose``, or None.

        Cost: distance + ``turn_cost`` * |bearing| (the heading change to face it).
        """
        front = self.grid.frontier().reshape(-1).copy()
        if self.abandoned:
            front[list(self.abandoned)] = False
        idx = np.flatnonzero(front)
        if idx.size == 0:
            return None
        d = self.grid.centres[idx] - np.asarray(pose)[:2]
        dist, bearing = range_bearing(d[:, 0], d[:, 1], pose[2])
        cost = dist + self.turn_cost * np.abs(bearing)
        return int(idx[np.argmin(cost)])

    def choose_anchor(self, filt: EKFSLAM) -> int | None:
        """The landmark to return to: the nearest one known much better than the robot."""
        ids = [i for i in filt.landmark_ids
               if len(self.sightings.get(i, ())) >= self.min_sightings]
        if not ids:
            return None
        sig = np.array([position_sigma(filt.landmark_cov(i)) for i in ids])
        good = np.flatnonzero(sig < self.anchor_ratio * position_sigma(filt.pose_cov))
        if good.size == 0:
            return ids[int(np.argmin(sig))]                 # the best-known one
        dist = [np.hypot(*(filt.landmark(ids[k]) - filt.pose[:2])) for k in good]
        return ids[int(good[np.argmin(dist)])]

    def _start_return(self, t: float, filt: EKFSLAM, sigma: float) -> bool:
        self.anchor = self.choose_anchor(filt)
        if self.anchor is None:
            return False
        lm = filt.landmark(self.anchor)
        side = np.mean(self.sightings[self.anchor], axis=0)
        side = side / max(np.hypot(*side), 1e-9)          # from the landmark towards the robot
        view = self._clamp(lm + self.return_distance * side)
        d = lm - view
        closer = self._clamp(view + self.approach * d / max(np.hypot(*d), 1e-9))
        self.mode, self._t_return, self._sigma_start = "return", t, sigma
        self.target = None
        self._go(t, [view, closer])
        return True

    def _end_return(self, t: float, sigma: float) -> None:
        self.returns.append((self._t_return, t, int(self.anchor), self._sigma_start, sigma))
        self.mode, self._t_last_return = "explore", t

    def command(self, t: float, filt: EKFSLAM, dt: float, wheel_base: float
                ) -> tuple[float, float]:
        """Wheel commands ``(V_R, V_L)`` for the next period, from the filter's estimate."""
        pose = filt.pose
        sigma = position_sigma(filt.pose_cov)
        if not self.grid.seen.any():             # before the first camera frame: wait
            return self.ctl.command(pose, dt, wheel_base)
        if self.mode == "return":
            if sigma < self.hysteresis * self.sigma_return or self.ctl.done:
                self._end_return(t, sigma)
        if self.mode == "explore":
            if (self.sigma_return is not None and sigma > self.sigma_return
                    and t - self._t_last_return > self.cooldown
                    and self._start_return(t, filt, sigma)):
                pass
            elif self.grid.coverage >= self.coverage_target:
                self.mode = "done"
                self._go(t, pose[:2])
            else:
                seen = self.grid.seen.reshape(-1)
                reached = self.ctl.index >= self.ctl.waypoints.shape[0]
                if self.target is not None and reached and not seen[self.target]:
                    self.abandoned.add(self.target)         # got there, still not seen
                if self.target is None or seen[self.target] or reached:
                    self.target = self.choose_frontier(pose)
                    if self.target is None:
                        self.mode = "done"
                        self._go(t, pose[:2])
                    else:
                        self._go(t, self._clamp(self.grid.centres[self.target]))
        return self.ctl.command(pose, dt, wheel_base)

    def after_frame(self, t: float, filt: EKFSLAM, report) -> None:
        """Called after every camera frame (``report`` None if it had no readings)."""
        if report is not None:
            pose = filt.pose
            for i in np.asarray(report.ids)[report.new | report.accepted]:
                d = pose[:2] - filt.landmark(i)
                u = d / max(np.hypot(*d), 1e-9)
                self.sightings.setdefault(int(i), []).append(u)
        self.grid.mark(filt.pose, self.fov_half_angle, self.view_range)
        h = self.history
        h["t"].append(t)
        h["coverage"].append(self.grid.coverage)
        h["landmarks"].append(filt.n_landmarks)
        h["sigma_xy"].append(position_sigma(filt.pose_cov))
        h["mode"].append(self.mode)


# --------------------------------------------------------------------------- the closed loop
@dataclass
class Exploration:
    """What a closed-loop run produced.

    Attributes
    ----------
    run : Run
        The simulated run (truth, encoder ticks, camera readings), recorded
        as by :func:`slamlib.sim.simulate`.
    trace : Trace
        The filter's pose and covariance after every event, with the truth
        (as :func:`slamlib.runner.run_filter` records it).
    policy : object
        The policy in its final state (for :class:`Explorer`: ``grid``,
        ``history``, ``returns``, ``goals``).
    """

    run: Run
    trace: Trace
    policy: object

    @property
    def filter(self) -> EKFSLAM:
        """The filter in its final state."""
        return self.trace.filter

    def history(self) -> dict[str, np.ndarray]:
        """The policy's per-frame history as arrays, plus the true position error then."""
        h = {k: np.asarray(v) for k, v in self.policy.history.items()}
        k = np.searchsorted(self.trace.t, h["t"], side="right") - 1
        e = self.trace.error[k]
        h["error_xy"] = np.hypot(e[:, 0], e[:, 1])
        return h

    def metrics(self, world=None) -> dict[str, float]:
        """Final and RMS position error, coverage, landmarks, returns (and map RMS with world)."""
        err = np.hypot(*self.trace.error[:, :2].T)
        out = {"duration": float(self.trace.t[-1]), "final_xy_error": float(err[-1]),
               "rms_xy_error": float(np.sqrt(np.mean(err ** 2))),
               "max_xy_error": float(err.max()),
               "final_sigma_xy": position_sigma(self.trace.P[-1]),
               "landmarks": float(self.filter.n_landmarks)}
        grid = getattr(self.policy, "grid", None)
        if grid is not None:
            out["coverage"] = grid.coverage
            out["returns"] = float(len(self.policy.returns))
        if world is not None:
            from .runner import map_error
            out["map_rmse"] = map_error(self.filter, world)[0]
        return out


def run_closed_loop(world, policy, *, seed: int = 0, params: KobukiParams | None = None,
                    sensor=None, start_pose=None, duration: float = 150.0,
                    gate: float | None = 0.95, initial_estimate=None, Q=None,
                    name: str | None = None) -> Exploration:
    """Simulate ``policy`` steering by an EKF SLAM estimate in ``world`` (chapter 07).

    Parameters
    ----------
    world : World
        The markers the camera sees (the policy gets only the bounds).
    policy : object
        Has ``reset(world)``, ``command(t, filt, dt, wheel_base) -> (V_R, V_L)``,
        ``after_frame(t, filt, report)``, ``finished`` and ``params()``; a copy
        is used (``copy.deepcopy``) and reset.
    seed : int
        Fixes the slip and the camera noise (as in :func:`slamlib.sim.simulate`).
    params : KobukiParams, optional
    sensor : optional
        Default :class:`~slamlib.sensors.AnalyticMarkerSensor()`; its ``R(rho)``
        gives each reading's covariance in the filter.
    start_pose : array_like (3,), optional
        The true start; default the world's.
    duration : float
        Stop after this many seconds at the latest.
    gate : float or None
        The filter's chi-square gate.
    initial_estimate : array_like (3,), optional
        Where the filter believes the robot starts (default: the true start).
        A wrong one shows that the robot goes where the *estimate* says.
    Q : array_like (2, 2), optional
        The filter's wheel-speed covariance; default: what the simulated slip
        and the tick quantisation imply (a smaller one makes it overconfident).
    """
    params = params or KobukiParams()
    sensor = AnalyticMarkerSensor() if sensor is None else sensor
    as_positive("duration", duration)
    sim = KobukiSim(world, sensor=sensor, seed=seed, params=params, start_pose=start_pose)
    if Q is None:
        Q = sim.record().Q(params.dt)      # slip plus tick quantisation, as for a recorded run
    x0 = sim.pose if initial_estimate is None else as_vector("initial_estimate",
                                                               initial_estimate, 3)
    filt = EKFSLAM(x0, DEFAULT_P0, Q, sensor.R(2.0), wheel_base=params.wheel_base, gate=gate)
    pol = copy.deepcopy(policy)
    pol.reset(world)
    b, dt = params.wheel_base, params.dt
    rec = TraceRecorder(0.0, filt)
    n_max = int(math.ceil(duration * params.encoder_rate))
    while sim.k < n_max and not pol.finished:
        frames = sim.step(*pol.command(sim.t, filt, dt, b))
        for obs in frames:                               # captured in [t_k, t_k+1)
            rep = None
            if len(obs):
                rep = filt.update(obs.ids, obs.z, R=reading_covariances(sensor, obs.z))
                rec.record(obs.t, "update", filt, rep)
            pol.after_frame(obs.t, filt, rep)
        # the wheel speeds from the ticks, as Run.controls computes them
        dR = tick_difference(sim.ticks_R[-1], sim.ticks_R[-2], bits=params.bits)
        dL = tick_difference(sim.ticks_L[-1], sim.ticks_L[-2], bits=params.bits)
        step = sim.times[-1] - sim.times[-2]
        filt.predict(wheel_speeds_from_ticks(dR, dL, step, params.ticks_per_rev,
                                             params.wheel_radius), step)
        rec.record(sim.t, "predict", filt)
    run = sim.record(name=name or f"explore_{world.name}_sim{seed}",
                     description="closed loop: the policy steers by the EKF SLAM estimate",
                     controller=pol.params(), finished=pol.finished)
    trace = rec.trace(run, filt)
    return Exploration(run=run, trace=trace, policy=pol)


def explore(world, *, explorer: Explorer | None = None, seed: int = 0,
            duration: float = 150.0, **kwargs) -> Exploration:
    """Explore ``world`` with an :class:`Explorer` (default parameters unless given).

    ``kwargs`` go to :func:`run_closed_loop` (``params``, ``sensor``,
    ``start_pose``, ``gate``, ``initial_estimate``, ``Q``, ``name``).
    """
    return run_closed_loop(world, explorer or Explorer(), seed=seed, duration=duration,
                           **kwargs)
