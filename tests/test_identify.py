"""Noise identification (slamlib.datasets.identify) against data with a known answer, and the
API round trip identify -> load(calibration=...) -> the filter."""

import warnings

import numpy as np
import pytest
from test_mrclam import BARCODES, LANDMARKS, make_dataset

from slamlib.datasets import identify, mrclam
from slamlib.models import observe


def synthetic_dataset(folder, scale_v=0.9, scale_w=0.8, delay=0.2, seconds=120.0, seed=3,
                      q_v=0.0, q_w=0.0, gaps=False, drift_w=0.0):
    """Commands held for 0.5 s, logged at 100 Hz (with ``gaps``: every 7th second logged
    only once per held command, as the real logs have gaps); Vicon = the scaled commands, delayed,
    plus white noise of densities ``q_v``, ``q_w`` (drawn every 1 ms) and a slow yaw-rate
    error ``drift_w sin(2 pi t / 60 s)``, integrated."""
    rng = np.random.default_rng(seed)
    t = np.round(np.arange(0.0, seconds, 0.01), 3)
    held = np.repeat(rng.uniform([0.0, -0.6], [0.3, 0.6], size=(int(seconds / 0.5) + 1, 2)),
                     50, axis=0)[:t.size]
    fine = np.arange(0.0, seconds, 0.001)
    k = np.clip(np.searchsorted(t, fine - delay, side="right") - 1, 0, t.size - 1)
    v, w = scale_v * held[k, 0], scale_w * held[k, 1]
    v[fine < delay] = 0.0
    w[fine < delay] = 0.0
    v = v + rng.normal(0.0, np.sqrt(q_v / 0.001), fine.size)       # density q: var q / dt
    w = w + rng.normal(0.0, np.sqrt(q_w / 0.001), fine.size) + drift_w * np.sin(fine / 60.0
                                                                                * 2 * np.pi)
    th = np.r_[0.0, np.cumsum(w * 0.001)][:-1]
    x = np.r_[0.0, np.cumsum(v * np.cos(th) * 0.001)][:-1]
    y = np.r_[0.0, np.cumsum(v * np.sin(th) * 0.001)][:-1]
    gt = [(round(a, 3), b, c, d) for a, b, c, d in zip(fine[::16], x[::16], y[::16], th[::16])]
    logged = np.ones(t.size, dtype=bool)
    if gaps:       # the command in force is the last logged: drop repeats inside a held command
        logged &= ~((np.floor(t) % 7 == 3) & (np.round(t * 100) % 50 != 0))
    odo = [(a, b, c) for a, (b, c), keep in zip(t, held, logged) if keep]
    return make_dataset(folder, **{"Robot1_Groundtruth.dat": gt, "Robot1_Odometry.dat": odo,
                                   "Robot1_Measurement.dat": [], "Barcodes.dat": BARCODES,
                                   "Landmark_Groundtruth.dat": LANDMARKS})


def test_the_command_fit_recovers_known_scales_and_delay(tmp_path):
    log = mrclam.load(synthetic_dataset(tmp_path / "s"), 1)
    fit = identify.fit_commands([log])
    assert fit.delay == pytest.approx(0.2)
    assert fit.scale_v == pytest.approx(0.9, abs=0.01)
    assert fit.scale_w == pytest.approx(0.8, abs=0.01)
    assert fit.rms_w[1] < 0.2 * fit.rms_w[0]        # the fit removes most of the residual
    only_scale = identify.fit_commands([log], delay=False)
    assert only_scale.delay == 0.0 and only_scale.rms_w[1] > fit.rms_w[1]
    as_logged = identify.fit_commands([log], scale=False, delay=False)
    assert (as_logged.scale_v, as_logged.scale_w, as_logged.delay) == (1.0, 1.0, 0.0)


@pytest.mark.parametrize("gaps", [False, True])
def test_a_white_noise_density_is_recovered_whatever_the_steps(tmp_path, gaps):
    q_v, q_w = 4e-4, 2e-3
    log = mrclam.load(synthetic_dataset(tmp_path / "n", 1.0, 1.0, 0.0, seconds=600.0, seed=5,
                                        q_v=q_v, q_w=q_w, gaps=gaps), 1)
    if gaps:
        assert np.diff(log.enc_t).max() > 0.4                 # steps up to 0.5 s
    got = identify.noise_density([log], window=1.0)
    # 600 windows: the estimate of a variance has a relative sd of sqrt(2/600) = 6 %
    assert got[0] == pytest.approx(q_v, rel=0.2) and got[1] == pytest.approx(q_w, rel=0.2)
    white = identify.whiteness([log], windows=(0.5, 1.0, 2.0, 4.0))
    assert np.all(np.abs(white.q_w / q_w - 1.0) < 0.3)        # flat in T: white
    assert np.all(np.abs(white.corr_w) < 3.0 / np.sqrt(white.n))


