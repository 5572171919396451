"""Recorded runs: ground truth, wheel encoders and camera readings (chapters 01-08).

A :class:`Run` is what a robot (simulated by :mod:`slamlib.sim`, or real)
recorded while driving: the true poses, the raw encoder counters and the
marker readings, with the parameters that produced them. The filters'
chapters take their inputs from it through three helpers:

- :meth:`Run.controls` turns successive encoder readings into the wheel
  speeds ``u_k = [V_R, V_L]`` over ``dt_k`` (with the 16-bit wrap undone);
- :meth:`Run.truth_at_encoders` gives the true pose at each encoder time;
- :meth:`Run.events` merges the prediction and update events in time order,
  by capture time (the ideal) or by arrival time (what a real robot with a
  late camera gets, chapter 08).

File format
-----------
A run is a folder (``data/runs/<name>/``) of four files, UTF-8 without a
byte-order mark. The CSV files have one header line (exactly as below), then
one row per line, each line ending with a newline (a last line without one is
a file cut short), comma-separated, numbers in plain decimal notation
(integers within int64), no quoting, no blank lines::

    truth.csv     t,x,y,theta
                  true pose (m, m, rad; frame N, z-down) at time t (s);
                  t strictly increasing
    encoders.csv  t,ticks_R,ticks_L
                  the raw wheel counters (integers in [0, 2**bits), they
                  wrap around) sampled at time t; t strictly increasing
    camera.csv    t_capture,t_arrival,id,rho,bearing,true_id,true_rho,true_bearing
                  one row per marker reading: when the frame was captured and
                  when it reached the filter (s), the id as read, the reading
                  [rho, bearing] (m, rad, robot frame, from the robot's
                  origin), and the simulator's truth: the marker that produced
                  it (-1 for a spurious outlier) and its noise-free
                  [rho, bearing] (nan for an outlier, or both nan and
                  true_id -1 when the truth is unknown, as on a real robot).
                  Rows of one frame share t_capture; t_capture never decreases
                  and t_arrival >= t_capture.
    meta.json     {"format": "slamlib-run/1", "name", "world", "seed",
                   "duration", "encoder": {"rate", "ticks_per_rev", "bits",
                   "wheel_radius", "wheel_base"}, "motion": {"sigma_wheel", ...},
                   "sensor": {...}, "controller": {...}, "description"}
                  "world" names a world of data/worlds; "sensor" holds the
                  sensor's parameters (AnalyticMarkerSensor.params());
                  "duration" is the time the encoders span (s).

The files describe one stretch of time: the truth covers the encoders' times,
and every camera frame is captured within them (it may arrive later).

No pickle anywhere: every file is text. The loader checks every line and
raises :class:`RunFormatError` (a ValueError) naming the file, the line number
(or the meta's field) and the reason (bytes that are not UTF-8, a file cut
inside its last line, wrong column count, a field that is not a number or not
an integer, a non-finite value, times not increasing, files that disagree on
time, an unknown world, a field of the wrong type...).

Values are rounded to the precision they are written with (:data:`DECIMALS`)
when a :class:`Run` is made, so a run in memory and the same run saved and
loaded back are equal, bit for bit.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .models import (
    KOBUKI_TICKS_PER_REV,
    KOBUKI_WHEEL_BASE,
    KOBUKI_WHEEL_RADIUS,
    tick_difference,
    wheel_speeds_from_ticks,
    wrap_angle,
)
from .sensors import AnalyticMarkerSensor, Observations
from .validate import as_positive, read_json_file, read_text_file
from .worlds import DATA_DIR, WORLDS_DIR, World, load_world

__all__ = ["Run", "CameraRows", "PredictEvent", "UpdateEvent", "RunFormatError",
           "load_run", "save_run", "RUNS_DIR", "FORMAT", "DECIMALS"]

FORMAT = "slamlib-run/1"
#: Where the recorded runs live.
RUNS_DIR = DATA_DIR / "runs"
#: Decimals written for each kind of column (times 1 us; positions 10 um; angles 1 urad).
DECIMALS = {"t": 6, "xy": 5, "angle": 6, "rho": 5}

TRUTH_HEADER = ("t", "x", "y", "theta")
ENCODER_HEADER = ("t", "ticks_R", "ticks_L")
CAMERA_HEADER = ("t_capture", "t_arrival", "id", "rho", "bearing",
                 "true_id", "true_rho", "true_bearing")


class RunFormatError(ValueError):
    """A run's file is malformed; the message names the file, the line and the reason."""


