"""The UTIAS MRCLAM data set, read from its original files (chapter 10).

K. Y. K. Leung, Y. Halpern, T. D. Barfoot and H. H. T. Liu, "The UTIAS
Multi-Robot Cooperative Localization and Mapping Dataset", International
Journal of Robotics Research 30(8), 2011. Five iRobot Create robots drive in a
room with 15 barcoded landmarks; each logs its commanded forward and angular
velocity, the range and bearing of the barcodes its camera reads, and a Vicon
system gives every robot's true pose.

Files (whitespace-separated columns, lines starting with ``#`` are comments;
a data set's folder holds all of them)::

    RobotN_Odometry.dat       time [s], forward velocity v [m/s], angular velocity w [rad/s]
    RobotN_Measurement.dat    time [s], barcode #, range [m], bearing [rad]
    RobotN_Groundtruth.dat    time [s], x [m], y [m], orientation [rad]   (Vicon)
    Landmark_Groundtruth.dat  subject #, x [m], y [m], x std-dev [m], y std-dev [m]
    Barcodes.dat              subject #, barcode #

Subjects 1-5 are the robots, 6 and up the landmarks. A camera reading names a
*barcode*, which :file:`Barcodes.dat` maps to a subject; readings of another
robot's barcode are not landmarks and are dropped.

What :func:`load` does
----------------------
- **Frame.** The data are z-up (counter-clockwise yaw). Positions, headings
  and bearings are mirrored into the course's z-down frame N with
  :mod:`slamlib.frames` (``y -> -y``, angles negated).
- **Controls.** The odometry is the *commanded* ``(v, w)``, not encoder ticks.
  The course's filters take wheel speeds ``u = [V_R, V_L]`` on a wheel base
  ``b`` with ``v = (V_R + V_L)/2`` and, in z-down, ``w = (V_L - V_R)/b``. With
  ``w_down = -w_up`` this gives, exactly::

      V_R = v + b w_up / 2,      V_L = v - b w_up / 2

  so the filter's motion model recovers the logged ``v`` and ``w`` whatever
  ``b`` is; ``b`` only matters for what a per-wheel sigma means.
- **Time.** The filter's timeline is every odometry time inside the Vicon
  record plus every reading time: between two successive times the command
  in force (the last one logged at or before the interval's start) is
  applied, so a reading is fused at the pose predicted exactly to its own
  time. Vicon is interpolated to any time (:meth:`Log.truth_at`).

The result is a :class:`Log`, a :class:`~slamlib.runs.Run` whose controls come
from the commands: the course's runners (:mod:`slamlib.runner`) take it
as they take a simulated run, and :func:`dead_reckoning`,
:func:`localization` and :func:`slam` call them with the log's noise.

Official data sets are read as they are: Dataset 6 holds six readings of
barcodes that no subject carries (43 for robot 1, 34 for robot 3, 50 for
robot 4: misread codes). By default they are dropped, counted
(``log.dropped``) and warned about once per load with the count
(:class:`MRCLAMWarning`); ``unknown_barcodes="error"`` raises instead. A
malformed file (a byte-order mark, a missing column, text where a number
belongs, a value outside its column's limits such as a negative range or
std-dev or a speed of 1e300, a time that goes backwards) raises
:class:`MRCLAMFormatError` (a ValueError) naming the file, the line and the
reason.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..frames import angles_from_zup, points_from_zup, pose_from_zup
from ..runner import Trace
from ..runner import dead_reckoning as _dead_reckoning
from ..runner import localization as _localization
from ..runner import slam as _slam
from ..runs import CameraRows, Run
from ..sensors import AnalyticMarkerSensor
from ..validate import as_covariance
from ..worlds import DATA_DIR, Marker, World

__all__ = ["Log", "MRCLAMFormatError", "MRCLAMWarning", "load", "read_table", "dead_reckoning",
           "localization", "slam", "commands_to_wheel_speeds", "write_excerpt", "EXCERPT_DIR",
           "ROBOTS", "TEXTBOOK_NOISE"]

#: The excerpt of Dataset 6 shipped with the course.
EXCERPT_DIR = DATA_DIR / "mrclam" / "MRCLAM_Dataset6"
#: Subject numbers of the robots.
ROBOTS = (1, 2, 3, 4, 5)
#: The untuned textbook noise: 0.05 m/s per wheel, 0.15 m in range, 0.03 rad in bearing.
TEXTBOOK_NOISE = {"sigma_wheel": 0.05, "sigma_range0": 0.15, "sigma_range_per_m": 0.0,
                  "sigma_bearing": 0.03}
#: The course's wheel base (m) used to express the commands as wheel speeds.
DEFAULT_WHEEL_BASE = 0.23

#: What each column may hold: (low, high, unit). Generous beyond any real log (a room of
#: 15 m, speeds below 1 m/s; angles are wrapped, so any size a wrap takes exactly), tight
#: enough that nothing overflows downstream (a range of 1e300 squared is inf).
_LIMITS = {
    "time": (-1e12, 1e12, "s"), "x": (-1e4, 1e4, "m"), "y": (-1e4, 1e4, "m"),
    "forward velocity": (-100.0, 100.0, "m/s"), "angular velocity": (-100.0, 100.0, "rad/s"),
    "range": (0.0, 1e3, "m"), "bearing": (-1e3, 1e3, "rad"), "orientation": (-1e3, 1e3, "rad"),
    "x std-dev": (0.0, 1e3, "m"), "y std-dev": (0.0, 1e3, "m"),
    "subject": (0, 2 ** 31 - 1, ""), "barcode": (0, 2 ** 31 - 1, ""),
}

_COLUMNS = {
    "Odometry": (("time", "f"), ("forward velocity", "f"), ("angular velocity", "f")),
    "Measurement": (("time", "f"), ("barcode", "i"), ("range", "f"), ("bearing", "f")),
    "Groundtruth": (("time", "f"), ("x", "f"), ("y", "f"), ("orientation", "f")),
    "Landmark_Groundtruth": (("subject", "i"), ("x", "f"), ("y", "f"), ("x std-dev", "f"),
                             ("y std-dev", "f")),
    "Barcodes": (("subject", "i"), ("barcode", "i")),
}


class MRCLAMFormatError(ValueError):
    """A data set's file is malformed; the message names the file, the line and the reason."""