def test_whiteness_sees_a_correlated_error(tmp_path):
    # a slow error the model does not know persists from one window to the next: q grows with
    # T and successive windows correlate; the white part alone passes
    for drift, white_noise in ((0.03, False), (0.0, True)):
        log = mrclam.load(synthetic_dataset(tmp_path / f"c{drift}", 1.0, 1.0, 0.0,
                                            seconds=300.0, q_w=1e-4, drift_w=drift), 1)
        white = identify.whiteness([log], windows=(0.5, 1.0, 2.0, 4.0))
        assert (white.q_w[-1] < 1.5 * white.q_w[0]) == white_noise, white.q_w
        assert (white.corr_w[1] < 0.2) == white_noise, white.corr_w


def test_the_density_makes_the_filters_covariance_independent_of_how_steps_are_cut(tmp_path):
    # Q_k = Q_c / dt_k: the pose covariance of a step grows as dt, so a log whose commands are
    # logged with gaps predicts (to first order) what the evenly logged one does
    Qc = identify.wheel_speed_covariance(np.sqrt(4e-4), np.sqrt(2e-3), 0.23)
    even = mrclam.load(synthetic_dataset(tmp_path / "e", 1.0, 1.0, 0.0, seconds=60.0), 1)
    gappy = mrclam.load(synthetic_dataset(tmp_path / "g", 1.0, 1.0, 0.0, seconds=60.0,
                                          gaps=True), 1)
    assert gappy.enc_t.size < 0.9 * even.enc_t.size
    P = {}
    for name, lg in (("even", even), ("gappy", gappy)):
        P[name] = mrclam.dead_reckoning(lg.with_noise(Q_density=Qc)).P[-1]
        # the heading's variance is q_w times the duration exactly, whatever the steps
        duration = lg.enc_t[-1] - lg.enc_t[0]
        assert P[name][2, 2] == pytest.approx(2e-3 * duration + 1e-6, rel=1e-9)
    # the position block: the same to first order (the Euler paths of 0.5 s steps and of
    # 0.01 s steps differ a little, and with them the Jacobians)
    assert np.linalg.norm(P["gappy"] - P["even"]) < 0.05 * np.linalg.norm(P["even"])
    # a constant per-step Q does not: the gaps' long steps get far more noise
    Qs = Qc / 0.01
    Ps = {n: mrclam.dead_reckoning(lg.with_noise(Q=Qs)).P[-1] for n, lg in
          (("even", even), ("gappy", gappy))}
    assert Ps["gappy"][2, 2] > 3.0 * Ps["even"][2, 2]


def test_the_density_predicts_the_spread_of_a_monte_carlo(tmp_path):
    # the heading error of dead reckoning over 60 s of white yaw-rate noise of density q_w:
    # variance q_w T exactly (the heading is linear in w), whatever the steps
    q_w, T = 2e-3, 60.0
    folder = synthetic_dataset(tmp_path / "m", 1.0, 1.0, 0.0, seconds=T + 1.0, gaps=True)
    log = mrclam.load(folder, 1).with_noise(Q_density=identify.wheel_speed_covariance(
        1e-9, np.sqrt(q_w), 0.23))
    P = mrclam.dead_reckoning(log).P
    np.testing.assert_allclose(P[-1, 2, 2] - P[0, 2, 2], q_w * (log.enc_t[-1] - log.enc_t[0]),
                               rtol=1e-9)
    rng = np.random.default_rng(7)
    dt = np.diff(log.enc_t)
    draws = rng.normal(0.0, 1.0, (2000, dt.size)) * np.sqrt(q_w / dt)   # Q_c / dt per step
    assert np.var(draws @ dt) == pytest.approx(P[-1, 2, 2], rel=0.1)


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
    plain = identify.fit_reading_noise(res, k=None)         # no outlier model: all count
    assert not plain.outlier.any() and plain.k is None
    assert plain.sigma_bearing > 5 * fit.sigma_bearing