def _r(a, kind: str) -> np.ndarray:
    return np.round(np.asarray(a, dtype=float), DECIMALS[kind]) + 0.0   # + 0.0: no -0.0


# --------------------------------------------------------------------------- containers
@dataclass
class CameraRows:
    """The camera's readings, one row per marker reading (see the module docstring)."""

    t_capture: np.ndarray
    t_arrival: np.ndarray
    id: np.ndarray
    rho: np.ndarray
    bearing: np.ndarray
    true_id: np.ndarray
    true_rho: np.ndarray
    true_bearing: np.ndarray

    def __post_init__(self):
        self.t_capture = _r(self.t_capture, "t").reshape(-1)
        self.t_arrival = _r(self.t_arrival, "t").reshape(-1)
        self.id = np.asarray(self.id, dtype=np.int64).reshape(-1)
        self.rho = _r(self.rho, "rho").reshape(-1)
        self.bearing = _r(self.bearing, "angle").reshape(-1)
        self.true_id = np.asarray(self.true_id, dtype=np.int64).reshape(-1)
        self.true_rho = _r(self.true_rho, "rho").reshape(-1)
        self.true_bearing = _r(self.true_bearing, "angle").reshape(-1)
        n = self.t_capture.shape[0]
        for name in CAMERA_HEADER:
            if getattr(self, name).shape[0] != n:
                raise ValueError(f"CameraRows.{name}: expected {n} rows, "
                                 f"got {getattr(self, name).shape[0]}")
        # what a filter's update would check reading by reading, checked once for the run
        if not (np.isfinite(self.rho).all() and np.isfinite(self.bearing).all()):
            raise ValueError("CameraRows: expected finite ranges and bearings (NaN or inf found)")
        if (self.rho < 0.0).any():
            raise ValueError(f"CameraRows.rho: expected ranges >= 0, got {self.rho.min()}")

    def __len__(self) -> int:
        return int(self.t_capture.shape[0])

    @classmethod
    def from_frames(cls, frames: list[Observations]) -> CameraRows:
        """Stack frames (each with ``t`` and ``t_arrival`` set) into rows."""
        cols: dict[str, list] = {k: [] for k in CAMERA_HEADER}
        for f in frames:
            k = len(f)
            ta = f.t if f.t_arrival is None else f.t_arrival
            zt = f.z_true if f.z_true is not None else np.full((k, 2), np.nan)
            cols["t_capture"].append(np.full(k, f.t))
            cols["t_arrival"].append(np.full(k, ta))
            cols["id"].append(f.ids)
            cols["rho"].append(f.z[:, 0])
            cols["bearing"].append(f.z[:, 1])
            cols["true_id"].append(f.true_ids)
            cols["true_rho"].append(zt[:, 0])
            cols["true_bearing"].append(zt[:, 1])
        return cls(**{k: (np.concatenate(v) if v else np.zeros(0)) for k, v in cols.items()})

    def frames(self) -> list[Observations]:
        """The rows grouped by capture time into :class:`~slamlib.sensors.Observations`."""
        out = []
        if len(self) == 0:
            return out
        starts = np.flatnonzero(np.r_[True, np.diff(self.t_capture) != 0.0])
        ends = np.r_[starts[1:], len(self)]
        # fresh arrays for the frames (views of these, not of the rows)
        ids, true_ids = self.id.copy(), self.true_id.copy()
        z = np.column_stack([self.rho, self.bearing])
        z_true = np.column_stack([self.true_rho, self.true_bearing])
        t_cap, t_arr = self.t_capture[starts].tolist(), self.t_arrival[starts].tolist()
        # the rows were checked when made: each frame is made of their slices as they are
        make = Observations._of_checked
        for i, (a, b) in enumerate(zip(starts.tolist(), ends.tolist())):
            out.append(make(t_cap[i], ids[a:b], z[a:b], true_ids[a:b], z_true[a:b], t_arr[i]))
        return out


