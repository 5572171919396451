"""The marker sensor interface, and an analytic marker sensor (chapters 01, 03, 05).

A *sensor* is any object with a method::

    read(world, pose, rng) -> Observations

that returns what the robot's camera reports when the robot stands at ``pose``
(``[x, y, theta]`` in the z-down world frame N) in ``world``
(:class:`slamlib.worlds.World`), drawing its noise from ``rng``
(a :class:`numpy.random.Generator`). The simulator (:mod:`slamlib.sim`) fills
in the capture time. A sensor may also have the attributes ``rate`` (frames
per second, default 10) and ``latency`` (seconds between capture and arrival,
default 0), and a method ``R(rho)`` giving the 2x2 covariance of a reading at
range ``rho`` that a filter should use.

Two sensors share this interface:

- :class:`AnalyticMarkerSensor` (here): geometry plus Gaussian noise, fast,
  with optional misread ids and spurious outliers; the filters' chapters use it;
- the camera sensor of :mod:`slamlib.vision` (chapter 02): renders the camera
  image and detects the markers with OpenCV.

Every reading ``z = [rho, beta]`` is in the robot frame B, measured from the
robot's origin (not the camera's): ``rho`` the horizontal range (m) and
``beta`` the bearing (rad, positive to the robot's right, z-down).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from .models import range_bearing, wrap
from .validate import as_finite_scalar, as_positive, as_vector

__all__ = ["Observations", "AnalyticMarkerSensor", "CAMERA_OFFSET", "DEFAULT_FOV_HALF_ANGLE",
           "ARUCO_ORIGINAL_IDS", "visible_markers"]

#: Position ``(x, y)`` of the camera in the robot frame B (m): 0.122 m forward,
#: 0.033 m to the left (z-down: y positive to the right).
CAMERA_OFFSET = (0.122, -0.033)
#: Horizontal half field of view of a 640x480 camera with f = 525 px: atan(320/525).
DEFAULT_FOV_HALF_ANGLE = math.atan(320.0 / 525.0)
#: Number of ids in DICT_ARUCO_ORIGINAL (ids 0..1023).
ARUCO_ORIGINAL_IDS = 1024


@dataclass
class Observations:
    """What a marker sensor reports for one camera frame.

    Attributes
    ----------
    t : float
        Capture time (s); the simulator fills it in (NaN until then).
    ids : numpy.ndarray, shape (k,), int
        The ids as read (a misread id differs from ``true_ids``).
    z : numpy.ndarray, shape (k, 2)
        ``[rho, beta]`` of each reading (m, rad) in the robot frame, from the
        robot's origin, noise included.
    true_ids : numpy.ndarray, shape (k,), int
        The marker that really produced each reading; -1 for a spurious outlier.
    z_true : numpy.ndarray, shape (k, 2), optional
        The noise-free ``[rho, beta]`` (NaN for an outlier); None if unknown
        (a real camera).
    t_arrival : float, optional
        When the frame reached the filter (capture time + latency); None if
        not known yet.
    """

    t: float
    ids: np.ndarray
    z: np.ndarray
    true_ids: np.ndarray
    z_true: np.ndarray | None = None
    t_arrival: float | None = None

    def __post_init__(self):
        self.ids = np.asarray(self.ids, dtype=np.int64).reshape(-1)
        self.z = np.asarray(self.z, dtype=float).reshape(-1, 2)
        self.true_ids = np.asarray(self.true_ids, dtype=np.int64).reshape(-1)
        k = self.ids.shape[0]
        if self.z.shape[0] != k or self.true_ids.shape[0] != k:
            raise ValueError(f"Observations: ids ({k}), z ({self.z.shape[0]}) and true_ids "
                             f"({self.true_ids.shape[0]}) must have the same length")
        if self.z_true is not None:
            self.z_true = np.asarray(self.z_true, dtype=float).reshape(-1, 2)
            if self.z_true.shape[0] != k:
                raise ValueError(f"Observations: z_true has {self.z_true.shape[0]} rows, "
                                 f"expected {k}")

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    @classmethod
    def _of_checked(cls, t: float, ids: np.ndarray, z: np.ndarray, true_ids: np.ndarray,
                    z_true: np.ndarray | None, t_arrival: float | None) -> Observations:
        """A frame from arrays already of the right types and shapes (int64 (k,), float
        (k, 2)), e.g. slices of checked camera rows: the same object, without the checks."""
        obs = object.__new__(cls)
        obs.t, obs.ids, obs.z, obs.true_ids = t, ids, z, true_ids
        obs.z_true, obs.t_arrival = z_true, t_arrival
        return obs

    @classmethod
    def empty(cls, t: float = float("nan")) -> Observations:
        """A frame with no reading."""
        return cls(t, np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0, np.int64),
                   np.zeros((0, 2)))


def _camera_positions(pose: np.ndarray, offset) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([pose[0] + c * offset[0] - s * offset[1],
                     pose[1] + s * offset[0] + c * offset[1]])


class _Geometry:
    """A world's marker arrays, computed once (the simulator reads the same world every frame)."""

    __slots__ = ("n", "ids", "positions", "yaws", "normals")

    def __init__(self, world):
        self.n = len(world.markers)
        self.ids = world.ids
        self.positions = world.positions
        self.yaws = world.yaws
        self.normals = np.column_stack([np.cos(self.yaws), np.sin(self.yaws)])


