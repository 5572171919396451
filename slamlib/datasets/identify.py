"""Noise identified from logs with ground truth (chapter 10), as a hypothesis to be tested.

A simulator is told its noise; a real robot's must be measured. With a
ground truth (Vicon) beside a log, every input of the filter can be compared
with what it should have been, and :func:`identify` turns the comparison into
a :class:`Calibration` that :func:`slamlib.datasets.mrclam.load` applies
(``load(folder, robot, calibration=cal)``). Its components:

- ``"scale"``, ``"delay"`` (:func:`fit_commands`): over windows of
  :data:`FIT_WINDOW` s, the forward distance and heading change Vicon shows
  against the commanded ones integrated over the same window: least-squares
  scale factors (a command is not what the wheels do) and the delay (the
  command takes effect later than it is logged) that leaves the smallest
  yaw-rate residual.
- ``"Q"`` (:func:`noise_density`): the speed errors that remain, modelled as
  white noise of a **density** ``q`` ((m/s)^2 s for the forward speed, (rad/s)^2 s
  for the yaw rate). White noise of density ``q`` averaged over a window of
  ``T`` s has variance ``q / T``, whatever steps the log has, so
  ``q = T mean(r^2)`` from the window residuals ``r`` (bias included: the
  filter cannot tell an unmodelled bias from noise). A filter step of ``dt``
  then gets ``Q = J diag(q_v, q_w) J^T / dt`` (``J`` below): its pose
  covariance ``W Q W^T`` grows in proportion to ``dt``, as the truth's does.
  :func:`whiteness` tests the white-noise hypothesis: ``q`` must not depend on
  ``T``, and successive windows' residuals must be uncorrelated.
- ``"R"`` (:func:`reading_residuals`, :func:`fit_reading_noise`): each
  reading's range and bearing against those of the known landmark from the
  true pose at its time; the range's spread fitted as ``a + b rho`` over
  range bins, the bearing's as one standard deviation.
- ``"outliers"``: readings more than ``k`` robust sigmas (:func:`robust_sigma`,
  1.4826 times the median absolute deviation) from their bin's median are
  left out of R's fit. Without it every residual counts.

The filters take ``u = [V_R, V_L]``: with ``V_R = v - b w/2`` and
``V_L = v + b w/2`` (z-down), independent noises on ``v`` and ``w`` give
``Q = J diag(s_v^2, s_w^2) J^T``, ``J = [[1, -b/2], [1, b/2]]``: a Q whose
wheels are correlated (:func:`wheel_speed_covariance`).

The residuals contain the truth's own error too (Vicon, the time alignment, a
landmark's radius): R identified this way is an upper bound of the sensor's
noise, and the right one for a filter fed the same data. Which components
:func:`identify` keeps by default (:data:`KEPT`) was decided on data the
identification never saw (chapter 10's held-out ablation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..models import range_bearing, wrap_angle

__all__ = ["robust_sigma", "OdometryWindows", "odometry_windows", "CommandFit",
           "fit_commands", "speed_residuals", "noise_density", "Whiteness", "whiteness",
           "wheel_speed_covariance", "ReadingResiduals", "reading_residuals", "ReadingNoise",
           "fit_reading_noise", "Calibration", "identify", "COMPONENTS", "KEPT",
           "FIT_WINDOW", "DENSITY_WINDOW", "OUTLIER_K"]

#: Scale from the median absolute deviation to a Gaussian's standard deviation.
MAD_TO_SIGMA = 1.482602218505602
#: Every component :func:`identify` can identify, in the order the chapter adds them.
COMPONENTS = ("R", "outliers", "Q", "scale", "delay")
#: The components :func:`identify` keeps by default: those that improved the held-out
#: part of Dataset 6 in chapter 10's ablation (the others made it worse or did not help).
KEPT = ("R", "outliers", "Q")
#: Window (s) of the command fit (scale, delay).
FIT_WINDOW = 1.0
#: Window (s) of the noise density's estimate (see :func:`whiteness`).
DENSITY_WINDOW = 1.0
#: The robust cut (in robust sigmas) of the "outliers" component.
OUTLIER_K = 5.0


def robust_sigma(x) -> float:
    """``1.4826 * median(|x - median(x)|)``: a standard deviation that outliers barely move."""
    x = np.asarray(x, dtype=float).reshape(-1)
    if x.size == 0:
        raise ValueError("x: expected at least one value")
    return float(MAD_TO_SIGMA * np.median(np.abs(x - np.median(x))))


# --------------------------------------------------------------------------- odometry
@dataclass(frozen=True)
class OdometryWindows:
    """Forward speed and yaw rate (z-down) over windows: from the truth and commanded.

    All arrays have one entry per window (starting at ``t``); ``v_cmd``/``w_cmd``
    are the commands' means over the window shifted by ``delay``.
    """

    t: np.ndarray
    v_true: np.ndarray
    w_true: np.ndarray
    v_cmd: np.ndarray
    w_cmd: np.ndarray
    window: float
    delay: float


def odometry_windows(log, window: float = 1.0, delay: float = 0.0) -> OdometryWindows:
    """The truth's and the commands' mean ``(v, w)`` over consecutive windows of ``window`` s.

    The truth's ``v`` is the distance Vicon moved along the robot's heading
    (each Vicon increment projected on the heading at its middle, summed) over
    the window, divided by it; ``w`` the heading change (increments wrapped,
    summed) divided by it. The commands are ``log.controls()`` (wheel speeds,
    turned back into ``v = (V_R + V_L)/2``, ``w = (V_L - V_R)/b``), integrated
    over ``[t - delay, t + window - delay]``.
    """
    if not (isinstance(window, (int, float)) and window > 0):
        raise ValueError(f"window: expected a positive duration, got {window!r}")
    if not (isinstance(delay, (int, float)) and math.isfinite(delay)):
        raise ValueError(f"delay: expected a finite number of seconds, got {delay!r}")
    u, dt = log.controls()
    T = log.enc_t
    v = 0.5 * (u[:, 0] + u[:, 1])
    w = (u[:, 1] - u[:, 0]) / log.wheel_base
    cum_v = np.r_[0.0, np.cumsum(v * dt)]
    cum_w = np.r_[0.0, np.cumsum(w * dt)]
    # the truth: distance along the heading and heading change, accumulated over Vicon
    X, tt = log.truth, log.truth_t
    dth = wrap_angle(np.diff(X[:, 2]))
    mid = X[:-1, 2] + 0.5 * dth
    d = np.diff(X[:, :2], axis=0)
    cum_s = np.r_[0.0, np.cumsum(d[:, 0] * np.cos(mid) + d[:, 1] * np.sin(mid))]
    cum_th = np.r_[0.0, np.cumsum(dth)]
    t = np.arange(T[0] + max(delay, 0.0), T[-1] - window + min(delay, 0.0), window)
    v_true = (np.interp(t + window, tt, cum_s) - np.interp(t, tt, cum_s)) / window
    w_true = (np.interp(t + window, tt, cum_th) - np.interp(t, tt, cum_th)) / window
    a, b = t - delay, t + window - delay
    v_cmd = (np.interp(b, T, cum_v) - np.interp(a, T, cum_v)) / window
    w_cmd = (np.interp(b, T, cum_w) - np.interp(a, T, cum_w)) / window
    return OdometryWindows(t, v_true, w_true, v_cmd, w_cmd, float(window), float(delay))


def wheel_speed_covariance(sigma_v: float, sigma_w: float, wheel_base: float) -> np.ndarray:
    """``Q = J diag(sigma_v^2, sigma_w^2) J^T`` of ``[V_R, V_L]``, ``J = [[1, -b/2], [1, b/2]]``.

    The same map takes densities: ``sqrt(q_v)``, ``sqrt(q_w)`` give ``Q_c``.
    """
    J = np.array([[1.0, -0.5 * wheel_base], [1.0, 0.5 * wheel_base]])
    return J @ np.diag([sigma_v ** 2, sigma_w ** 2]) @ J.T


@dataclass(frozen=True)
class CommandFit:
    """What :func:`fit_commands` found: ``v_true ~ scale_v v_cmd(t - delay)``, same for w.

    ``rms_v``, ``rms_w``: RMS of the window residuals (m/s, rad/s) of the
    commands as logged and corrected, ``(raw, corrected)``.
    """

    scale_v: float
    scale_w: float
    delay: float
    rms_v: tuple
    rms_w: tuple


#: The commands as logged.
AS_LOGGED = CommandFit(1.0, 1.0, 0.0, (math.nan, math.nan), (math.nan, math.nan))


def _pooled(logs, window: float, delay: float):
    ws = [odometry_windows(lg, window, delay) for lg in logs]
    return [np.concatenate([getattr(w, k) for w in ws])
            for k in ("v_true", "w_true", "v_cmd", "w_cmd")]


def fit_commands(logs, *, scale: bool = True, delay: bool = True, window: float = FIT_WINDOW,
                 delays=None) -> CommandFit:
    """Scale factors and delay of the commands, pooled over ``logs`` with truth.

    The delay is the one of ``delays`` (default 0 to 0.5 s by 0.05 s; 0 when
    ``delay`` is False) with the smallest yaw-rate residual after scaling; the
    scales are the least-squares ``sum(true * cmd) / sum(cmd^2)`` (1 when
    ``scale`` is False).
    """
    logs = list(logs)
    if not logs:
        raise ValueError("logs: expected at least one log")
    if delays is None:
        delays = np.round(np.arange(0.0, 0.501, 0.05), 2)
    grid = [float(d) for d in np.atleast_1d(delays)] if delay else [0.0]
    best = None
    for d in grid:
        vt, wt, vc, wc = _pooled(logs, window, d)
        sv = float(np.sum(vt * vc) / np.sum(vc * vc)) if scale else 1.0
        sw = float(np.sum(wt * wc) / np.sum(wc * wc)) if scale else 1.0
        cost = float(np.mean((wt - sw * wc) ** 2))
        if best is None or cost < best[0]:
            best = (cost, d, sv, sw, vt, wt, vc, wc)
    _, d, sv, sw, vt, wt, vc, wc = best
    vt0, wt0, vc0, wc0 = _pooled(logs, window, 0.0)

    def rms(x):
        return float(np.sqrt(np.mean(x ** 2)))

    return CommandFit(sv, sw, d, (rms(vt0 - vc0), rms(vt - sv * vc)),
                      (rms(wt0 - wc0), rms(wt - sw * wc)))


def speed_residuals(logs, window: float, commands: CommandFit = AS_LOGGED
                    ) -> tuple[list, list]:
    """Per log, the window residuals ``v_true - scale_v v_cmd`` and ``w_true - scale_w w_cmd``
    (windows of ``window`` s, the commands delayed by ``commands.delay``)."""
    rv, rw = [], []
    for lg in logs:
        w = odometry_windows(lg, window, commands.delay)
        rv.append(w.v_true - commands.scale_v * w.v_cmd)
        rw.append(w.w_true - commands.scale_w * w.w_cmd)
    return rv, rw


def noise_density(logs, window: float = DENSITY_WINDOW, commands: CommandFit = AS_LOGGED
                  ) -> tuple[float, float]:
    """``(q_v, q_w)``: the densities ``T mean(r^2)`` of the window residuals, pooled.

    White noise of density ``q`` averaged over ``T`` s has variance ``q / T``;
    a bias that the commands leave counts as noise (mean of ``r^2``, not the
    variance).
    """
    rv, rw = speed_residuals(list(logs), window, commands)
    v, w = np.concatenate(rv), np.concatenate(rw)
    if v.size < 2:
        raise ValueError(f"logs: expected at least two windows of {window} s, got {v.size}")
    return float(window * np.mean(v ** 2)), float(window * np.mean(w ** 2))


def _lag1(parts) -> float:
    """Correlation of successive windows' residuals, each log about its own mean, pooled."""
    a = np.concatenate([p[:-1] - p.mean() for p in parts if p.size > 1])
    b = np.concatenate([p[1:] - p.mean() for p in parts if p.size > 1])
    return float(np.sum(a * b) / np.sqrt(np.sum(a * a) * np.sum(b * b)))