class MRCLAMWarning(UserWarning):
    """Something in a data set was left out on reading (e.g. misread barcodes); once per load."""


def commands_to_wheel_speeds(v, w_up, wheel_base: float = DEFAULT_WHEEL_BASE) -> np.ndarray:
    """Commanded ``(v, w)`` (z-up yaw rate) as wheel speeds ``[V_R, V_L]`` (m/s), shape (n, 2).

    ``V_R = v + b w_up / 2`` and ``V_L = v - b w_up / 2``: the inverse of
    ``v = (V_R + V_L)/2``, ``w_down = (V_L - V_R)/b = -w_up`` (chapter 10).
    """
    v = np.asarray(v, dtype=float).reshape(-1)
    w = np.asarray(w_up, dtype=float).reshape(-1)
    if v.shape != w.shape:
        raise ValueError(f"v, w_up: expected equal lengths, got {v.shape[0]} and {w.shape[0]}")
    if not (isinstance(wheel_base, (int, float)) and math.isfinite(wheel_base)
            and wheel_base > 0):
        raise ValueError(f"wheel_base: expected a positive number, got {wheel_base!r}")
    half = 0.5 * float(wheel_base) * w
    return np.column_stack([v + half, v - half])


# --------------------------------------------------------------------------- reading files
def read_table(path, columns: tuple[tuple[str, str], ...]) -> tuple[dict[str, np.ndarray],
                                                                     np.ndarray]:
    """Read one whitespace-separated ``.dat`` file, checking every line.

    Parameters
    ----------
    path : path-like
        The file.
    columns : tuple of (name, kind)
        The expected columns; kind ``"f"`` (a finite number) or ``"i"`` (an integer).
        A column named in :data:`_LIMITS` must lie within its limits.

    Returns
    -------
    (dict of name -> numpy.ndarray, numpy.ndarray of int)
        The columns, and the line number (1-based) of each row in the file.

    Raises
    ------
    MRCLAMFormatError
        Missing file, a byte-order mark, wrong number of columns, a field that
        is not a (finite) number or an integer, or one outside its column's
        limits; the message names the file and the line.
    """
    path = Path(path)
    if not path.is_file():
        raise MRCLAMFormatError(f"{path}: missing file")
    n = len(columns)
    cols: list[list] = [[] for _ in columns]
    lines: list[int] = []
    with path.open(encoding="utf-8", errors="replace") as fh:
        for ln, line in enumerate(fh, start=1):
            if ln == 1 and line.startswith("\ufeff"):
                raise MRCLAMFormatError(f"{path}: line 1: starts with a byte-order mark "
                                        f"(U+FEFF, an editor's UTF-8 signature); the data "
                                        f"set's files are plain text: save it without one")
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            fields = s.split()
            if len(fields) != n:
                names = ", ".join(c[0] for c in columns)
                raise MRCLAMFormatError(f"{path}: line {ln}: {len(fields)} columns, expected "
                                        f"{n} ({names})")
            for j, (f, (name, kind)) in enumerate(zip(fields, columns)):
                if kind == "i":
                    try:
                        v = int(f)
                    except ValueError:
                        raise MRCLAMFormatError(f"{path}: line {ln}: column {name}: expected "
                                                f"an integer, got {f!r}") from None
                else:
                    try:
                        v = float(f)
                    except ValueError:
                        raise MRCLAMFormatError(f"{path}: line {ln}: column {name}: expected "
                                                f"a number, got {f!r}") from None
                    if not math.isfinite(v):
                        raise MRCLAMFormatError(f"{path}: line {ln}: column {name}: expected "
                                                f"a finite number, got {f!r}")
                lim = _LIMITS.get(name)
                if lim is not None and not lim[0] <= v <= lim[1]:
                    unit = f" {lim[2]}" if lim[2] else ""
                    raise MRCLAMFormatError(f"{path}: line {ln}: column {name}: expected a "
                                            f"value from {lim[0]:g} to {lim[1]:g}{unit}, "
                                            f"got {f!r}")
                cols[j].append(v)
            lines.append(ln)
    out = {name: np.array(c, dtype=np.int64 if kind == "i" else float)
           for c, (name, kind) in zip(cols, columns)}
    return out, np.array(lines, dtype=np.int64)