def visible_markers(world, pose, *, fov_half_angle: float = DEFAULT_FOV_HALF_ANGLE,
                    min_range: float = 0.2, max_range: float = 4.0,
                    max_view_angle: float = math.radians(75.0),
                    camera_offset=CAMERA_OFFSET) -> np.ndarray:
    """Which markers of ``world`` the camera can see from ``pose`` (chapter 02/03).

    A marker is visible when, measured from the camera (at ``camera_offset``
    in the robot frame, looking along the robot's x axis):

    - its centre lies within the horizontal field of view, ``|bearing| < fov_half_angle``;
    - its horizontal distance is in ``[min_range, max_range]``;
    - the camera is on its printed side and the viewing angle (between the
      marker's outward normal and the line from the marker to the camera) is
      below ``max_view_angle``.

    Returns
    -------
    numpy.ndarray of bool, shape (n,)
        One flag per marker, in the order of ``world.ids``.
    """
    pose = as_vector("pose", pose, 3)
    if len(world.markers) == 0:
        return np.zeros(0, dtype=bool)
    return _visible(_Geometry(world), pose[None, :], fov_half_angle, min_range, max_range,
                    max_view_angle, camera_offset)[0]


def _visible(geo: _Geometry, poses: np.ndarray, fov_half_angle, min_range, max_range,
             max_view_angle, camera_offset) -> np.ndarray:
    """:func:`visible_markers` from each of F checked poses (F, 3): flags (F, n)."""
    cam = np.array([_camera_positions(p, camera_offset) for p in poses]).reshape(-1, 2)
    d = geo.positions[None, :, :] - cam[:, None, :]        # camera -> marker
    dist, bearing_cam = range_bearing(d[:, :, 0], d[:, :, 1], poses[:, 2:3])
    safe = np.where(dist > 0.0, dist, 1.0)
    cos_view = -(geo.normals[None, :, :] * d).sum(axis=2) / safe   # normal . (camera - marker)
    return ((np.abs(bearing_cam) < fov_half_angle) & (dist >= min_range)
            & (dist <= max_range) & (dist > 0.0)
            & (cos_view > math.cos(max_view_angle)))