@dataclass(frozen=True)
class Whiteness:
    """The white-noise test of :func:`whiteness`: per window length ``T`` (s), the density
    ``q(T) = T mean(r^2)`` and the correlation of successive windows' residuals, for the
    forward speed (``v``) and the yaw rate (``w``). White noise: ``q`` flat in ``T``,
    correlations near 0 (within about ``2 / sqrt(n)``)."""

    windows: np.ndarray
    n: np.ndarray
    q_v: np.ndarray
    q_w: np.ndarray
    corr_v: np.ndarray
    corr_w: np.ndarray


def whiteness(logs, windows=(0.5, 1.0, 2.0, 4.0, 8.0, 16.0),
              commands: CommandFit = AS_LOGGED) -> Whiteness:
    """Test the white-noise model of the speed errors over several window lengths."""
    logs = list(logs)
    rows = []
    for T in windows:
        rv, rw = speed_residuals(logs, float(T), commands)
        v, w = np.concatenate(rv), np.concatenate(rw)
        rows.append((float(T), v.size, T * np.mean(v ** 2), T * np.mean(w ** 2), _lag1(rv),
                     _lag1(rw)))
    cols = list(zip(*rows))
    return Whiteness(*(np.array(c) for c in cols))


# --------------------------------------------------------------------------- readings
@dataclass(frozen=True)
class ReadingResiduals:
    """Each reading against the known landmark seen from the true pose.

    ``rho`` the true range (m), ``e_rho`` measured minus true range (m),
    ``e_bearing`` measured minus true bearing (rad, wrapped), ``ids`` the
    landmark, ``t`` the reading's time; one entry per reading of a mapped id.
    """

    t: np.ndarray
    ids: np.ndarray
    rho: np.ndarray
    e_rho: np.ndarray
    e_bearing: np.ndarray

    @staticmethod
    def concatenate(parts) -> ReadingResiduals:
        """Pool several logs' residuals."""
        parts = list(parts)
        return ReadingResiduals(*(np.concatenate([getattr(p, k) for p in parts])
                                  for k in ("t", "ids", "rho", "e_rho", "e_bearing")))