@dataclass(frozen=True)
class PredictEvent:
    """Move the filter from ``t - dt`` to ``t`` with wheel speeds ``u = [V_R, V_L]``.

    ``k`` is the index of the encoder reading at ``t`` (so ``k >= 1``).
    """

    t: float
    k: int
    u: np.ndarray
    dt: float
    kind: str = "predict"


@dataclass(frozen=True)
class UpdateEvent:
    """A camera frame delivered to the filter at time ``t`` (capture or arrival time)."""

    t: float
    obs: Observations
    kind: str = "update"


@dataclass
class Run:
    """One recorded run (see the module docstring for the meaning of each column).

    Attributes
    ----------
    name : str
    truth_t : numpy.ndarray (n,)
        Times of the true poses (s).
    truth : numpy.ndarray (n, 3)
        True poses ``[x, y, theta]`` in N.
    enc_t : numpy.ndarray (m,)
        Encoder sampling times (s).
    ticks_R, ticks_L : numpy.ndarray (m,) of int
        Raw wrapping counters of the right and left wheels.
    camera : CameraRows
        Marker readings.
    meta : dict
        Everything else (world name, seed, noise and sensor parameters).
    """

    name: str
    truth_t: np.ndarray
    truth: np.ndarray
    enc_t: np.ndarray
    ticks_R: np.ndarray
    ticks_L: np.ndarray
    camera: CameraRows
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.truth_t = _r(self.truth_t, "t").reshape(-1)
        tr = np.asarray(self.truth, dtype=float).reshape(-1, 3)
        self.truth = np.column_stack([_r(tr[:, 0], "xy"), _r(tr[:, 1], "xy"),
                                      _r(tr[:, 2], "angle")])
        self.enc_t = _r(self.enc_t, "t").reshape(-1)
        self.ticks_R = np.asarray(self.ticks_R, dtype=np.int64).reshape(-1)
        self.ticks_L = np.asarray(self.ticks_L, dtype=np.int64).reshape(-1)
        if self.truth.shape[0] != self.truth_t.shape[0]:
            raise ValueError("truth: expected one pose per time in truth_t")
        if not (self.ticks_R.shape == self.ticks_L.shape == self.enc_t.shape):
            raise ValueError("ticks_R, ticks_L: expected one reading per time in enc_t")

    # ------------------------------------------------------------------ parameters
    @property
    def wheel_base(self) -> float:
        """b (m)."""
        return float(self.meta.get("encoder", {}).get("wheel_base", KOBUKI_WHEEL_BASE))

    @property
    def wheel_radius(self) -> float:
        """r (m)."""
        return float(self.meta.get("encoder", {}).get("wheel_radius", KOBUKI_WHEEL_RADIUS))

    @property
    def ticks_per_rev(self) -> float:
        """Encoder ticks per wheel revolution."""
        return float(self.meta.get("encoder", {}).get("ticks_per_rev", KOBUKI_TICKS_PER_REV))

    @property
    def bits(self) -> int:
        """Width of the wrapping counters."""
        return int(self.meta.get("encoder", {}).get("bits", 16))

    @property
    def sigma_wheel(self) -> float:
        """Standard deviation of each wheel's slip speed noise (m/s), per encoder period."""
        return float(self.meta.get("motion", {}).get("sigma_wheel", 0.0))

    @property
    def start_pose(self) -> np.ndarray:
        """The first true pose (where a dead-reckoning filter starts)."""
        return self.truth[0].copy()

    def world(self) -> World:
        """The run's world, loaded from ``data/worlds``."""
        return load_world(WORLDS_DIR / f"{self.meta['world']}.json")

    def sensor(self) -> AnalyticMarkerSensor | None:
        """The analytic sensor that made the readings (None for another sensor type)."""
        d = self.meta.get("sensor")
        if not d or d.get("type") != AnalyticMarkerSensor.__name__:
            return None
        return AnalyticMarkerSensor.from_params(d)

    def quantisation_variance(self, dt: float) -> float:
        """Variance (m^2/s^2) a wheel speed from tick differences gets from the counting.

        A counter floors the rim angle, an error uniform in one tick; a speed is
        the difference of two such errors over ``dt``, so its variance is
        ``2 * (1/12) * (2 pi r / ticks_per_rev / dt)^2``.
        """
        step = 2.0 * math.pi * self.wheel_radius / self.ticks_per_rev / dt
        return step * step / 6.0

    def Q(self, dt: float | None = None, quantisation: bool = True) -> np.ndarray:
        """The 2x2 covariance of ``u = [V_R, V_L]`` a filter should use (chapter 01).

        ``sigma_wheel^2 I``, plus the tick quantisation variance at the encoder
        period ``dt`` (the median period by default) when ``quantisation``.
        """
        var = self.sigma_wheel ** 2
        if quantisation:
            if dt is None:
                dt = float(np.median(np.diff(self.enc_t))) if self.enc_t.size > 1 else 0.02
            var += self.quantisation_variance(dt)
        return var * np.eye(2)

    def Q_steps(self, dt: np.ndarray) -> np.ndarray | None:
        """Each step's covariance of ``u`` (k, 2, 2) for the steps ``dt`` (k,), or None when
        every step takes :meth:`Q` (a simulated run). A real log whose noise is a density
        (chapter 10) gives ``Q_c / dt_k``."""
        return None

    # ------------------------------------------------------------------ helpers
    def controls(self) -> tuple[np.ndarray, np.ndarray]:
        """Wheel speeds from the encoders (chapter 01).

        Returns
        -------
        u : numpy.ndarray (m-1, 2)
            ``u_k = [V_R, V_L]`` (m/s), the mean speed between encoder readings
            k-1 and k (row k-1), from the tick increments
            (:func:`~slamlib.models.tick_difference`, which undoes the wrap)
            through :func:`~slamlib.models.wheel_speeds_from_ticks`.
        dt : numpy.ndarray (m-1,)
            ``t_k - t_{k-1}`` (s).
        """
        dR = tick_difference(self.ticks_R[1:], self.ticks_R[:-1], bits=self.bits)
        dL = tick_difference(self.ticks_L[1:], self.ticks_L[:-1], bits=self.bits)
        dt = np.diff(self.enc_t)
        bad = np.flatnonzero(~(dt > 0.0))
        if bad.size:                      # the error wheel_speeds_from_ticks gives
            wheel_speeds_from_ticks(dR[bad[0]], dL[bad[0]], dt[bad[0]])
        # wheel_speeds_from_ticks row by row, vectorised: the same operations in the same order
        n, r = float(self.ticks_per_rev), float(self.wheel_radius)
        as_positive("ticks_per_rev", n)
        as_positive("radius", r)
        k = 2.0 * np.pi * r / (n * dt)
        u = np.column_stack([k * dR.astype(float), k * dL.astype(float)]) if dt.size else \
            np.zeros((0, 2))
        return u, dt

    def truth_at(self, t) -> np.ndarray:
        """True pose(s) at time(s) ``t``, interpolated linearly (heading unwrapped first).

        Exact at the recorded truth times. Times outside the record are clamped.
        """
        t = np.asarray(t, dtype=float)
        th = np.unwrap(self.truth[:, 2])
        out = np.stack([np.interp(t, self.truth_t, self.truth[:, 0]),
                        np.interp(t, self.truth_t, self.truth[:, 1]),
                        wrap_angle(np.interp(t, self.truth_t, th))], axis=-1)
        # exact values where the time is a recorded one
        idx = np.searchsorted(self.truth_t, t)
        idx = np.clip(idx, 0, self.truth_t.size - 1)
        hit = self.truth_t[idx] == t
        return np.where(hit[..., None], self.truth[idx], out)

    def truth_at_encoders(self) -> np.ndarray:
        """The true pose at each encoder time, shape (m, 3)."""
        return self.truth_at(self.enc_t)

    def frames(self) -> list[Observations]:
        """The camera readings grouped into frames (one Observations per capture time)."""
        return self.camera.frames()

    def events(self, by: str = "capture") -> Iterator[PredictEvent | UpdateEvent]:
        """Prediction and update events merged in time order (chapters 03, 05, 08).

        Parameters
        ----------
        by : {"capture", "arrival"}
            Deliver each camera frame at its capture time (as if the camera had
            no delay) or at its arrival time (what the filter of a real robot
            gets). At equal times the prediction comes first.

        Yields
        ------
        PredictEvent or UpdateEvent
            ``PredictEvent(t, k, u, dt)`` for each encoder reading k >= 1 and
            ``UpdateEvent(t, obs)`` for each camera frame.
        """
        if by not in ("capture", "arrival"):
            raise ValueError(f"by: expected 'capture' or 'arrival', got {by!r}")
        for kind, t, a, b in self._merged_events(by):
            yield PredictEvent(t, a, b[0], b[1]) if kind == 0 else UpdateEvent(t, a)

    def _event_order(self, by: str):
        """The merged events' order (see :meth:`_merged_events`): ``(u, dt, frames, order,
        t, kind, index)``, the last three as lists over all events, ``order`` the sequence."""
        if by not in ("capture", "arrival"):
            raise ValueError(f"by: expected 'capture' or 'arrival', got {by!r}")
        u, dt = self.controls()
        frames = self.frames()
        t_pred = self.enc_t[1:]
        t_cam = np.array([f.t if by == "capture" else float(f.t_arrival) for f in frames],
                         dtype=float)
        t_all = np.concatenate([t_pred, t_cam])
        kind = np.concatenate([np.zeros(t_pred.size, np.int64), np.ones(t_cam.size, np.int64)])
        index = np.concatenate([np.arange(t_pred.size), np.arange(t_cam.size)])
        order = np.lexsort((index, kind, t_all))
        return u, dt, frames, order.tolist(), t_all.tolist(), kind.tolist(), index.tolist()

    def _merged_events(self, by: str) -> list[tuple]:
        """The events of :meth:`events` as plain tuples, in the same order (the runners' loop).

        ``(0, t, k, (u_k, dt_k))`` for a prediction, ``(1, t, obs, None)`` for a
        camera frame; ordered by time, predictions first at equal times, then
        by index (a stable sort on those three keys).
        """
        u, dt, frames, order, t_list, kind_list, index_list = self._event_order(by)
        dt_list = dt.tolist()
        out = []
        for i in order:
            j = index_list[i]
            if kind_list[i] == 0:
                out.append((0, t_list[i], j + 1, (u[j], dt_list[j])))
            else:
                out.append((1, t_list[i], frames[j], None))
        return out

    def _event_blocks(self, by: str) -> tuple[np.ndarray, np.ndarray, list[tuple]]:
        """The events of :meth:`_merged_events`, the predictions between two frames together.

        Returns ``(u, dt, blocks)``: the controls (:meth:`controls`) and, in
        order, ``(0, j0, j1, times)`` for the predictions with the controls
        ``u[j0:j1]``, ``dt[j0:j1]`` at the times ``times`` (a list), and
        ``(1, t, obs, r0)`` for a camera frame whose readings are the rows
        ``r0:r0 + len(obs)`` of :attr:`camera`.
        """
        u, dt, frames, order, t_list, kind_list, index_list = self._event_order(by)
        first_row = np.cumsum([0] + [len(f) for f in frames]).tolist()
        blocks: list[tuple] = []
        times: list[float] = []
        j0 = 0
        for i in order:
            j = index_list[i]
            if kind_list[i] == 0:
                if not times:
                    j0 = j
                times.append(t_list[i])
            else:
                if times:
                    blocks.append((0, j0, j0 + len(times), times))
                    times = []
                blocks.append((1, t_list[i], frames[j], first_row[j]))
        if times:
            blocks.append((0, j0, j0 + len(times), times))
        return u, dt, blocks

    def summary(self) -> str:
        """One line: name, world, duration, readings."""
        path = np.sum(np.hypot(*np.diff(self.truth[:, :2], axis=0).T))
        return (f"run {self.name!r} in world {self.meta.get('world')!r}: "
                f"{self.enc_t[-1] - self.enc_t[0]:.1f} s, {path:.2f} m driven, "
                f"{self.enc_t.size} encoder readings, {len(self.frames())} camera frames "
                f"with {len(self.camera)} readings")

    def save(self, folder) -> None:
        """Write the run into ``folder`` (see :func:`save_run`)."""
        save_run(self, folder)