def _non_decreasing(path: Path, t: np.ndarray, lines: np.ndarray) -> None:
    bad = np.flatnonzero(np.diff(t) < 0.0)
    if bad.size:
        i = int(bad[0]) + 1
        raise MRCLAMFormatError(f"{path}: line {lines[i]}: time goes backwards "
                                f"({t[i]!r} after {t[i - 1]!r})")


def _unique(path: Path, values: np.ndarray, lines: np.ndarray, what: str) -> None:
    seen: dict[int, int] = {}
    for v, ln in zip(values.tolist(), lines.tolist()):
        if v in seen:
            raise MRCLAMFormatError(f"{path}: line {ln}: {what} {v} listed twice "
                                    f"(first on line {seen[v]})")
        seen[v] = ln


def _read_subjects(folder: Path) -> tuple[dict[int, int], World, dict[int, np.ndarray]]:
    """Barcodes and landmarks: barcode -> subject, the z-down landmark world, their std-devs."""
    p = folder / "Barcodes.dat"
    bc, bl = read_table(p, _COLUMNS["Barcodes"])
    _unique(p, bc["subject"], bl, "subject")
    _unique(p, bc["barcode"], bl, "barcode")
    subject_of = dict(zip(bc["barcode"].tolist(), bc["subject"].tolist()))
    missing = [r for r in ROBOTS if r not in set(bc["subject"].tolist())]
    if missing:
        raise MRCLAMFormatError(f"{p}: line {int(bl[-1]) if bl.size else 1}: no barcode for "
                                f"robot subject(s) {missing} (subjects 1-5 are the robots)")
    barcode_of = {s: b for b, s in subject_of.items()}

    p = folder / "Landmark_Groundtruth.dat"
    lm, ll = read_table(p, _COLUMNS["Landmark_Groundtruth"])
    _unique(p, lm["subject"], ll, "subject")
    markers, std = [], {}
    xy = points_from_zup(np.column_stack([lm["x"], lm["y"]])) if lm["x"].size else np.zeros((0, 2))
    for k, (s, ln) in enumerate(zip(lm["subject"].tolist(), ll.tolist())):
        if s in ROBOTS:
            raise MRCLAMFormatError(f"{p}: line {ln}: subject {s} is a robot, not a landmark")
        if s not in barcode_of:
            raise MRCLAMFormatError(f"{p}: line {ln}: subject {s} has no barcode in "
                                    f"{folder / 'Barcodes.dat'}")
        b = barcode_of[s]
        markers.append(Marker(b, float(xy[k, 0]), float(xy[k, 1])))
        std[b] = np.array([lm["x std-dev"][k], lm["y std-dev"][k]])
    if not markers:
        raise MRCLAMFormatError(f"{p}: line 1: no landmarks")
    pos = xy
    pad = 1.0
    world = World(name=f"MRCLAM {folder.name}", markers=tuple(markers), marker_length=0.0,
                  marker_height=0.0, dictionary="MRCLAM barcodes",
                  bounds=(float(pos[:, 0].min() - pad), float(pos[:, 0].max() + pad),
                          float(pos[:, 1].min() - pad), float(pos[:, 1].max() + pad)),
                  description="landmarks of the UTIAS MRCLAM data set (ids are barcodes), "
                              "frame N z-down")
    return subject_of, world, std