def reading_residuals(log, landmarks=None) -> ReadingResiduals:
    """Residuals of every reading of a known landmark (``log.world()`` by default)."""
    lm = log.world().landmarks() if landmarks is None else landmarks
    c = log.camera
    keep = np.array([i in lm for i in c.id.tolist()], dtype=bool)
    t, ids = c.t_capture[keep], c.id[keep]
    pose = log.truth_at(t).reshape(-1, 3)
    L = np.array([lm[i] for i in ids.tolist()], dtype=float).reshape(-1, 2)
    rho, bearing = range_bearing(L[:, 0] - pose[:, 0], L[:, 1] - pose[:, 1], pose[:, 2])
    return ReadingResiduals(t, ids, rho, c.rho[keep] - rho, wrap_angle(c.bearing[keep] - bearing))


@dataclass(frozen=True)
class ReadingNoise:
    """A reading noise model fitted to residuals (:func:`fit_reading_noise`).

    Attributes
    ----------
    sigma_range0, sigma_range_per_m : float
        ``sigma_rho = sigma_range0 + sigma_range_per_m * rho`` (m).
    sigma_bearing : float
        Bearing standard deviation of the inliers (rad).
    outlier : numpy.ndarray of bool
        Which readings were outliers (beyond ``k`` robust sigmas in range, for
        its range bin, or in bearing); all False without an outlier model.
    k : float or None
        The cut, in robust sigmas (None: no outlier model).
    bins : numpy.ndarray (n+1,)
        Range bin edges (m).
    bin_sigma_range, bin_bias, bin_sigma_bearing : numpy.ndarray (n,)
        Per bin: inlier standard deviation and mean of the range residual, and
        the bearing's standard deviation (nan for an empty bin).
    bin_count : numpy.ndarray (n,) of int
    """

    sigma_range0: float
    sigma_range_per_m: float
    sigma_bearing: float
    outlier: np.ndarray
    k: float | None
    bins: np.ndarray
    bin_sigma_range: np.ndarray
    bin_bias: np.ndarray
    bin_sigma_bearing: np.ndarray
    bin_count: np.ndarray

    def sigma_range(self, rho):
        """The fitted range standard deviation at ``rho`` (m)."""
        return self.sigma_range0 + self.sigma_range_per_m * np.asarray(rho, dtype=float)

    def params(self) -> dict:
        """The parameters a :class:`~slamlib.sensors.AnalyticMarkerSensor` (and ``load``) take."""
        return {"sigma_range0": self.sigma_range0, "sigma_range_per_m": self.sigma_range_per_m,
                "sigma_bearing": self.sigma_bearing}