# --------------------------------------------------------------------------- writing
def _fmt(v: float, decimals: int) -> str:
    if math.isnan(v):
        return "nan"
    return np.format_float_positional(v, precision=decimals, unique=True, trim="-")


def _write_csv(path: Path, header: tuple[str, ...], columns: list[tuple[np.ndarray, int | None]]
               ) -> None:
    n = columns[0][0].shape[0] if columns else 0
    lines = [",".join(header)]
    for i in range(n):
        lines.append(",".join(str(int(c[i])) if d is None else _fmt(float(c[i]), d)
                              for c, d in columns))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def save_run(run: Run, folder) -> None:
    """Write ``run`` as a folder of CSV files and a ``meta.json`` (format in the module doc)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    D = DECIMALS
    _write_csv(folder / "truth.csv", TRUTH_HEADER,
               [(run.truth_t, D["t"]), (run.truth[:, 0], D["xy"]), (run.truth[:, 1], D["xy"]),
                (run.truth[:, 2], D["angle"])])
    _write_csv(folder / "encoders.csv", ENCODER_HEADER,
               [(run.enc_t, D["t"]), (run.ticks_R, None), (run.ticks_L, None)])
    c = run.camera
    _write_csv(folder / "camera.csv", CAMERA_HEADER,
               [(c.t_capture, D["t"]), (c.t_arrival, D["t"]), (c.id, None), (c.rho, D["rho"]),
                (c.bearing, D["angle"]), (c.true_id, None), (c.true_rho, D["rho"]),
                (c.true_bearing, D["angle"])])
    meta = {"format": FORMAT, "name": run.name, **{k: v for k, v in run.meta.items()
                                                    if k not in ("format", "name")}}
    (folder / "meta.json").write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")


# --------------------------------------------------------------------------- reading
INT64_MIN, INT64_MAX = -(2**63), 2**63 - 1


def _shown(s: str) -> str:
    """A field for an error message: at most 24 characters of it."""
    return repr(s) if len(s) <= 24 else f"{s[:20]!r}... ({len(s)} characters)"


def _read_csv(path: Path, header: tuple[str, ...], kinds: tuple[str, ...],
              allow_nan: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """Parse a CSV with the exact ``header``; kinds: 'f' float, 'i' integer."""
    text = read_text_file(path, RunFormatError)
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    elif lines[-1]:                  # the writer ends every line: the file was cut in this one
        raise RunFormatError(f"{path}: line {len(lines)}: the file ends inside this line (no "
                             f"newline after it): cut short?")
    if not lines:
        raise RunFormatError(f"{path}: line 1: empty file, expected the header "
                             f"{','.join(header)}")
    got = tuple(h.strip() for h in lines[0].split(","))
    if got != header:
        raise RunFormatError(f"{path}: line 1: header {','.join(got)!r}, expected "
                             f"{','.join(header)!r}")
    cols: list[list] = [[] for _ in header]
    for ln, line in enumerate(lines[1:], start=2):
        fields = line.split(",")
        if len(fields) != len(header):
            raise RunFormatError(f"{path}: line {ln}: {len(fields)} columns, "
                                 f"expected {len(header)} ({','.join(header)})")
        for j, (s, kind) in enumerate(zip(fields, kinds)):
            name = header[j]
            s = s.strip()
            if kind == "i":
                try:
                    v = int(s) if len(s) <= 40 else None      # int() reads 4300 digits
                except ValueError:
                    v = None
                if v is None:
                    raise RunFormatError(f"{path}: line {ln}: column {name}: expected an "
                                         f"integer, got {_shown(s)}")
                if not INT64_MIN <= v <= INT64_MAX:
                    raise RunFormatError(f"{path}: line {ln}: column {name}: expected an "
                                         f"integer within int64, got {_shown(s)}")
            else:
                try:
                    v = float(s)
                except ValueError:
                    raise RunFormatError(f"{path}: line {ln}: column {name}: expected a "
                                         f"number, got {_shown(s)}") from None
                if not math.isfinite(v) and not (math.isnan(v) and name in allow_nan):
                    raise RunFormatError(f"{path}: line {ln}: column {name}: expected a "
                                         f"finite number, got {_shown(s)}")
            cols[j].append(v)
    return {name: np.array(c, dtype=np.int64 if kind == "i" else float)
            for name, c, kind in zip(header, cols, kinds)}


def _increasing(path: Path, t: np.ndarray, name: str, strict: bool = True) -> None:
    d = np.diff(t)
    bad = np.flatnonzero(d <= 0.0 if strict else d < 0.0)
    if bad.size:
        i = int(bad[0]) + 1
        word = "strictly increasing" if strict else "non-decreasing"
        raise RunFormatError(f"{path}: line {i + 2}: column {name}: times not {word} "
                             f"({t[i]} after {t[i - 1]})")


def _is_number(v) -> bool:
    """A finite JSON number (not a bool; an integer too large for a float is not one)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    return math.isfinite(v) if isinstance(v, float) else abs(v) < 2**1000