@dataclass
class AnalyticMarkerSensor:
    """A marker sensor made of geometry and Gaussian noise (chapters 01, 03, 05, 08).

    Which markers are seen is decided by :func:`visible_markers` (field of
    view, range and viewing angle, all from the camera). Each seen marker gives
    a reading ``z = [rho, beta]`` from the robot's origin with

    - range noise ``N(bias, sigma_rho^2)``, ``sigma_rho = sigma_range0 +
      sigma_range_per_m * rho`` and ``bias = range_bias_per_m2 * rho^2``
      (a detector's ranges come out too long, growing with distance squared;
      default 0);
    - bearing noise ``N(0, sigma_bearing^2)``.

    Faults, each drawn independently per reading or frame:

    - with probability ``p_misread`` the id is misread: replaced by another id
      of the world (fraction ``misread_in_world`` of the misreads) or by a
      random id of the dictionary that is not the true one;
    - with probability ``p_outlier`` per frame a spurious reading is added
      (``true_id = -1``): range uniform in ``[min_range, max_range]``, bearing
      uniform in the field of view, id drawn like a misread.

    The sensor draws a fixed number of random numbers per marker of the world
    and per frame, whatever its fault probabilities, so that switching the
    faults on changes the ids and nothing else: the noise on every true
    reading stays the same for the same generator state.

    Parameters
    ----------
    fov_half_angle : float
        Horizontal half field of view (rad); default ``atan(320/525)``, about
        31.4 degrees, a 640x480 camera with f = 525 px.
    min_range, max_range : float
        Distance limits from the camera (m).
    max_view_angle : float
        Largest angle between the marker's normal and the line to the camera (rad).
    camera_offset : tuple of float
        Camera position ``(x, y)`` in the robot frame (m).
    sigma_range0, sigma_range_per_m : float
        Range noise standard deviation ``sigma_range0 + sigma_range_per_m * rho``.
    range_bias_per_m2 : float
        Range bias ``range_bias_per_m2 * rho^2`` (m).
    sigma_bearing : float
        Bearing noise standard deviation (rad).
    p_misread, misread_in_world, p_outlier : float
        Fault probabilities (see above).
    rate : float
        Frames per second.
    latency : float
        Seconds from capture to arrival at the filter.
    """

    fov_half_angle: float = DEFAULT_FOV_HALF_ANGLE
    min_range: float = 0.2
    max_range: float = 4.0
    max_view_angle: float = math.radians(75.0)
    camera_offset: tuple[float, float] = CAMERA_OFFSET
    sigma_range0: float = 0.02
    sigma_range_per_m: float = 0.01
    range_bias_per_m2: float = 0.0
    sigma_bearing: float = math.radians(1.0)
    p_misread: float = 0.0
    misread_in_world: float = 0.5
    p_outlier: float = 0.0
    rate: float = 10.0
    latency: float = 0.0
    dictionary_size: int = field(default=ARUCO_ORIGINAL_IDS)

    def __post_init__(self):
        as_positive("fov_half_angle", self.fov_half_angle)
        if not self.fov_half_angle < math.pi:
            raise ValueError(f"fov_half_angle: expected < pi, got {self.fov_half_angle}")
        lo = as_finite_scalar("min_range", self.min_range)
        hi = as_positive("max_range", self.max_range)
        if not 0.0 <= lo < hi:
            raise ValueError(f"min_range, max_range: expected 0 <= min_range < max_range, "
                             f"got {lo}, {hi}")
        as_positive("max_view_angle", self.max_view_angle)
        self.camera_offset = tuple(float(v) for v in as_vector("camera_offset",
                                                               self.camera_offset, 2))
        for name in ("sigma_range0", "sigma_range_per_m", "sigma_bearing"):
            if as_finite_scalar(name, getattr(self, name)) < 0.0:
                raise ValueError(f"{name}: expected a standard deviation >= 0, "
                                 f"got {getattr(self, name)}")
        as_finite_scalar("range_bias_per_m2", self.range_bias_per_m2)
        for name in ("p_misread", "misread_in_world", "p_outlier"):
            p = as_finite_scalar(name, getattr(self, name))
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"{name}: expected a probability in [0, 1], got {p}")
        as_positive("rate", self.rate)
        if as_finite_scalar("latency", self.latency) < 0.0:
            raise ValueError(f"latency: expected >= 0 s, got {self.latency}")
        if int(self.dictionary_size) < 2:
            raise ValueError(f"dictionary_size: expected >= 2, got {self.dictionary_size}")

    # ------------------------------------------------------------------ noise model
    def sigma_range(self, rho):
        """Range noise standard deviation at range ``rho`` (m)."""
        return self.sigma_range0 + self.sigma_range_per_m * np.asarray(rho, dtype=float)

    def range_bias(self, rho):
        """Range bias at range ``rho`` (m)."""
        return self.range_bias_per_m2 * np.asarray(rho, dtype=float) ** 2

    def R(self, rho: float) -> np.ndarray:
        """The 2x2 covariance of a reading at range ``rho`` that a filter should use.

        ``diag(sigma_rho^2, sigma_bearing^2)`` with ``sigma_rho = sigma_range0 +
        sigma_range_per_m * rho`` (the bias is not noise: correct it, or it
        shows up as inconsistency).
        """
        rho = as_finite_scalar("rho", rho)
        return np.diag([float(self.sigma_range(max(rho, 0.0))) ** 2, self.sigma_bearing ** 2])

    def R_batch(self, rho) -> np.ndarray:
        """:meth:`R` of each range in ``rho`` (shape (k,)), stacked: shape (k, 2, 2)."""
        rho = np.asarray(rho, dtype=float).reshape(-1)
        if not np.all(np.isfinite(rho)):
            return np.stack([self.R(r) for r in rho])        # the error R gives
        out = np.zeros((rho.size, 2, 2))
        # the same operations as R, element by element (x ** 2 is x * x, correctly rounded)
        s = self.sigma_range(np.maximum(rho, 0.0))
        with np.errstate(over="ignore"):        # an absurd range: inf, which the filter refuses
            out[:, 0, 0] = s * s
        out[:, 1, 1] = self.sigma_bearing ** 2
        return out

    def params(self) -> dict:
        """The parameters as a JSON-ready dict (for a run's ``meta.json``)."""
        d = asdict(self)
        d["camera_offset"] = list(self.camera_offset)
        return {"type": type(self).__name__, **d}

    @classmethod
    def from_params(cls, d: dict) -> AnalyticMarkerSensor:
        """Rebuild a sensor from :meth:`params`."""
        d = dict(d)
        kind = d.pop("type", cls.__name__)
        if kind != cls.__name__:
            raise ValueError(f"type: expected {cls.__name__!r}, got {kind!r}")
        return cls(**d)

    # ------------------------------------------------------------------ reading
    def visible(self, world, pose) -> np.ndarray:
        """Flags of the markers this sensor sees from ``pose`` (see :func:`visible_markers`)."""
        return visible_markers(world, pose, fov_half_angle=self.fov_half_angle,
                               min_range=self.min_range, max_range=self.max_range,
                               max_view_angle=self.max_view_angle,
                               camera_offset=self.camera_offset)

    def _wrong_id(self, true_id: int, world_ids: np.ndarray, u_kind: float, u_pick: float) -> int:
        others = world_ids[world_ids != true_id]
        if u_kind < self.misread_in_world and others.size:
            return int(others[min(int(u_pick * others.size), others.size - 1)])
        n = int(self.dictionary_size)
        if true_id < 0:                       # an outlier: any id of the dictionary
            return min(int(u_pick * n), n - 1)
        # a dictionary id other than true_id
        k = min(int(u_pick * (n - 1)), n - 2)
        return k + 1 if 0 <= true_id <= k else k

    def read(self, world, pose, rng: np.random.Generator) -> Observations:
        """One camera frame from ``pose`` in ``world`` (the capture time is left NaN).

        Readings come in the order of ``world.ids``, an outlier (if any) last.
        """
        pose = as_vector("pose", pose, 3)
        return self._read(_Geometry(world), pose, rng)

    def _read_rows(self, geo: _Geometry, poses: list, times: list, latency: float,
                   rng: np.random.Generator) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """The frames seen from ``poses`` at the capture ``times``, in order, all at once, as
        the columns of :class:`slamlib.runs.CameraRows` (one row per reading), and the
        number of readings of each frame.

        Per frame the same draws in the same order (a fixed number per marker and
        per frame), so reading a run's frames one by one (:meth:`_read`, as a
        closed-loop run must) or all at the end gives the same numbers bit for bit
        (``tests/test_fast_paths.py``). In a frame the readings come in the order
        of ``world.ids``, the outlier (if any) last.
        """
        F, n = len(poses), geo.n
        E = np.empty((F, n, 2))
        U = np.empty((F, n, 3))
        V = np.empty((F, 5))
        for f in range(F):           # fixed draws: the noise of marker i does not depend on faults
            E[f] = rng.standard_normal((n, 2))
            U[f] = rng.random((n, 3))
            V[f] = rng.random(5)
        P = np.array(poses, dtype=float).reshape(-1, 3)
        seen = _visible(geo, P, self.fov_half_angle, self.min_range, self.max_range,
                        self.max_view_angle, self.camera_offset)
        # the readings of every marker in every frame; only the seen ones are kept
        dx = geo.positions[None, :, 0] - P[:, 0:1]
        dy = geo.positions[None, :, 1] - P[:, 1:2]
        rho_t, beta_t = range_bearing(dx, dy, P[:, 2:3])
        rho = rho_t + self.range_bias(rho_t) + self.sigma_range(rho_t) * E[:, :, 0]
        rho = np.maximum(rho, 0.0)
        beta = wrap(beta_t + self.sigma_bearing * E[:, :, 1])
        world_ids = geo.ids.astype(np.int64)
        fi, mi = np.nonzero(seen)                # frame by frame, markers in world order
        true_ids = world_ids[mi]
        ids = true_ids.copy()
        if self.p_misread > 0.0:
            for r in np.flatnonzero(U[fi, mi, 0] < self.p_misread).tolist():
                ids[r] = self._wrong_id(int(true_ids[r]), world_ids, U[fi[r], mi[r], 1],
                                        U[fi[r], mi[r], 2])
        cols = {"t_capture": np.asarray(times, dtype=float).reshape(-1)[fi], "id": ids,
                "rho": rho[fi, mi], "bearing": beta[fi, mi], "true_id": true_ids,
                "true_rho": rho_t[fi, mi], "true_bearing": beta_t[fi, mi]}
        counts = np.bincount(fi, minlength=F)
        out = np.flatnonzero(V[:, 0] < self.p_outlier)
        if out.size:                             # one outlier, after the frame's readings
            u = V[out]
            at = np.cumsum(counts)[out]
            extra = {"t_capture": np.asarray(times, dtype=float).reshape(-1)[out],
                     "id": np.array([self._wrong_id(-1, world_ids, a, b)
                                     for a, b in zip(u[:, 3], u[:, 4])], dtype=np.int64),
                     "rho": self.min_range + u[:, 1] * (self.max_range - self.min_range),
                     "bearing": (2.0 * u[:, 2] - 1.0) * self.fov_half_angle,
                     "true_id": np.full(out.size, -1, dtype=np.int64),
                     "true_rho": np.full(out.size, np.nan),
                     "true_bearing": np.full(out.size, np.nan)}
            cols = {k: np.insert(v, at, extra[k]) for k, v in cols.items()}
            counts[out] += 1
        cols["t_arrival"] = cols["t_capture"] + latency
        return cols, counts

    def _read_frames(self, geo: _Geometry, poses: list, times: list, latency: float,
                     rng: np.random.Generator) -> list[Observations]:
        """:meth:`_read_rows` as one :class:`Observations` per frame (capture ``times``)."""
        cols, counts = self._read_rows(geo, poses, times, latency, rng)
        z = np.column_stack([cols["rho"], cols["bearing"]])
        z_true = np.column_stack([cols["true_rho"], cols["true_bearing"]])
        out = []
        a = 0
        for f, c in enumerate(counts.tolist()):
            obs = Observations(float(times[f]), cols["id"][a:a + c], z[a:a + c],
                               cols["true_id"][a:a + c], z_true[a:a + c])
            obs.t_arrival = times[f] + latency
            out.append(obs)
            a += c
        return out

    def _read(self, geo: _Geometry, pose: np.ndarray, rng: np.random.Generator) -> Observations:
        """:meth:`read` on a checked pose and the world's arrays: :meth:`_read_frames` of one
        frame, its times left unset."""
        obs = self._read_frames(geo, [pose], [float("nan")], 0.0, rng)[0]
        obs.t_arrival = None
        return obs