def fit_reading_noise(res: ReadingResiduals, bins=None, k: float | None = OUTLIER_K
                      ) -> ReadingNoise:
    """Fit ``sigma_rho = a + b rho`` and ``sigma_bearing`` to residuals, outliers excluded.

    A reading is an outlier when its range residual is more than ``k`` robust
    sigmas (of its range bin) from the bin's median, or its bearing residual
    more than ``k`` robust sigmas from the median of all (``k=None``: no
    outliers, every residual counts). The line is a least-squares fit,
    weighted by count, of the bins' inlier standard deviations against the
    bins' mean range (bins with at least 20 inliers); ``a`` is clipped at 0.
    """
    if k is not None and not (isinstance(k, (int, float)) and k > 0):
        raise ValueError(f"k: expected a positive number of robust sigmas or None, got {k!r}")
    bins = np.arange(0.0, 8.01, 1.0) if bins is None else np.asarray(bins, dtype=float)
    nb = bins.size - 1
    which = np.clip(np.searchsorted(bins, res.rho, side="right") - 1, 0, nb - 1)
    outlier = np.zeros(res.rho.size, dtype=bool)
    if k is not None:
        mb, sb = np.median(res.e_bearing), robust_sigma(res.e_bearing)
        outlier |= np.abs(res.e_bearing - mb) > k * sb
    sig, bias, sigb, cnt, mid = (np.full(nb, np.nan) for _ in range(5))
    for j in range(nb):
        m = which == j
        if k is None or np.sum(m) < 5:
            continue
        med, s = np.median(res.e_rho[m]), robust_sigma(res.e_rho[m])
        outlier[m] |= np.abs(res.e_rho[m] - med) > k * s
    for j in range(nb):
        m = (which == j) & ~outlier
        cnt[j] = np.sum(m)
        if cnt[j] >= 2:
            sig[j], bias[j] = np.std(res.e_rho[m]), np.mean(res.e_rho[m])
            sigb[j], mid[j] = np.std(res.e_bearing[m]), np.mean(res.rho[m])
    use = cnt >= 20
    if np.sum(use) >= 2:
        A = np.column_stack([np.ones(np.sum(use)), mid[use]]) * np.sqrt(cnt[use])[:, None]
        a, b = np.linalg.lstsq(A, sig[use] * np.sqrt(cnt[use]), rcond=None)[0]
        if a < 0.0:
            a, b = 0.0, float(np.sum(cnt[use] * mid[use] * sig[use])
                              / np.sum(cnt[use] * mid[use] ** 2))
    else:
        a, b = float(np.std(res.e_rho[~outlier])), 0.0
    return ReadingNoise(float(a), float(b), float(np.std(res.e_bearing[~outlier])), outlier,
                        None if k is None else float(k), bins, sig, bias, sigb,
                        cnt.astype(int))