def _read_meta(path: Path) -> dict:
    meta, _ = read_json_file(path, RunFormatError)
    if not isinstance(meta, dict):
        raise RunFormatError(f"{path}: line 1: expected a JSON object")
    if meta.get("format") != FORMAT:
        raise RunFormatError(f"{path}: field 'format': expected {FORMAT!r}, "
                             f"got {meta.get('format')!r}")
    for key in ("name", "world"):
        if not isinstance(meta.get(key), str) or not meta[key]:
            raise RunFormatError(f"{path}: field '{key}': expected a non-empty string")
    if not (WORLDS_DIR / f"{meta['world']}.json").is_file():
        raise RunFormatError(f"{path}: field 'world': unknown world {meta['world']!r} "
                             f"(no {meta['world']}.json in {WORLDS_DIR})")
    for key in ("encoder", "motion", "sensor", "controller"):
        if key in meta and not isinstance(meta[key], dict):
            raise RunFormatError(f"{path}: field '{key}': expected an object, got "
                                 f"{meta[key]!r}"[:200])
    for key, ok, what in (
            ("seed", lambda v: v is None or (isinstance(v, int) and not isinstance(v, bool)),
             "an integer or null"),
            ("duration", lambda v: _is_number(v) and v >= 0, "a number >= 0 (s)"),
            ("description", lambda v: isinstance(v, str), "a string")):
        if key in meta and not ok(meta[key]):
            raise RunFormatError(f"{path}: field '{key}': expected {what}, got "
                                 f"{meta[key]!r}"[:200])
    enc = meta.get("encoder", {})
    for key in ("rate", "ticks_per_rev", "wheel_radius", "wheel_base"):
        v = enc.get(key)
        if key in enc and (not _is_number(v) or v <= 0):
            raise RunFormatError(f"{path}: field 'encoder.{key}': expected a positive "
                                 f"number, got {v!r}")
    bits = enc.get("bits", 16)
    if isinstance(bits, bool) or not isinstance(bits, int) or not 1 <= bits <= 62:
        raise RunFormatError(f"{path}: field 'encoder.bits': expected an integer in 1..62, "
                             f"got {bits!r}")
    sw = meta.get("motion", {}).get("sigma_wheel", 0.0)
    if not _is_number(sw) or sw < 0:
        raise RunFormatError(f"{path}: field 'motion.sigma_wheel': expected a number >= 0, "
                             f"got {sw!r}")
    sensor = meta.get("sensor")
    if sensor and sensor.get("type") == AnalyticMarkerSensor.__name__:
        try:
            AnalyticMarkerSensor.from_params(sensor)
        except (TypeError, ValueError) as exc:
            raise RunFormatError(f"{path}: field 'sensor': {exc}") from None
    return meta


