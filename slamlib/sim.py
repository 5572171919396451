"""A simulated Kobuki: waypoint driving, wheel slip, wrapping encoders, a camera (chapter 01).

What the simulator does, one encoder period ``dt = 1/encoder_rate`` at a time:

1. the :class:`WaypointController` looks at the true pose and commands the
   wheels' rim speeds ``[V_R, V_L]`` (speed, turn-rate and acceleration
   limits), held for the period;
2. each wheel's *ground* speed is its rim speed plus a slip ``N(0,
   sigma_wheel^2)``, drawn per wheel and held for the period;
3. the true pose moves along the exact arc of the ground speeds
   (:func:`integrate_arc`): no integration error in the ground truth;
4. each encoder counts the *rim* angle, floored to whole ticks, in an unsigned
   16-bit counter that wraps around (:func:`encoder_counter`).

So the wheel speeds a filter computes from the ticks differ from the ground
speeds that moved the robot by the slip (white, variance ``sigma_wheel^2``
per wheel per period) plus the tick quantisation: ``Q = sigma_wheel^2 I``
(plus the quantisation variance, :meth:`slamlib.runs.Run.Q`) is the right
process noise for a filter that predicts once per encoder period.

A camera frame is captured every ``1/sensor.rate`` s at the pose on the arc
at that instant; it reaches the filter ``sensor.latency`` s later.

Randomness: ``np.random.default_rng(seed)`` spawns two child generators, one
for the motion (slip) and one for the sensing, so a run is fixed by its seed,
bit for bit, and changing the sensor (switching misreads on, say) never
changes the motion.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from .compiled import compiled
from .models import (
    KOBUKI_TICKS_PER_REV,
    KOBUKI_WHEEL_BASE,
    KOBUKI_WHEEL_RADIUS,
    _body_speeds,
    _wrap,
    wrap_angle,
)
from .runs import CAMERA_HEADER, CameraRows, Run
from .sensors import AnalyticMarkerSensor, Observations, _Geometry
from .validate import as_finite_scalar, as_matrix, as_positive, as_seed, as_vector
from .worlds import World

__all__ = ["KobukiParams", "WaypointController", "wheel_commands", "integrate_arc",
           "encoder_counter", "KobukiSim", "simulate", "arena_loop_waypoints", "loop_waypoints",
           "arena_laps_waypoints", "SCENARIOS", "STUDY_SCENARIOS", "scenario", "kobuki_params_dict"]


# --------------------------------------------------------------------------- pure pieces
def wheel_commands(v: float, w: float, wheel_base: float = KOBUKI_WHEEL_BASE
                   ) -> tuple[float, float]:
    """Body speeds to wheel speeds, the inverse of :func:`slamlib.models.body_velocity`.

    With ``w = (V_L - V_R)/b`` (z-down: positive w turns clockwise seen from
    above): ``V_R = v - w b/2`` and ``V_L = v + w b/2``.

    Returns
    -------
    (float, float)
        ``(V_R, V_L)`` in m/s.
    """
    half = 0.5 * w * wheel_base
    return v - half, v + half


_wheel_commands = compiled(wheel_commands)


def integrate_arc(pose, v: float, w: float, dt: float) -> np.ndarray:
    """Exact motion at constant ``v`` (m/s) and ``w`` (rad/s) for ``dt`` seconds (chapter 01).

    The unicycle ``x' = v cos(theta), y' = v sin(theta), theta' = w`` solved in
    closed form: an arc of radius ``v/w``, or a straight segment when ``w`` is
    (nearly) zero. Compare with the Euler step of
    :func:`slamlib.models.motion_model`, which keeps the start heading.

    Returns
    -------
    numpy.ndarray, shape (3,)
        The pose after ``dt``, heading wrapped to [-pi, pi).
    """
    x, y, th = arc(float(pose[0]), float(pose[1]), float(pose[2]), float(v),
                            float(w), float(dt))
    if not math.isfinite(th):
        raise ValueError(f"angle: expected finite numbers, got {th!r}")
    return np.array([x, y, th])


def encoder_counter(rim_angle: float, ticks_per_rev: float = KOBUKI_TICKS_PER_REV,
                    offset: int = 0, bits: int = 16) -> int:
    """The counter an encoder shows after its wheel turned ``rim_angle`` rad (chapter 01).

    Whole ticks passed (floor), plus the counter's initial value ``offset``,
    modulo ``2**bits``: a 16-bit counter wraps from 65535 to 0 going forwards
    and from 0 to 65535 going backwards.
    """
    return encoder_count(float(rim_angle), float(ticks_per_rev), int(offset), int(bits))


# --------------------------------------------------------------------------- the compiled loop
# The simulator's loop, one encoder period at a time: the controller, the slip, the camera's
# capture instants, the exact arc and the encoders. Each function is compiled by numba (its
# Python, with NUMBA_DISABLE_JIT=1); Python's min and max are written out (``min(a, b)`` is ``b``
# only if ``b < a``) so that ties give the same float as in Python.
@compiled
def _py_min(a: float, b: float) -> float:
    return b if b < a else a


@compiled
def _py_max(a: float, b: float) -> float:
    return b if b > a else a


@compiled
def arc(x: float, y: float, th: float, v: float, w: float, dt: float):
    """Exact motion at constant ``v`` and ``w`` for ``dt`` (``slamlib.sim.integrate_arc``).

    An arc of radius ``v/w`` or, when ``|w dt| < 1e-9``, its second-order
    expansion (a segment at the mid heading); heading wrapped.
    """
    dth = w * dt
    if abs(dth) < 1e-9:
        c, s = math.cos(th + 0.5 * dth), math.sin(th + 0.5 * dth)
        return x + v * dt * c, y + v * dt * s, _wrap(th + dth)
    r = v / w
    th1 = th + dth
    return (x + r * (math.sin(th1) - math.sin(th)), y - r * (math.cos(th1) - math.cos(th)),
            _wrap(th1))


@compiled
def encoder_count(rim_angle: float, ticks_per_rev: float, offset: int, bits: int) -> int:
    """The counter after the wheel turned ``rim_angle`` (``slamlib.sim.encoder_counter``):
    whole ticks (floor) plus ``offset``, modulo ``2**bits``."""
    ticks = int(math.floor(rim_angle * ticks_per_rev / (2.0 * math.pi)))
    return (ticks + offset) % (1 << bits)


@compiled
def waypoint_command(wp, index: int, v: float, w: float, px: float, py: float, th: float,
                     dt: float, b: float, v_max: float, w_max: float, k_heading: float,
                     accel: float, alpha: float, tolerance: float, turn_in_place: float):
    """One call of ``WaypointController.command``: returns ``(index, v, w, V_R, V_L)``.

    Skip the waypoints within ``tolerance``; aim at the next one (``w = k e``
    clipped to ``w_max``, ``v = v_max cos e``, zero beyond ``turn_in_place``,
    braking on the final approach); both speeds rate-limited; wheel speeds
    ``v -/+ w b/2``.
    """
    n = wp.shape[0]
    while index < n:
        if math.hypot(wp[index, 0] - px, wp[index, 1] - py) > tolerance:
            break
        index += 1
    if index < n:
        dx, dy = wp[index, 0] - px, wp[index, 1] - py
        dist = math.hypot(dx, dy)
        e = _wrap(math.atan2(dy, dx) - th)
        w_des = _py_max(-w_max, _py_min(w_max, k_heading * e))
        v_des = 0.0 if abs(e) > turn_in_place else v_max * math.cos(e)
        if index == n - 1:                 # final approach: brake in time
            v_des = _py_min(v_des, math.sqrt(2.0 * accel * _py_max(dist - 0.5 * tolerance,
                                                                    0.0)))
    else:
        v_des = w_des = 0.0
    dv, dw = accel * dt, alpha * dt
    v += _py_max(-dv, _py_min(dv, v_des - v))
    w += _py_max(-dw, _py_min(dw, w_des - w))
    VR, VL = _wheel_commands(v, w, b)
    return index, v, w, VR, VL


@compiled
def sim_period(pose, VR: float, VL: float, eR: float, eL: float, k: int, next_frame: int,
               b: float, dt: float, sigma_wheel: float, encoder_rate: float,
               camera_rate: float, cap_j, cap_pose):
    """One encoder period of ``KobukiSim.step``: returns ``(next_frame, n_captured)``.

    The ground speeds are the rim speeds plus the slip ``sigma_wheel * [eR, eL]``;
    the camera frames ``j`` whose instant ``j / camera_rate`` falls in this
    period (none without a camera, ``camera_rate = 0``) are captured at the
    pose on the arc then (into ``cap_j``, ``cap_pose``); ``pose`` moves along
    the arc of the period.
    """
    v, w = _body_speeds(VR + sigma_wheel * eR, VL + sigma_wheel * eL, b)   # ground speeds
    x0, y0, th0 = pose[0], pose[1], pose[2]
    n = 0
    while camera_rate > 0.0:
        x = next_frame * encoder_rate / camera_rate     # capture time in periods
        kk = int(math.floor(x + 1e-9))
        if kk > k:
            break
        frac = _py_max(x - k, 0.0) if kk == k else 0.0
        if frac < 1e-9:
            px, py, pth = x0, y0, th0
        else:
            px, py, pth = arc(x0, y0, th0, v, w, frac * dt)
        cap_j[n] = next_frame
        cap_pose[n, 0], cap_pose[n, 1], cap_pose[n, 2] = px, py, pth
        n += 1
        next_frame += 1
    pose[0], pose[1], pose[2] = arc(x0, y0, th0, v, w, dt)
    return next_frame, n


@compiled
def drive_waypoints(wp, control, pose, state, angles, slip, n_max: int, b: float, r: float,
                    dt: float, sigma_wheel: float, encoder_rate: float, camera_rate: float,
                    ticks_per_rev: float, bits: int, off_R: int, off_L: int,
                    times, poses, ticks, cap_j, cap_pose):
    """``simulate``'s loop (command, then one period) while ``state[0] < n_max``, the path is
    not finished and slip rows remain; returns ``(periods done, frames captured)``.

    ``control = [index, v, w, v_max, w_max, k_heading, accel, alpha, tolerance,
    turn_in_place]`` (the first three updated), ``state = [k, next_frame]``,
    ``angles`` the rim angles; each period's time, pose and counters go to
    ``times``, ``poses``, ``ticks``, its frames to ``cap_j``, ``cap_pose``.
    """
    index, v, w = int(control[0]), control[1], control[2]
    k, next_frame = state[0], state[1]
    n_wp = wp.shape[0]
    done = 0
    ncap = 0
    while k < n_max and done < slip.shape[0]:
        if index >= n_wp and v == 0.0 and w == 0.0:
            break
        index, v, w, VR, VL = waypoint_command(
            wp, index, v, w, pose[0], pose[1], pose[2], dt, b, control[3], control[4],
            control[5], control[6], control[7], control[8], control[9])
        next_frame, n = sim_period(pose, VR, VL, slip[done, 0], slip[done, 1], k, next_frame,
                                   b, dt, sigma_wheel, encoder_rate, camera_rate,
                                   cap_j[ncap:], cap_pose[ncap:])
        ncap += n
        angles[0] += VR * dt / r
        angles[1] += VL * dt / r
        k += 1
        times[done] = k / encoder_rate
        poses[done, 0], poses[done, 1], poses[done, 2] = pose[0], pose[1], pose[2]
        ticks[done, 0] = encoder_count(angles[0], ticks_per_rev, off_R, bits)
        ticks[done, 1] = encoder_count(angles[1], ticks_per_rev, off_L, bits)
        done += 1
    control[0], control[1], control[2] = index, v, w
    state[0], state[1] = k, next_frame
    return done, ncap


# --------------------------------------------------------------------------- robot
@dataclass(frozen=True)
class KobukiParams:
    """The simulated Kobuki's wheels, encoders and slip (chapter 01).

    Attributes
    ----------
    wheel_base, wheel_radius : float
        b and r (m).
    ticks_per_rev : float
        Encoder ticks per wheel revolution.
    encoder_rate : float
        Encoder sampling rate (Hz); also the simulation step.
    bits : int
        Counter width (the counters wrap modulo ``2**bits``).
    sigma_wheel : float
        Standard deviation of each wheel's slip speed (m/s), white, held for
        one encoder period.
    initial_ticks : tuple of int
        The counters' values at t = 0 ``(right, left)``; the default puts the
        right counter close to its wrap so that it wraps within a second.
    """

    wheel_base: float = KOBUKI_WHEEL_BASE
    wheel_radius: float = KOBUKI_WHEEL_RADIUS
    ticks_per_rev: float = KOBUKI_TICKS_PER_REV
    encoder_rate: float = 50.0
    bits: int = 16
    sigma_wheel: float = 0.02
    initial_ticks: tuple[int, int] = (65_300, 12_000)

    def __post_init__(self):
        for name in ("wheel_base", "wheel_radius", "ticks_per_rev", "encoder_rate"):
            as_positive(name, getattr(self, name))
        if as_finite_scalar("sigma_wheel", self.sigma_wheel) < 0.0:
            raise ValueError(f"sigma_wheel: expected a standard deviation >= 0, "
                             f"got {self.sigma_wheel}")
        if not isinstance(self.bits, int) or not 1 <= self.bits <= 62:
            raise ValueError(f"bits: expected an integer in 1..62, got {self.bits!r}")
        if len(self.initial_ticks) != 2 or any(
                not 0 <= int(v) < (1 << self.bits) for v in self.initial_ticks):
            raise ValueError(f"initial_ticks: expected two counters in [0, 2**bits), "
                             f"got {self.initial_ticks!r}")

    @property
    def dt(self) -> float:
        """Encoder period (s)."""
        return 1.0 / self.encoder_rate


@dataclass
class WaypointController:
    """Drive through waypoints: turn towards the next one, go, slow down at the end (ch. 01).

    At each call of :meth:`command` (once per encoder period) the controller
    aims at the current waypoint: turn rate ``w = k_heading * e`` for the
    heading error ``e`` (clipped to ``w_max``), forward speed ``v_max *
    cos(e)`` (zero when ``|e| > turn_in_place``, and slower on the final
    approach), both rate-limited by ``accel`` and ``alpha``. A waypoint is
    reached within ``tolerance``; after the last one the robot stops.

    The controller steers by the *true* pose: it stands for a robot that
    follows its path well, so that every run of a scenario drives the same
    path whatever its noise.

    Attributes
    ----------
    waypoints : array_like, shape (n, 2)
        Points to pass, in N.
    v_max, w_max : float
        Speed (m/s) and turn-rate (rad/s) limits.
    accel, alpha : float
        Linear (m/s^2) and angular (rad/s^2) acceleration limits.
    """

    waypoints: np.ndarray
    v_max: float = 0.2
    w_max: float = 0.7
    k_heading: float = 1.8
    accel: float = 0.4
    alpha: float = 2.0
    tolerance: float = 0.10
    turn_in_place: float = math.radians(50.0)
    index: int = field(default=0, init=False)
    _v: float = field(default=0.0, init=False, repr=False)
    _w: float = field(default=0.0, init=False, repr=False)

    def __post_init__(self):
        self.waypoints = as_matrix("waypoints", self.waypoints, (None, 2)).copy()
        if self.waypoints.shape[0] == 0:
            raise ValueError("waypoints: expected at least one waypoint")
        for name in ("v_max", "w_max", "k_heading", "accel", "alpha", "tolerance",
                     "turn_in_place"):
            as_positive(name, getattr(self, name))

    def reset(self) -> None:
        """Back to the first waypoint, at rest."""
        self.index, self._v, self._w = 0, 0.0, 0.0

    def set_waypoints(self, waypoints) -> None:
        """Follow new waypoints from the current speeds (the robot keeps moving; chapter 07).

        An exploration policy changes its goal while driving: the speeds stay
        continuous, only the path changes.
        """
        wp = as_matrix("waypoints", waypoints, (None, 2)).copy()
        if wp.shape[0] == 0:
            raise ValueError("waypoints: expected at least one waypoint")
        self.waypoints, self.index = wp, 0

    @property
    def done(self) -> bool:
        """True once the last waypoint is reached and the robot has stopped."""
        return self.index >= self.waypoints.shape[0] and self._v == 0.0 and self._w == 0.0

    def params(self) -> dict:
        """The parameters as a JSON-ready dict."""
        return {"type": type(self).__name__, "waypoints": self.waypoints.tolist(),
                "v_max": self.v_max, "w_max": self.w_max, "k_heading": self.k_heading,
                "accel": self.accel, "alpha": self.alpha, "tolerance": self.tolerance,
                "turn_in_place": self.turn_in_place}

    def command(self, pose, dt: float, wheel_base: float = KOBUKI_WHEEL_BASE
                ) -> tuple[float, float]:
        """Wheel speed commands ``(V_R, V_L)`` (m/s) for the next ``dt`` seconds."""
        self.index, self._v, self._w, VR, VL = waypoint_command(
            self.waypoints, self.index, self._v, self._w, float(pose[0]), float(pose[1]),
            float(pose[2]), float(dt), float(wheel_base), *self._gains())
        return VR, VL

    def _gains(self) -> tuple[float, ...]:
        """``(v_max, w_max, k_heading, accel, alpha, tolerance, turn_in_place)``."""
        return (float(self.v_max), float(self.w_max), float(self.k_heading), float(self.accel),
                float(self.alpha), float(self.tolerance), float(self.turn_in_place))


# --------------------------------------------------------------------------- paths
def arena_loop_waypoints() -> np.ndarray:
    """The loop in the report's arena (chapters 01, 03, 05).

    From the start pose (3.0, -0.78) heading +y, the robot drives around the
    central post (markers 41/51), along the markers 21/31, 81, 71, 0 and 1,
    and comes back along its first leg, past the first markers it saw, so that
    a SLAM filter closes the loop. About 13 m, a little over a minute.
    """
    return np.array([
        [3.05, 0.60], [2.95, 2.00], [1.90, 2.30], [0.95, 2.05], [0.75, 1.00],
        [0.95, 0.00], [1.90, -0.65], [2.80, -0.90], [3.05, 0.30], [3.00, 1.50],
    ])


def loop_waypoints(bounds, margin: float = 0.8, count: int = 10, overlap: int = 2
                   ) -> np.ndarray:
    """A closed loop of ``count`` points on an ellipse inside ``bounds``, plus ``overlap``
    points of a second lap (so the robot passes its start again), for random worlds.

    The loop runs clockwise seen from above (positive angles in z-down).
    """
    xmin, xmax, ymin, ymax = (float(v) for v in bounds)
    cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
    ax, ay = 0.5 * (xmax - xmin) - margin, 0.5 * (ymax - ymin) - margin
    if ax <= 0 or ay <= 0:
        raise ValueError(f"margin: {margin} m leaves no room inside bounds {bounds}")
    a = np.pi + 2.0 * np.pi * np.arange(count + overlap + 1) / count
    return np.column_stack([cx + ax * np.cos(a), cy + ay * np.sin(a)])


# --------------------------------------------------------------------------- the simulator
def _sensor_params(sensor) -> dict:
    if sensor is None:
        return {}
    if hasattr(sensor, "params"):
        return sensor.params()
    return {"type": type(sensor).__name__}


class KobukiSim:
    """The simulated Kobuki, one encoder period at a time (the loop inside :func:`simulate`).

    ``sim.step(V_R, V_L)`` holds the wheel commands for one period ``params.dt``:
    it draws the slip, captures the camera frames that fall in the period,
    moves the true pose along the exact arc and counts the ticks (steps 2-4 of
    the module docstring). Who chooses the commands is up to the caller:
    :func:`simulate` asks a :class:`WaypointController` that looks at the true
    pose; the exploration of chapter 07 (:mod:`slamlib.explore`) asks a policy
    that looks at a filter's estimate. Both share this code, so a closed-loop
    run is recorded exactly like an open-loop one.

    Attributes
    ----------
    pose : numpy.ndarray (3,)
        The true pose now.
    k : int
        Periods simulated so far (the time is ``t = k / encoder_rate``).
    times, poses, ticks_R, ticks_L, frames : list
        What has been recorded so far (see :meth:`record`).
    """

    def __init__(self, world: World, *, sensor=None, seed: int = 0,
                 params: KobukiParams | None = None, start_pose=None,
                 defer_reads: bool = False):
        self.world = world
        self.sensor = sensor
        self.params = params = params or KobukiParams()
        if start_pose is None:
            if world.start_pose is None:
                raise ValueError("start_pose: the world has none; pass start_pose=[x, y, theta]")
            start_pose = world.start_pose
        pose = as_vector("start_pose", start_pose, 3).copy()
        pose[2] = wrap_angle(pose[2])
        self.seed = as_seed("seed", seed)
        self._rng_motion, self._rng_sense = np.random.default_rng(int(seed)).spawn(2)
        self._rate = float(getattr(sensor, "rate", 10.0)) if sensor is not None else 0.0
        self._latency = float(getattr(sensor, "latency", 0.0)) if sensor is not None else 0.0
        self.pose = pose
        self.k = 0
        self.times, self.poses = [0.0], [pose.copy()]
        self._angle_R = self._angle_L = 0.0
        tpr, bits, off = params.ticks_per_rev, params.bits, params.initial_ticks
        self.ticks_R = [encoder_counter(0.0, tpr, off[0], bits)]
        self.ticks_L = [encoder_counter(0.0, tpr, off[1], bits)]
        self.frames: list[Observations] = []
        self._geometry = (_Geometry(world) if isinstance(sensor, AnalyticMarkerSensor)
                          and type(sensor).read is AnalyticMarkerSensor.read else None)
        self._next_frame = 0            # index j of the next camera frame, at t = j / rate
        # The analytic sensor's frames may be read at the end, all at once (simulate: nobody
        # looks at them during the run): the same draws in the same order, the same numbers.
        self._deferred: list | None = [] if defer_reads and self._geometry is not None else None
        self._deferred_rows: list[dict] = []    # their readings, once read (record)
        self._slip: list = []           # standard normal pairs drawn ahead (the same sequence)
        # at most this many camera frames fall in one encoder period
        self._max_frames = int(math.ceil(self._rate / params.encoder_rate)) + 1

    @property
    def t(self) -> float:
        """The simulated time now (s)."""
        return self.times[-1]

    def _capture(self, j: int, p: np.ndarray) -> Observations | None:
        if self._deferred is not None:          # read in record(), with the other frames
            self._deferred.append((j, p))
            return None
        if self._geometry is not None:          # the analytic sensor: the world's arrays once
            obs = self.sensor._read(self._geometry, p, self._rng_sense)
        else:
            obs = self.sensor.read(self.world, p, self._rng_sense)
        t = j / self._rate
        obs.t, obs.t_arrival = t, t + self._latency
        self.frames.append(obs)
        return obs

    def step(self, VR: float, VL: float) -> list[Observations]:
        """Drive one encoder period with the rim speeds ``(V_R, V_L)`` (m/s).

        Returns
        -------
        list of Observations
            The camera frames captured during this period ``[k dt, (k+1) dt)``
            (usually none or one), each with its capture time ``t`` set.
        """
        if not (math.isfinite(VR) and math.isfinite(VL)):
            raise ValueError(f"VR, VL: expected finite wheel speeds, got {VR!r}, {VL!r}")
        params, k = self.params, self.k
        b, r, dt = params.wheel_base, params.wheel_radius, params.dt
        if not self._slip:              # 2 normals per period, 256 periods at a time
            self._slip = self._rng_motion.standard_normal((256, 2)).tolist()[::-1]
        eR, eL = self._slip.pop()
        pose = self.pose.copy()
        cap_j = np.empty(self._max_frames, dtype=np.int64)
        cap_pose = np.empty((self._max_frames, 3))
        self._next_frame, n = sim_period(
            pose, float(VR), float(VL), eR, eL, k, self._next_frame, b, dt, params.sigma_wheel,
            params.encoder_rate, self._rate if self.sensor is not None else 0.0, cap_j, cap_pose)
        captured = []
        for i in range(n):
            obs = self._capture(int(cap_j[i]), cap_pose[i].copy())
            if obs is not None:
                captured.append(obs)
        self.pose = pose
        self._angle_R += VR * dt / r
        self._angle_L += VL * dt / r
        self.k = k = k + 1
        tpr, bits, off = params.ticks_per_rev, params.bits, params.initial_ticks
        self.times.append(k / params.encoder_rate)
        self.poses.append(self.pose)
        self.ticks_R.append(encoder_counter(self._angle_R, tpr, off[0], bits))
        self.ticks_L.append(encoder_counter(self._angle_L, tpr, off[1], bits))
        return captured

    def drive(self, controller: WaypointController, n_max: int) -> None:
        """``step(*controller.command(pose, dt))`` until ``n_max`` periods or the path's end.

        The same periods, draws and numbers as that loop in Python, bit for bit,
        run by the compiled :func:`drive_waypoints` 256 periods
        (one draw of slip) at a time when nothing needs the frames during the
        run (no camera, or the analytic sensor's deferred reads); else that loop.
        """
        params = self.params
        if type(controller) is not WaypointController or not (
                self.sensor is None or self._deferred is not None):
            while self.k < n_max and not controller.done:
                self.step(*controller.command(self.pose, params.dt, params.wheel_base))
            return
        control = np.array([controller.index, controller._v, controller._w,
                            *controller._gains()], dtype=float)
        state = np.array([self.k, self._next_frame], dtype=np.int64)
        angles = np.array([self._angle_R, self._angle_L])
        pose = self.pose.copy()
        rate = self._rate if self.sensor is not None else 0.0
        off = params.initial_ticks
        wp = np.ascontiguousarray(controller.waypoints, dtype=float)
        while self.k < n_max and not controller.done:
            if not self._slip:
                self._slip = self._rng_motion.standard_normal((256, 2)).tolist()[::-1]
            slip = np.array(self._slip[::-1])
            m = slip.shape[0]
            times, poses, ticks = np.empty(m), np.empty((m, 3)), np.empty((m, 2), dtype=np.int64)
            cap_j = np.empty(m * self._max_frames, dtype=np.int64)
            cap_pose = np.empty((m * self._max_frames, 3))
            done, ncap = drive_waypoints(
                wp, control, pose, state, angles, slip, n_max, params.wheel_base,
                params.wheel_radius, params.dt, params.sigma_wheel, params.encoder_rate, rate,
                float(params.ticks_per_rev), int(params.bits), int(off[0]), int(off[1]),
                times, poses, ticks, cap_j, cap_pose)
            del self._slip[len(self._slip) - done:]
            controller.index, controller._v, controller._w = (int(control[0]), float(control[1]),
                                                              float(control[2]))
            self.k, self._next_frame = int(state[0]), int(state[1])
            self._angle_R, self._angle_L = float(angles[0]), float(angles[1])
            self.pose = pose.copy()
            self.times.extend(times[:done].tolist())
            self.poses.extend(poses[:done])
            self.ticks_R.extend(ticks[:done, 0].tolist())
            self.ticks_L.extend(ticks[:done, 1].tolist())
            for i in range(ncap):
                self._capture(int(cap_j[i]), cap_pose[i].copy())

    def record(self, *, name: str | None = None, description: str = "",
               controller: dict | None = None, finished: bool = False) -> Run:
        """Everything simulated so far as a :class:`~slamlib.runs.Run`.

        ``controller`` (the parameters of whatever chose the commands) and
        ``finished`` go into the run's meta.
        """
        params = self.params
        if self._deferred is None:
            camera = CameraRows.from_frames(self.frames)
        else:
            if self._deferred:          # the analytic sensor's frames, read now, all at once
                frames, self._deferred = self._deferred, []
                cols, _ = self.sensor._read_rows(
                    self._geometry, [p for _, p in frames], [j / self._rate for j, _ in frames],
                    self._latency, self._rng_sense)
                self._deferred_rows.append(cols)
            camera = CameraRows(**{k: np.concatenate([c[k] for c in self._deferred_rows])
                                   for k in CAMERA_HEADER}) if self._deferred_rows else \
                CameraRows.from_frames([])
        t = np.array(self.times)
        meta = {
            "world": self.world.name, "seed": self.seed, "duration": float(t[-1]),
            "description": description,
            "encoder": {"rate": params.encoder_rate, "ticks_per_rev": params.ticks_per_rev,
                        "bits": params.bits, "wheel_radius": params.wheel_radius,
                        "wheel_base": params.wheel_base},
            "motion": {"sigma_wheel": params.sigma_wheel, "kobuki": kobuki_params_dict(params),
                       "model": "ground speed = rim speed + N(0, sigma_wheel^2) per wheel, "
                                "held for each encoder period; exact arcs"},
            "sensor": _sensor_params(self.sensor),
            "controller": controller or {},
            "start_pose": [float(v) for v in self.poses[0]],
            "finished": bool(finished),
        }
        return Run(name=name or f"{self.world.name}_seed{self.seed}", truth_t=t,
                   truth=np.array(self.poses), enc_t=t, ticks_R=np.array(self.ticks_R),
                   ticks_L=np.array(self.ticks_L), camera=camera,
                   meta=meta)


def simulate(world: World, controller: WaypointController, *, sensor=None, seed: int = 0,
             params: KobukiParams | None = None, start_pose=None, max_duration: float = 300.0,
             name: str | None = None, description: str = "") -> Run:
    """Drive the simulated Kobuki through ``world`` and record a :class:`~slamlib.runs.Run`.

    The controller steers by the true pose (open loop as far as any filter is
    concerned); :mod:`slamlib.explore` closes the loop through a filter with
    the same :class:`KobukiSim`.

    Parameters
    ----------
    world : World
        Where the robot drives (its markers are what the sensor sees).
    controller : WaypointController
        The path; it is reset first (a copy is used, the argument is not changed).
    sensor : object with ``read(world, pose, rng)``, optional
        The camera; ``None`` records no readings (the sensing generator is
        still spawned, so the motion is the same with or without a sensor).
    seed : int
        Fixes the run, bit for bit.
    params : KobukiParams, optional
        Wheels, encoders and slip (default ``KobukiParams()``).
    start_pose : array_like (3,), optional
        Default: the world's ``start_pose``.
    max_duration : float
        Stop after this many seconds even if the path is not finished.
    name, description : str
        Stored in the run's meta.

    Returns
    -------
    Run
    """
    as_positive("max_duration", max_duration)
    sim = KobukiSim(world, sensor=sensor, seed=seed, params=params, start_pose=start_pose,
                    defer_reads=True)
    ctl = replace(controller)
    ctl.reset()
    sim.drive(ctl, int(math.ceil(max_duration * sim.params.encoder_rate)))
    return sim.record(name=name, description=description, controller=ctl.params(),
                      finished=ctl.done)


def kobuki_params_dict(params: KobukiParams) -> dict:
    """``params`` as a JSON-ready dict."""
    d = asdict(params)
    d["initial_ticks"] = [int(v) for v in d["initial_ticks"]]
    return d


# --------------------------------------------------------------------------- recorded scenarios
#: The recorded runs of ``data/runs`` (``tools/make_runs.py`` writes them):
#: name -> (world, path, seed, sensor overrides, description).
SCENARIOS = {
    "arena_loop": ("report_arena", "arena", 1, {},
                   "The report's arena, one loop around the central post and back along the "
                   "first leg (loop closure on markers 21/31)."),
    "arena_loop_misreads": ("report_arena", "arena", 1, {"p_misread": 0.05},
                            "arena_loop with 5 % of the ids misread (half of them as another "
                            "marker of the world): the same motion and the same range/bearing "
                            "noise, only some ids differ."),
    "random_loop": ("random_16_seed4", "ellipse", 2, {},
                    "An elliptic loop and a bit through a random world of 16 markers facing "
                    "random directions."),
}


#: Scenarios for studies only (not recorded in ``data/runs``): name -> as :data:`SCENARIOS`.
STUDY_SCENARIOS = {
    "arena_laps": ("report_arena", "arena_laps", 1, {},
                   "The arena loop driven three times (chapter 06): the same waypoints, lap "
                   "after lap, so the heading uncertainty of the long stretches grows three "
                   "times as long and the filter closes the loop twice more."),
}


def arena_laps_waypoints(laps: int = 3) -> np.ndarray:
    """:func:`arena_loop_waypoints` driven ``laps`` times: each further lap goes from the
    first leg round the post again, and the last one ends like the single loop."""
    wp = arena_loop_waypoints()
    lap = np.vstack([wp[8:10], wp[1:8]])                  # back along the first leg, round again
    return np.vstack([wp[:8]] + [lap] * (int(laps) - 1) + [wp[8:10]])


def scenario(name: str, *, seed: int | None = None, sigma_wheel: float | None = None,
             sensor=None, **sensor_overrides) -> Run:
    """Simulate one of the recorded scenarios (:data:`SCENARIOS`), optionally changed.

    ``scenario("arena_loop")`` equals ``load_run("arena_loop")`` bit for bit;
    ``seed``, ``sigma_wheel``, a different ``sensor`` or sensor parameters
    (``p_misread=0.1``...) give variations of it (chapter 01's noise slider).
    """
    from .worlds import load_world

    known = {**SCENARIOS, **STUDY_SCENARIOS}
    if name not in known:
        raise ValueError(f"name: expected one of {sorted(known)}, got {name!r}")
    world_name, path, seed0, overrides, description = known[name]
    world = load_world(world_name)
    if path == "arena":
        waypoints = arena_loop_waypoints()
    elif path == "arena_laps":
        waypoints = arena_laps_waypoints(3)
    else:
        waypoints = loop_waypoints(world.bounds, margin=1.0)[1:]
    if sensor is None:
        sensor = AnalyticMarkerSensor(**{**overrides, **sensor_overrides})
    params = KobukiParams() if sigma_wheel is None else KobukiParams(sigma_wheel=sigma_wheel)
    return simulate(world, WaypointController(waypoints), sensor=sensor,
                    seed=seed0 if seed is None else seed, params=params, name=name,
                    description=description)