# --------------------------------------------------------------------------- the calibration
@dataclass(frozen=True)
class Calibration:
    """What :func:`identify` found, for :func:`slamlib.datasets.mrclam.load` to apply.

    A component that was not identified is None and leaves the log's default:
    the commands as logged, the textbook noise (:data:`mrclam.TEXTBOOK_NOISE`).

    Attributes
    ----------
    components : tuple of str
        The components identified (of :data:`COMPONENTS`).
    command_scale : (float, float) or None
        Factors applied to the logged ``v`` and ``w``.
    command_delay : float or None
        Seconds from a command's log time to its effect.
    q_density : (float, float) or None
        Densities of the forward-speed ((m/s)^2 s) and yaw-rate ((rad/s)^2 s) errors.
    reading : dict or None
        ``sigma_range0``, ``sigma_range_per_m`` (m, m/m), ``sigma_bearing`` (rad).
    outlier_k : float or None
        The cut of R's fit in robust sigmas (None: every residual counted).
    window : float
        The density's window (s).
    counts : dict
        ``logs``, ``windows`` (of the density), ``readings``, ``outliers``.
    """

    components: tuple = ()
    command_scale: tuple | None = None
    command_delay: float | None = None
    q_density: tuple | None = None
    reading: dict | None = None
    outlier_k: float | None = None
    window: float = DENSITY_WINDOW
    counts: dict = field(default_factory=dict)

    def noise(self, wheel_base: float) -> dict:
        """The ``noise`` argument of :func:`~slamlib.datasets.mrclam.load`: ``Q_density``
        (2x2 of ``[V_R, V_L]`` on ``wheel_base``) and the reading parameters, as identified."""
        out: dict = {}
        if self.q_density is not None:
            out["Q_density"] = wheel_speed_covariance(math.sqrt(self.q_density[0]),
                                                      math.sqrt(self.q_density[1]), wheel_base)
        if self.reading is not None:
            out.update(self.reading)
        return out

    def to_dict(self) -> dict:
        """A JSON-able dict (:meth:`from_dict` reads it back)."""
        return {"components": list(self.components),
                "command_scale": None if self.command_scale is None else list(self.command_scale),
                "command_delay": self.command_delay,
                "q_density": None if self.q_density is None else list(self.q_density),
                "reading": self.reading, "outlier_k": self.outlier_k, "window": self.window,
                "counts": dict(self.counts)}

    @classmethod
    def from_dict(cls, d: dict) -> Calibration:
        """The calibration :meth:`to_dict` wrote."""
        unknown = set(d.get("components", ())) - set(COMPONENTS)
        if unknown:
            raise ValueError(f"components: expected names from {COMPONENTS}, got "
                             f"{sorted(unknown)}")
        return cls(components=tuple(d["components"]),
                   command_scale=None if d["command_scale"] is None else
                   tuple(float(v) for v in d["command_scale"]),
                   command_delay=d["command_delay"],
                   q_density=None if d["q_density"] is None else
                   tuple(float(v) for v in d["q_density"]),
                   reading=None if d["reading"] is None else
                   {k: float(v) for k, v in d["reading"].items()},
                   outlier_k=d["outlier_k"], window=float(d["window"]),
                   counts=dict(d.get("counts", {})))

    def describe(self) -> str:
        """One line per component, as a chapter prints it."""
        rows = []
        if self.command_scale is not None:
            rows.append(f"command scale  v x {self.command_scale[0]:.3f}, "
                        f"w x {self.command_scale[1]:.3f}")
        if self.command_delay is not None:
            rows.append(f"command delay  {self.command_delay:.2f} s")
        if self.q_density is not None:
            rows.append(f"Q density      q_v = {self.q_density[0]:.2e} (m/s)^2 s, "
                        f"q_w = {self.q_density[1]:.2e} (rad/s)^2 s  ({self.window:g} s windows)")
        if self.reading is not None:
            r = self.reading
            cut = ("every residual" if self.outlier_k is None else
                   f"outliers beyond {self.outlier_k:g} robust sigmas left out")
            rows.append(f"R(rho)         sigma_rho = {r['sigma_range0']:.3f} + "
                        f"{r['sigma_range_per_m']:.3f} rho m, sigma_beta = "
                        f"{r['sigma_bearing']:.4f} rad ({cut})")
        return "\n".join(rows) if rows else "nothing identified: the textbook noise"


