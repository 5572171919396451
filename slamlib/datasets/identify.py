"""Noise identified from a log with ground truth (chapter 10).

A simulator is told its noise; a real robot's must be measured. With a
ground truth (Vicon) beside the log, every input of the filter can be compared
with what it should have been:

- **odometry** (:func:`odometry_windows`, :func:`calibrate_odometry`): over
  windows of ``window`` seconds, the forward speed and yaw rate the truth
  shows against the commanded ones integrated over the same window. A least
  squares fit gives scale factors (a command is not what the wheels do) and a
  delay (the command takes effect later than it is logged); what remains is
  the noise. The filters add noise per prediction step: a speed error of
  variance ``s^2`` held over a step of ``dt_k``, so that the mean over a window
  of length ``T_w`` has variance ``s^2 sum_k dt_k^2 / T_w^2``, which is
  ``s^2 dt / T_w`` for equal steps of ``dt``. With ``dt`` the median step,
  ``s^2 = var(residual) T_w / dt``. (``T_w``, not ``W``: W is the motion
  model's noise Jacobian everywhere in the course.) On a real timeline, whose steps are not all
  equal (gaps of up to a second between commands), the longer steps make the
  filter's variance larger than that (``mean_step_sq`` tells by how much);
  the residuals are also correlated in time, which makes the true error grow
  faster than white noise would: chapter 10 measures both. The filters take ``u = [V_R, V_L]``: with
  ``V_R = v - b w/2`` and ``V_L = v + b w/2`` (z-down), independent noises on
  ``v`` and ``w`` give ``Q = J diag(s_v^2, s_w^2) J^T``, ``J = [[1, -b/2],
  [1, b/2]]``, a Q whose wheels are correlated.
- **readings** (:func:`reading_residuals`, :func:`fit_reading_noise`): range
  and bearing against those of the known landmark from the true pose at the
  reading's time. Outliers are counted with a robust scale
  (:func:`robust_sigma`, 1.4826 times the median absolute deviation) and
  left out of the fit; the range's spread is fitted as ``a + b rho`` over range
  bins.

The residuals of the readings contain the truth's own error (Vicon, the time
alignment, a landmark's radius): R identified this way is an upper bound of
the sensor's noise, and the right one for a filter fed the same data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..models import range_bearing, wrap_angle

__all__ = ["robust_sigma", "OdometryWindows", "odometry_windows", "OdometryCalibration",
           "calibrate_odometry", "wheel_speed_covariance", "ReadingResiduals",
           "reading_residuals", "ReadingNoise", "fit_reading_noise"]

#: Scale from the median absolute deviation to a Gaussian's standard deviation.
MAD_TO_SIGMA = 1.482602218505602


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

    All arrays have one entry per window; ``v_cmd``/``w_cmd`` are the
    commands' means over the window shifted by ``delay``; ``step_sq`` the sum
    of the squared prediction steps inside each window (s^2, steps cut at the
    window's edges); ``dt`` is the log's median prediction step.
    """

    t: np.ndarray
    v_true: np.ndarray
    w_true: np.ndarray
    v_cmd: np.ndarray
    w_cmd: np.ndarray
    step_sq: np.ndarray
    window: float
    delay: float
    dt: float


def odometry_windows(log, window: float = 1.0, delay: float = 0.0) -> OdometryWindows:
    """The truth's and the commands' mean ``(v, w)`` over consecutive windows of ``window`` s.

    The truth's ``v`` is the displacement over the window projected on the
    heading at its start, divided by the window; ``w`` the wrapped heading
    change divided by it. The commands are ``log.controls()`` (wheel speeds,
    turned back into ``v = (V_R + V_L)/2``, ``w = (V_L - V_R)/b``), integrated
    over ``[t - delay, t + window - delay]``.
    """
    if not window > 0:
        raise ValueError(f"window: expected a positive duration, got {window!r}")
    u, dt = log.controls()
    T = log.enc_t
    v = 0.5 * (u[:, 0] + u[:, 1])
    w = (u[:, 1] - u[:, 0]) / log.wheel_base
    cum_v = np.r_[0.0, np.cumsum(v * dt)]
    cum_w = np.r_[0.0, np.cumsum(w * dt)]
    t = np.arange(T[0] + max(delay, 0.0), T[-1] - window + min(delay, 0.0), window)
    p0, p1 = log.truth_at(t), log.truth_at(t + window)
    d = p1[:, :2] - p0[:, :2]
    v_true = (d[:, 0] * np.cos(p0[:, 2]) + d[:, 1] * np.sin(p0[:, 2])) / window
    w_true = wrap_angle(p1[:, 2] - p0[:, 2]) / window
    a, b = t - delay, t + window - delay
    v_cmd = (np.interp(b, T, cum_v) - np.interp(a, T, cum_v)) / window
    w_cmd = (np.interp(b, T, cum_w) - np.interp(a, T, cum_w)) / window
    # sum of squared steps inside [a, b]: whole steps, plus the parts cut by the edges
    ia, ib = np.searchsorted(T, a, side="right"), np.searchsorted(T, b, side="right")
    cum_d2 = np.r_[0.0, np.cumsum(dt * dt)]
    step_sq = cum_d2[np.maximum(ib - 1, ia)] - cum_d2[ia]
    step_sq += (T[np.minimum(ia, T.size - 1)] - a) ** 2 + (b - T[np.maximum(ib - 1, 0)]) ** 2
    return OdometryWindows(t, v_true, w_true, v_cmd, w_cmd, step_sq, float(window),
                           float(delay), float(np.median(dt)))


