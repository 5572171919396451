"""Noise identification (slamlib.datasets.identify) against data with a known answer."""

import numpy as np
import pytest
from test_mrclam import BARCODES, LANDMARKS, make_dataset

from slamlib.datasets import identify, mrclam
from slamlib.models import observe


def synthetic_dataset(folder, scale_v=0.9, scale_w=0.8, delay=0.2, seconds=120.0, seed=3):
    """Commands held for 0.5 s at 100 Hz; Vicon = the scaled commands, delayed, integrated."""
    rng = np.random.default_rng(seed)
    t = np.round(np.arange(0.0, seconds, 0.01), 3)
    held = np.repeat(rng.uniform([0.0, -0.6], [0.3, 0.6], size=(int(seconds / 0.5) + 1, 2)),
                     50, axis=0)[:t.size]
    fine = np.arange(0.0, seconds, 0.001)
    k = np.clip(np.searchsorted(t, fine - delay, side="right") - 1, 0, t.size - 1)
    v, w = scale_v * held[k, 0], scale_w * held[k, 1]
    v[fine < delay] = 0.0
    w[fine < delay] = 0.0
    th = np.r_[0.0, np.cumsum(w * 0.001)][:-1]
    x = np.r_[0.0, np.cumsum(v * np.cos(th) * 0.001)][:-1]
    y = np.r_[0.0, np.cumsum(v * np.sin(th) * 0.001)][:-1]
    gt = [(round(a, 3), b, c, d) for a, b, c, d in zip(fine[::16], x[::16], y[::16], th[::16])]
    odo = [(a, b, c) for a, (b, c) in zip(t, held)]
    return make_dataset(folder, **{"Robot1_Groundtruth.dat": gt, "Robot1_Odometry.dat": odo,
                                   "Robot1_Measurement.dat": [], "Barcodes.dat": BARCODES,
                                   "Landmark_Groundtruth.dat": LANDMARKS})


def test_odometry_calibration_recovers_known_scales_and_delay(tmp_path):
    log = mrclam.load(synthetic_dataset(tmp_path / "s"), 1)
    cal = identify.calibrate_odometry([log], window=1.0)
    assert cal.delay == pytest.approx(0.2)
    assert cal.scale_v == pytest.approx(0.9, abs=0.01)
    assert cal.scale_w == pytest.approx(0.8, abs=0.01)
    assert cal.rms_w[1] < 0.2 * cal.rms_w[0]        # calibration removes most of the residual
    # per-step noise from window residuals: s^2 = var * T_w / dt (T_w the window length)
    assert cal.sigma_v == pytest.approx(cal.rms_v[1] * np.sqrt(1.0 / cal.dt), rel=0.2)


def test_the_window_scaling_of_white_noise_is_right():
    # white noise of per-step sigma s on steps dt, averaged over T_w seconds, has sd s sqrt(dt/T_w)
    rng = np.random.default_rng(0)
    s, dt, T_w = 0.1, 0.01, 1.0
    noise = rng.normal(0.0, s, size=(4000, int(T_w / dt)))
    assert np.std(noise.mean(axis=1)) == pytest.approx(s * np.sqrt(dt / T_w), rel=0.05)
    np.testing.assert_allclose(identify.wheel_speed_covariance(0.1, 0.0, 0.23),
                               0.01 * np.ones((2, 2)))        # v noise moves both wheels


def test_reading_noise_fit_recovers_a_range_law_and_counts_outliers():
    rng = np.random.default_rng(1)
    n = 20000
    rho = rng.uniform(0.5, 6.0, n)
    e_rho = rng.normal(0.0, 0.02 + 0.04 * rho)
    e_b = rng.normal(0.0, 0.01, n)
    bad = rng.random(n) < 0.02
    e_b[bad] += rng.choice([-1, 1], bad.sum()) * rng.uniform(0.2, 1.0, bad.sum())
    res = identify.ReadingResiduals(np.arange(n) * 0.1, np.zeros(n, int), rho, e_rho, e_b)
    fit = identify.fit_reading_noise(res)
    assert fit.sigma_range0 == pytest.approx(0.02, abs=0.01)
    assert fit.sigma_range_per_m == pytest.approx(0.04, abs=0.004)
    assert fit.sigma_bearing == pytest.approx(0.01, rel=0.05)
    assert np.mean(fit.outlier[bad]) > 0.95 and np.mean(fit.outlier[~bad]) < 0.01
    assert identify.robust_sigma(e_b) == pytest.approx(0.01, rel=0.05)


def test_reading_residuals_are_zero_for_perfect_readings(tmp_path):
    folder = make_dataset(tmp_path / "p")
    log = mrclam.load(folder, 1)
    lm = log.world().landmarks()
    pose = log.truth_at(log.camera.t_capture)
    z = np.array([observe(p, lm[i]) for p, i in zip(pose, log.camera.id)])
    res = identify.reading_residuals(log.with_readings(z[:, 0], z[:, 1]))
    np.testing.assert_allclose(res.e_rho, 0.0, atol=1e-5)
    np.testing.assert_allclose(res.e_bearing, 0.0, atol=1e-5)