# --------------------------------------------------------------------------- the log
@dataclass
class Log(Run):
    """One MRCLAM robot's log as a :class:`~slamlib.runs.Run` (frame N, z-down).

    Besides a Run's fields (``truth_t``/``truth`` are Vicon's, ``enc_t`` is the
    filter's timeline, ``camera`` the barcode readings, ids = barcodes, truth
    unknown), it holds:

    Attributes
    ----------
    u : numpy.ndarray (m-1, 2)
        Wheel speeds ``[V_R, V_L]`` applied from ``enc_t[k]`` to ``enc_t[k+1]``
        (row k), from the commanded ``(v, w)`` (:func:`commands_to_wheel_speeds`).
    landmark_world : World
        The 15 landmarks (ids = barcodes) in N, from Vicon.
    landmark_std : dict of int -> (2,)
        Vicon's standard deviations of each landmark's x and y (m).

    ``meta`` holds the robot, the folder, the wheel base, the noise the
    runners use (``motion.sigma_wheel``, ``sensor``: an
    :class:`~slamlib.sensors.AnalyticMarkerSensor` whose ``R(rho)`` is used,
    nothing else of it) and counts of what was dropped.
    """

    u: np.ndarray = None
    landmark_world: World = None
    landmark_std: dict = None

    def __post_init__(self):
        super().__post_init__()
        self.u = np.asarray(self.u, dtype=float).reshape(-1, 2)
        if self.u.shape[0] != max(self.enc_t.size - 1, 0):
            raise ValueError(f"u: expected {self.enc_t.size - 1} rows (one per interval of "
                             f"enc_t), got {self.u.shape[0]}")

    @property
    def robot(self) -> int:
        """The robot's subject number (1-5)."""
        return int(self.meta["robot"])

    @property
    def dropped(self) -> dict[str, int]:
        """How many readings the loader left out, by reason: of other robots
        (``robot_readings``), of barcodes no subject carries (``unknown_barcode_readings``,
        misreads) and of landmarks outside the log's time span (``readings_outside_span``)."""
        return dict(self.meta["dropped"])

    @property
    def start_pose(self) -> np.ndarray:
        """Vicon's pose at the first time of the timeline (where the filters start)."""
        return self.truth_at(self.enc_t[0])

    def controls(self) -> tuple[np.ndarray, np.ndarray]:
        """``u`` (m-1, 2) and ``dt`` (m-1,): the commands as wheel speeds over each interval."""
        return self.u.copy(), np.diff(self.enc_t)

    def Q(self, dt: float | None = None, quantisation: bool = False) -> np.ndarray:
        """The 2x2 covariance of ``u = [V_R, V_L]`` per prediction step.

        With a noise density ``Q_c`` (``meta["motion"]["Q_density"]``, identified
        from data, chapter 10): ``Q_c / dt`` for a step of ``dt`` (the median step
        by default; the runners take every step's own, :meth:`Q_steps`). Else
        ``meta["motion"]["Q"]`` if given, else ``sigma_wheel^2 I``: commanded
        speeds are not counted ticks, so nothing is quantised.
        """
        motion = self.meta.get("motion", {})
        if motion.get("Q_density") is not None:
            if dt is None:
                dt = float(np.median(np.diff(self.enc_t)))
            return np.array(motion["Q_density"], dtype=float) / float(dt)
        q = motion.get("Q")
        if q is not None:
            return np.array(q, dtype=float)
        return self.sigma_wheel ** 2 * np.eye(2)

    def Q_steps(self, dt: np.ndarray) -> np.ndarray | None:
        """``Q_c / dt_k`` (k, 2, 2) for the steps ``dt`` when the noise is a density, else None.

        A white speed error of density ``Q_c`` ((m/s)^2 s) averaged over a step
        of ``dt`` has covariance ``Q_c / dt``; the step's pose covariance
        ``W Q W^T`` (``W`` grows with ``dt``) then grows in proportion to ``dt``,
        so splitting a step in two changes nothing (chapter 10).
        """
        qc = self.meta.get("motion", {}).get("Q_density")
        if qc is None:
            return None
        dt = np.asarray(dt, dtype=float)
        return np.array(qc, dtype=float)[None, :, :] / dt[:, None, None]

    def world(self) -> World:
        """The landmark map (ids are barcodes), frame N."""
        return self.landmark_world

    def with_noise(self, *, sigma_wheel: float | None = None, Q=None, Q_density=None,
                   **sensor) -> Log:
        """The same log with other noise for the runners.

        One of: ``sigma_wheel`` (m/s per wheel and prediction step, ``Q = sigma^2
        I``), a full 2x2 ``Q`` of ``[V_R, V_L]`` per step, or a 2x2 noise density
        ``Q_density`` ((m/s)^2 s; each step gets ``Q_density / dt``, :meth:`Q_steps`);
        and any :class:`~slamlib.sensors.AnalyticMarkerSensor` parameter
        (``sigma_range0``, ``sigma_range_per_m``, ``sigma_bearing``).
        """
        if sum(a is not None for a in (sigma_wheel, Q, Q_density)) > 1:
            raise ValueError("sigma_wheel, Q, Q_density: expected at most one of them")
        meta = {**self.meta}
        meta["motion"] = {**meta.get("motion", {})}
        if sigma_wheel is not None or Q is not None or Q_density is not None:
            meta["motion"].pop("Q", None)
            meta["motion"].pop("Q_density", None)
        if sigma_wheel is not None:
            meta["motion"]["sigma_wheel"] = float(sigma_wheel)
        if Q is not None:
            meta["motion"]["Q"] = as_covariance("Q", Q, 2).tolist()
        if Q_density is not None:
            meta["motion"]["Q_density"] = as_covariance("Q_density", Q_density, 2).tolist()
        if sensor:
            params = {**meta["sensor"], **{k: float(v) for k, v in sensor.items()}}
            AnalyticMarkerSensor.from_params(params)   # checks the names and values
            meta["sensor"] = params
        return dataclasses.replace(self, meta=meta)

    def with_readings(self, rho, bearing) -> Log:
        """The same log with every reading's range and bearing replaced (e.g. corrected)."""
        c = self.camera
        cam = CameraRows(c.t_capture, c.t_arrival, c.id, rho, bearing, c.true_id, c.true_rho,
                         c.true_bearing)
        return dataclasses.replace(self, camera=cam)

    def between(self, t_from: float, t_to: float | None = None) -> Log:
        """The same log over the absolute times ``[t_from, t_to]`` (to its end without ``t_to``).

        The timeline begins at its first time at or after ``t_from`` (the filters
        start there, at Vicon's pose) and ends at its last at or before ``t_to``;
        the readings after the first time and up to the last are kept. Every
        step keeps its command, so a log cut in two runs as its halves would.
        ``meta["dropped"]`` keeps the counts of the whole record.
        """
        T = self.enc_t
        if not (isinstance(t_from, (int, float, np.floating)) and math.isfinite(t_from)):
            raise ValueError(f"t_from: expected a time in s, got {t_from!r}")
        k0 = int(np.searchsorted(T, t_from, side="left"))
        k1 = T.size if t_to is None else int(np.searchsorted(T, t_to, side="right"))
        if k1 - k0 < 2:
            raise ValueError(f"t_from, t_to: expected at least two times of the timeline "
                             f"({T[0]:.3f} to {T[-1]:.3f} s) between them, got {t_from!r} and "
                             f"{t_to!r}")
        enc = T[k0:k1]
        c = self.camera
        m = (c.t_capture > enc[0]) & (c.t_capture <= enc[-1])
        cam = CameraRows(*(getattr(c, n)[m] for n in ("t_capture", "t_arrival", "id", "rho",
                                                      "bearing", "true_id", "true_rho",
                                                      "true_bearing")))
        # Vicon samples covering the timeline (one before its start, one after its end)
        a = max(int(np.searchsorted(self.truth_t, enc[0], side="right")) - 1, 0)
        b = min(int(np.searchsorted(self.truth_t, enc[-1], side="left")) + 1,
                self.truth_t.size)
        zeros = np.zeros(enc.size, dtype=np.int64)
        meta = {**self.meta, "duration": float(enc[-1] - enc[0])}
        return dataclasses.replace(self, enc_t=enc, ticks_R=zeros, ticks_L=zeros,
                                   u=self.u[k0:k1 - 1], camera=cam, truth_t=self.truth_t[a:b],
                                   truth=self.truth[a:b], meta=meta)

    def select_readings(self, keep) -> Log:
        """The same log with only the readings where ``keep`` (bool, one per reading) is true.

        The timeline is unchanged (a dropped reading's time still splits a step).
        """
        keep = np.asarray(keep, dtype=bool).reshape(-1)
        c = self.camera
        if keep.shape[0] != len(c):
            raise ValueError(f"keep: expected {len(c)} booleans (one per reading), "
                             f"got {keep.shape[0]}")
        cam = CameraRows(*(getattr(c, n)[keep] for n in ("t_capture", "t_arrival", "id", "rho",
                                                         "bearing", "true_id", "true_rho",
                                                         "true_bearing")))
        return dataclasses.replace(self, camera=cam)

    def save(self, folder) -> None:   # pragma: no cover - a Log is read from the original files
        raise NotImplementedError("a Log is read from the MRCLAM files; it has no encoder "
                                  "ticks to save as a run")