def test_reading_residuals_are_zero_for_perfect_readings(tmp_path):
    folder = make_dataset(tmp_path / "p")
    log = mrclam.load(folder, 1)
    lm = log.world().landmarks()
    pose = log.truth_at(log.camera.t_capture)
    z = np.array([observe(p, lm[i]) for p, i in zip(pose, log.camera.id)])
    res = identify.reading_residuals(log.with_readings(z[:, 0], z[:, 1]))
    np.testing.assert_allclose(res.e_rho, 0.0, atol=1e-5)
    np.testing.assert_allclose(res.e_bearing, 0.0, atol=1e-5)


def test_identify_keeps_only_the_components_asked_and_checks_them(tmp_path):
    log = mrclam.load(synthetic_dataset(tmp_path / "k", q_v=1e-4, q_w=1e-3), 1)
    cal = identify.identify([log], ("Q", "delay"))
    assert cal.components == ("Q", "delay")
    assert cal.command_scale is None and cal.reading is None
    assert cal.command_delay == pytest.approx(0.2)
    textbook = identify.identify([log], ())
    assert textbook.noise(0.23) == {} and "textbook" in textbook.describe()
    with pytest.raises(ValueError, match="components: expected names"):
        identify.identify([log], ("Q", "bias"))
    with pytest.raises(ValueError, match="'outliers' is part of R"):
        identify.identify([log], ("outliers",))
    with pytest.raises(ValueError, match="logs: expected at least one"):
        identify.identify([])
    assert identify.Calibration.from_dict(cal.to_dict()) == cal


# --------------------------------------------------------------------------- the round trip
@pytest.fixture(scope="module")
def excerpt_halves():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrclam.MRCLAMWarning)     # robot 4's misreads
        whole = {r: mrclam.load(mrclam.EXCERPT_DIR, r) for r in mrclam.ROBOTS}
    half = {r: (lg.enc_t[-1] - lg.enc_t[0]) / 2 for r, lg in whole.items()}
    first = {r: whole[r].between(whole[r].enc_t[0], whole[r].enc_t[0] + half[r])
             for r in mrclam.ROBOTS}
    return whole, first, half


def test_the_api_round_trip_on_the_excerpts_first_half(excerpt_halves):
    whole, first, half = excerpt_halves
    cal = identify.identify(first.values())
    assert set(cal.components) == set(identify.KEPT)
    # the second half, never seen by the identification, loaded with the calibration
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrclam.MRCLAMWarning)
        log = mrclam.load(mrclam.EXCERPT_DIR, 2, start=half[2], calibration=cal)
    assert log.enc_t[0] >= whole[2].enc_t[0] + half[2]
    # what the calibration says is what the filter gets
    b = log.wheel_base
    if cal.q_density is not None:
        dt = np.diff(log.enc_t)
        np.testing.assert_allclose(log.Q_steps(dt), cal.noise(b)["Q_density"] / dt[:, None, None])
    if cal.reading is not None:
        r = cal.reading
        s = r["sigma_range0"] + 3.0 * r["sigma_range_per_m"]
        np.testing.assert_allclose(log.sensor().R(3.0), np.diag([s ** 2, r["sigma_bearing"] ** 2]))
    scale = (1.0, 1.0) if cal.command_scale is None else cal.command_scale
    assert log.meta["commands"]["scale"] == list(scale)
    tr = mrclam.slam(log)
    m = tr.metrics()
    assert np.all(np.isfinite(tr.x)) and np.all(np.isfinite(tr.P))
    assert m["landmarks"] >= 3 and m["ate_xy"] < 2.0
    # the public API without a calibration still works (textbook noise)
    assert mrclam.slam(whole[2].between(log.enc_t[0])).metrics()["ate_xy"] > 0.0


def test_load_rejects_a_calibration_with_its_own_arguments(excerpt_halves):
    _, first, _ = excerpt_halves
    cal = identify.identify([first[1]], ("R",))
    with pytest.raises(ValueError, match="calibration: expected alone"):
        mrclam.load(mrclam.EXCERPT_DIR, 1, calibration=cal, command_delay=0.1)
    with pytest.raises(ValueError, match="calibration: expected an identify.Calibration"):
        mrclam.load(mrclam.EXCERPT_DIR, 1, calibration={"R": 1})