def _same_times(folder: Path, meta: dict, truth_t: np.ndarray, enc_t: np.ndarray,
                t_capture: np.ndarray) -> None:
    """The files of one run describe one stretch of time: the encoders span the meta's
    ``duration``, the truth covers the encoders and every camera frame lies within them
    (a frame after the last encoder reading would be fused with no prediction to it)."""
    enc = f"encoders.csv line {enc_t.size + 1}"
    span = float(enc_t[-1] - enc_t[0])
    if "duration" in meta and abs(span - float(meta["duration"])) > 1e-6:
        raise RunFormatError(f"{folder / 'meta.json'}: field 'duration': {meta['duration']} s, "
                             f"but the encoders span {span:g} s (the last reading, {enc}, is "
                             f"at t = {enc_t[-1]:g}): lines missing?")
    p = folder / "truth.csv"
    if truth_t[0] > enc_t[0]:
        raise RunFormatError(f"{p}: line 2: column t: the truth starts at {truth_t[0]:g} s, "
                             f"after the first encoder reading (t = {enc_t[0]:g} s)")
    if truth_t[-1] < enc_t[-1]:
        raise RunFormatError(f"{p}: line {truth_t.size + 1}: column t: the truth ends at "
                             f"{truth_t[-1]:g} s, before the last encoder reading "
                             f"(t = {enc_t[-1]:g} s, {enc})")
    p = folder / "camera.csv"
    for bad, word in ((t_capture < enc_t[0], "before the first"),
                      (t_capture > enc_t[-1], "after the last")):
        if bad.any():
            i = int(np.argmax(bad))
            raise RunFormatError(f"{p}: line {i + 2}: column t_capture: {t_capture[i]:g} s is "
                                 f"{word} encoder reading (t = "
                                 f"{enc_t[0 if word == 'before the first' else -1]:g} s)")