def load(folder=EXCERPT_DIR, robot: int = 1, *, start: float = 0.0,
         duration: float | None = None,
         wheel_base: float = DEFAULT_WHEEL_BASE, unknown_barcodes: str = "drop",
         noise: dict | None = None, command_scale: tuple[float, float] = (1.0, 1.0),
         command_delay: float = 0.0, calibration=None) -> Log:
    """Read robot ``robot``'s log from an MRCLAM data set folder (the module doc says how).

    Parameters
    ----------
    folder : path-like
        A folder with the original ``.dat`` files (the shipped excerpt by
        default, or a full download).
    robot : int
        Subject number 1-5.
    duration : float, optional
        Keep only ``duration`` seconds of the timeline (from ``start``).
    wheel_base : float
        b (m) used to express the commands as wheel speeds.
    unknown_barcodes : {"drop", "error"}
        What a reading of a barcode no subject carries (a misread) does: be
        dropped, counted in ``log.dropped`` and warned about once per load
        (:class:`MRCLAMWarning`, with the count), or raise
        :class:`MRCLAMFormatError`.
    noise : dict, optional
        ``sigma_wheel``, a 2x2 ``Q`` per step or a 2x2 ``Q_density`` ((m/s)^2 s,
        :meth:`Log.Q_steps`), and sensor parameters
        (``sigma_range0``, ``sigma_range_per_m``, ``sigma_bearing``); what is not
        given comes from :data:`TEXTBOOK_NOISE`.
    command_scale : (float, float)
        Factors applied to the logged ``v`` and ``w`` (a calibration; 1 = as logged).
    command_delay : float
        Seconds between a command's log time and the moment it takes effect
        (a calibration; 0 = as logged): command times are shifted by it.
    calibration : identify.Calibration, optional
        What :func:`slamlib.datasets.identify.identify` found: its command
        scale and delay, noise density and R(rho), each where it has one (the
        rest as logged / textbook). Not together with ``noise``,
        ``command_scale`` or ``command_delay``.
    start : float
        Skip the first ``start`` seconds of the timeline (:meth:`Log.between`).

    Returns
    -------
    Log

    Raises
    ------
    MRCLAMFormatError
        A malformed file (its name, the line and the reason).
    ValueError
        A bad argument.
    """
    folder = Path(folder)
    if isinstance(robot, bool) or not isinstance(robot, (int, np.integer)) or robot not in ROBOTS:
        raise ValueError(f"robot: expected a robot subject number in {ROBOTS}, got {robot!r}")
    if unknown_barcodes not in ("error", "drop"):
        raise ValueError(f"unknown_barcodes: expected 'error' or 'drop', got {unknown_barcodes!r}")
    if not (isinstance(start, (int, float)) and math.isfinite(start) and start >= 0):
        raise ValueError(f"start: expected a number of seconds >= 0, got {start!r}")
    if duration is not None and not (isinstance(duration, (int, float)) and duration > 0):
        raise ValueError(f"duration: expected a positive number of seconds, got {duration!r}")
    if calibration is not None:
        from .identify import Calibration

        if not isinstance(calibration, Calibration):
            raise ValueError(f"calibration: expected an identify.Calibration, got "
                             f"{type(calibration).__name__}")
        if noise is not None or tuple(command_scale) != (1.0, 1.0) or command_delay != 0.0:
            raise ValueError("calibration: expected alone, not with noise, command_scale or "
                             "command_delay (it sets them)")
        noise = calibration.noise(wheel_base)
        if calibration.command_scale is not None:
            command_scale = calibration.command_scale
        if calibration.command_delay is not None:
            command_delay = calibration.command_delay
    if not folder.is_dir():
        raise MRCLAMFormatError(f"{folder}: not a folder")
    robot = int(robot)
    subject_of, world, std = _read_subjects(folder)
    robot_barcodes = {b for b, s in subject_of.items() if s in ROBOTS}

    p_odo = folder / f"Robot{robot}_Odometry.dat"
    odo, ol = read_table(p_odo, _COLUMNS["Odometry"])
    _non_decreasing(p_odo, odo["time"], ol)
    p_gt = folder / f"Robot{robot}_Groundtruth.dat"
    gt, gl = read_table(p_gt, _COLUMNS["Groundtruth"])
    _non_decreasing(p_gt, gt["time"], gl)
    p_me = folder / f"Robot{robot}_Measurement.dat"
    me, ml = read_table(p_me, _COLUMNS["Measurement"])
    _non_decreasing(p_me, me["time"], ml)
    known = np.array([b in subject_of for b in me["barcode"].tolist()], dtype=bool)
    if unknown_barcodes == "error" and not known.all():
        k = int(np.flatnonzero(~known)[0])
        raise MRCLAMFormatError(
            f"{p_me}: line {ml[k]}: unknown barcode {me['barcode'][k]} (no subject carries it "
            f"in {folder / 'Barcodes.dat'}; {int(np.sum(~known))} such reading(s) in this "
            f"file; the default, unknown_barcodes='drop', drops and counts them)")
    for path, table in ((p_odo, odo), (p_gt, gt)):
        if table["time"].size < 2:
            raise MRCLAMFormatError(f"{path}: line 1: expected at least two rows")

    # --- Vicon: drop repeated times (keep the first), mirror into z-down
    keep = np.r_[True, np.diff(gt["time"]) > 0.0]
    gt_t = gt["time"][keep]
    truth = pose_from_zup(np.column_stack([gt["x"], gt["y"], gt["orientation"]])[keep])

    # --- the timeline: odometry times inside the Vicon record, plus reading times
    for val in command_scale:
        if not math.isfinite(float(val)):
            raise ValueError(f"command_scale: expected two finite numbers, got {command_scale!r}")
    if not math.isfinite(float(command_delay)):
        raise ValueError(f"command_delay: expected a finite number, got {command_delay!r}")
    odo_t = odo["time"] + float(command_delay)
    t0 = odo_t[np.searchsorted(odo_t, gt_t[0], side="left")] if odo_t[-1] >= gt_t[0] else None
    t_end = min(float(odo_t[-1]), float(gt_t[-1]))
    if t0 is None or t0 >= t_end:
        raise MRCLAMFormatError(f"{p_odo}: line {ol[0]}: the odometry does not overlap the "
                                f"Vicon record of {p_gt} in time")
    t0 = float(t0)
    if start >= t_end - t0:
        raise ValueError(f"start: expected less than the log's {t_end - t0:.1f} s, got {start!r}")
    ro = (odo_t >= t0) & (odo_t <= t_end)
    inside = (me["time"] > t0) & (me["time"] <= t_end)
    use = known & inside
    n_misread = int(np.sum(~known & inside))
    if n_misread:
        codes = sorted(set(me["barcode"][~known & inside].tolist()))
        warnings.warn(f"{p_me}: {n_misread} reading(s) of barcode(s) {codes} that no subject "
                      f"carries (misreads) dropped; counted in log.dropped; "
                      f"unknown_barcodes='error' raises instead", MRCLAMWarning, stacklevel=2)
    is_robot = np.array([b in robot_barcodes for b in me["barcode"].tolist()], dtype=bool)
    n_robot = int(np.sum(use & is_robot))
    use &= ~is_robot
    # on the Run's 1 us grid (DECIMALS["t"]): a shifted command time that rounds onto a reading's
    # time is one time, not a step of length zero
    timeline = np.unique(np.round(np.concatenate([odo_t[ro], me["time"][use]]), 6))
    # the command in force on [T_k, T_k+1): the last one logged at or before T_k
    idx = np.searchsorted(odo_t, timeline[:-1], side="right") - 1
    u = commands_to_wheel_speeds(float(command_scale[0]) * odo["forward velocity"][idx],
                                 float(command_scale[1]) * odo["angular velocity"][idx],
                                 wheel_base)

    # Vicon samples covering the timeline (one before its start, one after its end)
    a = max(int(np.searchsorted(gt_t, t0, side="right")) - 1, 0)
    b = min(int(np.searchsorted(gt_t, t_end, side="left")) + 1, gt_t.size)

    t_me = me["time"][use]
    camera = CameraRows(t_capture=t_me, t_arrival=t_me, id=me["barcode"][use],
                        rho=me["range"][use], bearing=angles_from_zup(me["bearing"][use]),
                        true_id=np.full(t_me.size, -1), true_rho=np.full(t_me.size, np.nan),
                        true_bearing=np.full(t_me.size, np.nan))
    nz = {**TEXTBOOK_NOISE, **(noise or {})}
    sensor = AnalyticMarkerSensor(**{k: float(v) for k, v in nz.items()
                                     if k not in ("sigma_wheel", "Q", "Q_density")})
    motion = {"sigma_wheel": float(nz["sigma_wheel"])}
    if nz.get("Q") is not None and nz.get("Q_density") is not None:
        raise ValueError("noise: expected 'Q' (per step) or 'Q_density', not both")
    if nz.get("Q") is not None:
        motion["Q"] = as_covariance("noise['Q']", nz["Q"], 2).tolist()
    if nz.get("Q_density") is not None:
        motion["Q_density"] = as_covariance("noise['Q_density']", nz["Q_density"], 2).tolist()
    meta = {
        "world": world.name, "robot": robot, "folder": str(folder), "source": "UTIAS MRCLAM",
        "duration": float(timeline[-1] - timeline[0]),
        "encoder": {"wheel_base": float(wheel_base)},
        "motion": motion,
        "sensor": sensor.params(),
        "commands": {"scale": [float(command_scale[0]), float(command_scale[1])],
                     "delay": float(command_delay)},
        "calibration": None if calibration is None else calibration.to_dict(),
        "dropped": {"robot_readings": n_robot, "unknown_barcode_readings": n_misread,
                    "readings_outside_span": int(np.sum(known & ~is_robot & ~inside))},
        "description": f"MRCLAM {folder.name}, robot {robot}: commanded (v, w) as wheel speeds "
                       f"on b = {wheel_base} m, barcode readings, Vicon truth; frame N z-down",
    }
    zeros = np.zeros(timeline.size, dtype=np.int64)
    log = Log(name=f"{folder.name} robot {robot}", truth_t=gt_t[a:b], truth=truth[a:b],
              enc_t=timeline, ticks_R=zeros, ticks_L=zeros, camera=camera, meta=meta, u=u,
              landmark_world=world, landmark_std=std)
    if start > 0 or duration is not None:
        t_from = t0 + float(start)
        log = log.between(t_from, None if duration is None else t_from + float(duration))
    return log