def wheel_speed_covariance(sigma_v: float, sigma_w: float, wheel_base: float) -> np.ndarray:
    """``Q = J diag(sigma_v^2, sigma_w^2) J^T`` of ``[V_R, V_L]``, ``J = [[1, -b/2], [1, b/2]]``."""
    J = np.array([[1.0, -0.5 * wheel_base], [1.0, 0.5 * wheel_base]])
    return J @ np.diag([sigma_v ** 2, sigma_w ** 2]) @ J.T


@dataclass(frozen=True)
class OdometryCalibration:
    """What :func:`calibrate_odometry` found.

    Attributes
    ----------
    scale_v, scale_w : float
        True over commanded forward speed and yaw rate (least squares).
    delay : float
        Seconds from a command's log time to its effect.
    sigma_v, sigma_w : float
        Per-step standard deviations of the remaining noise on ``v`` (m/s) and
        ``w`` (rad/s) (see the module doc).
    window, dt : float
        The window, and the median step of the logs.
    mean_step_sq : float
        The mean over the windows of the sum of squared steps inside (s^2).
    rms_v, rms_w : float
        RMS of the window residuals (m/s, rad/s) before and after: tuples
        ``(raw, calibrated)``.
    """

    scale_v: float
    scale_w: float
    delay: float
    sigma_v: float
    sigma_w: float
    window: float
    dt: float
    rms_v: tuple
    rms_w: tuple
    mean_step_sq: float

    def Q(self, wheel_base: float) -> np.ndarray:
        """The identified covariance of ``u = [V_R, V_L]`` per step (see the module doc)."""
        return wheel_speed_covariance(self.sigma_v, self.sigma_w, wheel_base)


def calibrate_odometry(logs, window: float = 1.0, delays=None) -> OdometryCalibration:
    """Scale factors, delay and per-step noise of the commands, from logs with truth.

    The delay is the one of ``delays`` (default 0 to 0.5 s by 0.05 s) with the
    smallest yaw-rate residual after scaling; the scales are the least-squares
    ``sum(true * cmd) / sum(cmd^2)`` pooled over all ``logs``.
    """
    logs = list(logs)
    if not logs:
        raise ValueError("logs: expected at least one log")
    delays = np.round(np.arange(0.0, 0.501, 0.05), 2) if delays is None else np.asarray(delays)

    def pooled(delay):
        ws = [odometry_windows(lg, window, float(delay)) for lg in logs]
        return (np.concatenate([getattr(w, k) for w in ws])
                for k in ("v_true", "w_true", "v_cmd", "w_cmd", "step_sq")), ws[0].dt

    best = None
    for delay in delays:
        (vt, wt, vc, wc, d2), dt = pooled(delay)
        sv, sw = np.sum(vt * vc) / np.sum(vc * vc), np.sum(wt * wc) / np.sum(wc * wc)
        cost = float(np.mean((wt - sw * wc) ** 2))
        if best is None or cost < best[0]:
            best = (cost, float(delay), sv, sw, vt, wt, vc, wc, d2, dt)
    _, delay, sv, sw, vt, wt, vc, wc, d2, dt = best
    (vt0, wt0, vc0, wc0, _), _ = pooled(0.0)
    rv, rw = vt - sv * vc, wt - sw * wc
    gain = np.sqrt(window / dt)                 # s = sd(residual) sqrt(T_w / dt), equal steps
    return OdometryCalibration(
        scale_v=float(sv), scale_w=float(sw), delay=delay,
        sigma_v=float(np.std(rv) * gain), sigma_w=float(np.std(rw) * gain),
        window=float(window), dt=float(dt),
        rms_v=(float(np.sqrt(np.mean((vt0 - vc0) ** 2))), float(np.sqrt(np.mean(rv ** 2)))),
        rms_w=(float(np.sqrt(np.mean((wt0 - wc0) ** 2))), float(np.sqrt(np.mean(rw ** 2)))),
        mean_step_sq=float(np.mean(d2)))


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
        its range bin, or in bearing).
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


def fit_reading_noise(res: ReadingResiduals, bins=None, k: float = 5.0) -> ReadingNoise:
    """Fit ``sigma_rho = a + b rho`` and ``sigma_bearing`` to residuals, outliers excluded.

    A reading is an outlier when its range residual is more than ``k`` robust
    sigmas (of its range bin) from the bin's median, or its bearing residual
    more than ``k`` robust sigmas from the median of all. The line is a
    least-squares fit, weighted by count, of the bins' inlier standard
    deviations against the bins' mean range (bins with at least 20 inliers);
    ``a`` is clipped at 0.
    """
    bins = np.arange(0.0, 8.01, 1.0) if bins is None else np.asarray(bins, dtype=float)
    nb = bins.size - 1
    which = np.clip(np.searchsorted(bins, res.rho, side="right") - 1, 0, nb - 1)
    mb, sb = np.median(res.e_bearing), robust_sigma(res.e_bearing)
    outlier = np.abs(res.e_bearing - mb) > k * sb
    sig, bias, sigb, cnt, mid = (np.full(nb, np.nan) for _ in range(5))
    for j in range(nb):
        m = which == j
        if np.sum(m) < 5:
            cnt[j] = np.sum(m)
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
                        bins, sig, bias, sigb, cnt.astype(int))