def identify(logs, components=KEPT, *, window: float = DENSITY_WINDOW,
             k: float = OUTLIER_K) -> Calibration:
    """Identify the noise of ``logs`` (logs with truth, e.g. ``mrclam.load(...)``), pooled.

    Parameters
    ----------
    logs : iterable of Log
        The logs to learn from (as loaded: commands as logged, any noise).
    components : iterable of str
        Which of :data:`COMPONENTS` to identify; the rest stay the log's default.
        The default, :data:`KEPT`, is what held out data supported (chapter 10).
    window : float
        The window (s) of the noise density's estimate.
    k : float
        The outlier cut of R's fit, in robust sigmas ("outliers" component).

    Returns
    -------
    Calibration
    """
    logs = list(logs)
    if not logs:
        raise ValueError("logs: expected at least one log")
    comps = tuple(components)
    unknown = set(comps) - set(COMPONENTS)
    if unknown:
        raise ValueError(f"components: expected names from {COMPONENTS}, got {sorted(unknown)}")
    comps = tuple(c for c in COMPONENTS if c in comps)       # in the canonical order
    if "outliers" in comps and "R" not in comps:
        raise ValueError("components: 'outliers' is part of R's fit; expected 'R' with it")
    use_scale, use_delay = "scale" in comps, "delay" in comps
    cmd = (fit_commands(logs, scale=use_scale, delay=use_delay)
           if use_scale or use_delay else AS_LOGGED)
    out: dict = {"components": comps, "window": float(window)}
    if use_scale:
        out["command_scale"] = (cmd.scale_v, cmd.scale_w)
    if use_delay:
        out["command_delay"] = cmd.delay
    counts = {"logs": len(logs)}
    if "Q" in comps:
        out["q_density"] = noise_density(logs, window, cmd)
        counts["windows"] = int(sum(odometry_windows(lg, window, cmd.delay).t.size
                                    for lg in logs))
    if "R" in comps:
        res = ReadingResiduals.concatenate(reading_residuals(lg) for lg in logs)
        fit = fit_reading_noise(res, k=k if "outliers" in comps else None)
        out["reading"] = fit.params()
        out["outlier_k"] = fit.k
        counts["readings"] = int(res.rho.size)
        counts["outliers"] = int(fit.outlier.sum())
    return Calibration(counts=counts, **out)