# --------------------------------------------------------------------------- the pipeline
def dead_reckoning(log: Log, **kw) -> Trace:
    """Prediction only from Vicon's first pose, with the log's ``Q`` (chapter 10)."""
    return _dead_reckoning(log, **kw)


def localization(log: Log, *, gate: float | None = 0.95, **kw) -> Trace:
    """The map-based EKF on the landmarks' Vicon map, with the log's ``Q`` and ``R(rho)``."""
    return _localization(log, gate=gate, **kw)


def slam(log: Log, *, gate: float | None = 0.95, **kw) -> Trace:
    """EKF SLAM from Vicon's first pose, with the log's ``Q`` and ``R(rho)`` (chapter 10)."""
    return _slam(log, gate=gate, **kw)


# --------------------------------------------------------------------------- the excerpt
def write_excerpt(source, target, seconds: float, vicon_every: int = 1) -> dict[str, int]:
    """Copy the first ``seconds`` of a data set into ``target``, line by line (chapter 10).

    Every kept line is copied verbatim (comments included), so the excerpt is
    in the original format and :func:`load` reads it as it reads the source.
    Times are cut at ``t_start + seconds`` with ``t_start`` the earliest Vicon
    time of all robots; ``Barcodes.dat`` and ``Landmark_Groundtruth.dat`` are
    copied whole; of the Vicon files only every ``vicon_every``-th data line
    is kept (Vicon logs at about 60 Hz; the filters compare at their own
    times by interpolation).

    Returns
    -------
    dict of file name -> number of data lines written.
    """
    source, target = Path(source), Path(target)
    if not seconds > 0:
        raise ValueError(f"seconds: expected a positive duration, got {seconds!r}")
    if int(vicon_every) < 1:
        raise ValueError(f"vicon_every: expected an integer >= 1, got {vicon_every!r}")
    starts = []
    for r in ROBOTS:
        gt, _ = read_table(source / f"Robot{r}_Groundtruth.dat", _COLUMNS["Groundtruth"])
        starts.append(float(gt["time"][0]))
    t_cut = min(starts) + float(seconds)
    target.mkdir(parents=True, exist_ok=True)
    counts = {}
    for name in ("Barcodes.dat", "Landmark_Groundtruth.dat"):
        text = (source / name).read_text(encoding="utf-8")
        (target / name).write_text(text, encoding="utf-8")
        counts[name] = sum(1 for ln in text.splitlines() if ln.strip() and
                           not ln.lstrip().startswith("#"))
    for r in ROBOTS:
        for kind in ("Odometry", "Measurement", "Groundtruth"):
            name = f"Robot{r}_{kind}.dat"
            out, n, k = [], 0, 0
            with (source / name).open(encoding="utf-8") as fh:
                for line in fh:
                    s = line.strip()
                    if not s or s.startswith("#"):
                        out.append(line)
                        continue
                    if float(s.split()[0]) >= t_cut:
                        break
                    if kind != "Groundtruth" or k % int(vicon_every) == 0:
                        out.append(line)
                        n += 1
                    k += 1
            (target / name).write_text("".join(out), encoding="utf-8")
            counts[name] = n
    return counts