def load_run(folder) -> Run:
    """Load a run folder; a bare name is looked up in ``data/runs``.

    Raises
    ------
    RunFormatError
        With the file, the line number and the reason.
    """
    folder = Path(folder)
    if not folder.exists() and not folder.is_absolute() and len(folder.parts) == 1:
        folder = RUNS_DIR / folder.name
    if not folder.is_dir():
        raise RunFormatError(f"{folder}: not a run folder")
    meta = _read_meta(folder / "meta.json")
    bits = int(meta.get("encoder", {}).get("bits", 16))

    p = folder / "truth.csv"
    tr = _read_csv(p, TRUTH_HEADER, ("f", "f", "f", "f"))
    if tr["t"].size == 0:
        raise RunFormatError(f"{p}: line 2: no rows")
    _increasing(p, tr["t"], "t")

    p = folder / "encoders.csv"
    en = _read_csv(p, ENCODER_HEADER, ("f", "i", "i"))
    if en["t"].size == 0:
        raise RunFormatError(f"{p}: line 2: no rows")
    _increasing(p, en["t"], "t")
    for name in ("ticks_R", "ticks_L"):
        bad = np.flatnonzero((en[name] < 0) | (en[name] >= (1 << bits)))
        if bad.size:
            i = int(bad[0])
            raise RunFormatError(f"{p}: line {i + 2}: column {name}: expected a counter in "
                                 f"[0, {1 << bits}), got {en[name][i]}")

    p = folder / "camera.csv"
    ca = _read_csv(p, CAMERA_HEADER, ("f", "f", "i", "f", "f", "i", "f", "f"),
                   allow_nan=("true_rho", "true_bearing"))
    _increasing(p, ca["t_capture"], "t_capture", strict=False)
    late = np.flatnonzero(ca["t_arrival"] < ca["t_capture"])
    if late.size:
        i = int(late[0])
        raise RunFormatError(f"{p}: line {i + 2}: column t_arrival: arrives before its "
                             f"capture ({ca['t_arrival'][i]} < {ca['t_capture'][i]})")
    neg = np.flatnonzero(ca["rho"] < 0.0)
    if neg.size:
        i = int(neg[0])
        raise RunFormatError(f"{p}: line {i + 2}: column rho: expected a range >= 0, "
                             f"got {ca['rho'][i]}")
    _same_times(folder, meta, tr["t"], en["t"], ca["t_capture"])
    # times stored are rounded already; rounding again is the identity
    return Run(name=meta["name"], truth_t=tr["t"],
               truth=np.column_stack([tr["x"], tr["y"], tr["theta"]]),
               enc_t=en["t"], ticks_R=en["ticks_R"], ticks_L=en["ticks_L"],
               camera=CameraRows(**ca),
               meta={k: v for k, v in meta.items() if k not in ("format", "name")})
