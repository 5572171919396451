"""The factor-graph smoother (slamlib.graph, chapter 11) against independent computations."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from slamlib import graph, runner
from slamlib.ekf import EKFLocalization
from slamlib.metrics import pose_error
from slamlib.models import (
    compose_poses,
    invert_pose,
    motion_model,
    motion_model_batch,
    observe,
    wrap_angle,
)
from slamlib.runs import CameraRows, Run, load_run
from slamlib.sim import scenario

finite = st.floats(-5.0, 5.0, allow_nan=False)
angle = st.floats(-np.pi, np.pi, allow_nan=False, exclude_max=True)


def random_cov(seed: int, n: int, scale: float = 1e-2) -> np.ndarray:
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n)) * scale
    return A @ A.T + scale**2 * 0.1 * np.eye(n)


# --------------------------------------------------------------------------- frames
@given(finite, finite, angle, st.integers(0, 10_000))
def test_pose_and_covariance_round_trip(x, y, th, seed):
    p = np.array([x, y, th])
    P = random_cov(seed, 3)
    g = graph.pose_to_gtsam(p)
    assert g.y() == -y and wrap_angle(g.theta() + th) == pytest.approx(0.0, abs=1e-12)
    back = graph.pose_from_gtsam(g)
    np.testing.assert_allclose(pose_error(back, p), 0.0, atol=1e-12)
    np.testing.assert_allclose(graph.pose_cov_from_gtsam(p, graph.pose_cov_to_gtsam(p, P)), P,
                               rtol=1e-10, atol=1e-15)
    L = random_cov(seed + 1, 2)
    q = np.array([x, y])
    np.testing.assert_array_equal(graph.point_from_gtsam(graph.point_to_gtsam(q)), q)
    np.testing.assert_allclose(graph.point_cov_from_gtsam(graph.point_cov_to_gtsam(L)), L)


def test_pose_covariance_matches_samples_of_gtsam_retract():
    # Independent of the formula: perturb a Pose2 in GTSAM's own chart (retract), mirror each
    # sample into z-down, and measure the additive covariance the course uses.
    rng = np.random.default_rng(0)
    for th in (0.3, 2.5, -1.9):
        p = np.array([1.2, -0.7, th])
        Sigma = random_cov(int(10 * th) + 50, 3, scale=3e-3)
        g = graph.pose_to_gtsam(p)
        xi = rng.multivariate_normal(np.zeros(3), Sigma, size=20_000)
        samples = np.array([graph.pose_from_gtsam(g.retract(v)) for v in xi])
        emp = np.cov(pose_error(samples, np.tile(p, (len(samples), 1))).T)
        np.testing.assert_allclose(graph.pose_cov_from_gtsam(p, Sigma), emp,
                                   atol=0.05 * np.max(np.abs(emp)))


@given(finite, finite, angle, st.floats(-4, 4), st.floats(-4, 4))
def test_reading_in_gtsam_frame_is_gtsam_bearing_and_range(x, y, th, dx, dy):
    pose, lm = np.array([x, y, th]), np.array([x + dx, y + dy])
    if np.hypot(dx, dy) < 0.1:
        return
    z = observe(pose, lm)
    bearing, rng, _ = graph.reading_to_gtsam(z, np.diag([0.01, 0.001]))
    g, q = graph.pose_to_gtsam(pose), graph.point_to_gtsam(lm)
    assert rng == pytest.approx(g.range(q), abs=1e-9)
    assert wrap_angle(bearing.theta() - g.bearing(q).theta()) == pytest.approx(0.0, abs=1e-9)


def test_reading_covariance_is_reordered_and_mirrored():
    R = np.array([[4e-4, 1e-5], [1e-5, 3e-4]])
    _, _, C = graph.reading_to_gtsam([2.0, 0.1], R)
    # GTSAM's error is [bearing_zup, range] = [-beta, rho]
    np.testing.assert_allclose(C, [[3e-4, -1e-5], [-1e-5, 4e-4]])


# --------------------------------------------------------------------------- odometry
def test_odometry_is_the_motion_model_seen_from_the_first_pose_and_its_ekf_covariance():
    rng = np.random.default_rng(3)
    u = rng.uniform(0.05, 0.3, size=(12, 2))
    dt = np.full(12, 0.02)
    Q = np.diag([2e-4, 3e-4])
    x0 = np.array([2.0, -1.0, 2.2])
    od = graph.integrate_odometry(u, dt, Q, 0.23)
    x = x0.copy()
    for k in range(12):
        x = motion_model(x, u[k], dt[k], 0.23)
    np.testing.assert_allclose(pose_error(compose_poses(x0, od.delta), x), 0.0, atol=1e-12)
    np.testing.assert_allclose(pose_error(od.delta, compose_poses(invert_pose(x0), x)), 0.0,
                               atol=1e-12)
    # the EKF's prediction from x0 with no initial uncertainty gives the same covariance,
    # rotated into N
    f = EKFLocalization(x0, 1e-30 * np.eye(3), Q, np.eye(2), {}, wheel_base=0.23)
    for k in range(12):
        f.predict(u[k], dt[k])
    B = np.array([[np.cos(x0[2]), -np.sin(x0[2]), 0], [np.sin(x0[2]), np.cos(x0[2]), 0],
                  [0, 0, 1]])
    np.testing.assert_allclose(B @ od.cov @ B.T, f.pose_cov, rtol=1e-9, atol=1e-18)


def test_odometry_covariance_against_monte_carlo():
    rng = np.random.default_rng(4)
    u = np.tile([0.25, 0.15], (25, 1))
    dt = np.full(25, 0.02)
    Q = np.diag([0.02, 0.02]) ** 2
    od = graph.integrate_odometry(u, dt, Q, 0.23)
    ends = np.zeros((20_000, 3))
    for k in range(25):
        noise = rng.multivariate_normal(np.zeros(2), Q, size=ends.shape[0])
        ends = motion_model_batch(ends, u[k] + noise, dt[k], 0.23)
    emp = np.cov(pose_error(ends, np.tile(od.delta, (ends.shape[0], 1))).T)
    np.testing.assert_allclose(od.cov, emp, atol=0.05 * np.max(np.abs(emp)))


# --------------------------------------------------------------------------- whole runs
#: The reading covariance the estimators assume for the exact run (it records no sensor model,
#: so the runners need one: 5 cm in range, 2 deg in bearing).
EXACT_R = np.diag([0.05 ** 2, np.radians(2.0) ** 2])


def exact_run() -> Run:
    """A run whose odometry and readings are exact: truth from the motion model itself,
    encoders so fine that the tick quantisation is below the stored precision, readings
    from the observation model."""
    n, rate = 601, 50.0
    t = np.arange(n) / rate
    speeds = np.column_stack([0.25 + 0.05 * np.sin(t / 3), 0.2 + 0.05 * np.cos(t / 2)])
    tpr, r_w = 2.0**40, 0.035
    ticks = np.zeros((n, 2))
    ticks[1:] = np.cumsum(speeds[1:] / rate / (2 * np.pi * r_w) * tpr, axis=0)
    ticks = np.round(ticks).astype(np.int64)
    meta = {"world": "report_arena",
            "encoder": {"rate": rate, "ticks_per_rev": tpr, "bits": 62, "wheel_radius": r_w,
                        "wheel_base": 0.23},
            "motion": {"sigma_wheel": 0.0}}
    empty = CameraRows(*[np.zeros(0)] * 8)
    start = np.array([0.5, -0.4, 0.3])
    run = Run("exact", t, np.tile(start, (n, 1)), t, ticks[:, 0], ticks[:, 1], empty, meta)
    u, dt = run.controls()
    truth = [start]
    for k in range(n - 1):
        truth.append(motion_model(truth[-1], u[k], dt[k], 0.23))
    truth = np.array(truth)
    lms = {i: np.array([1.5 + 2.5 * np.cos(a), 1.0 + 2.5 * np.sin(a)])
           for i, a in enumerate(np.linspace(0, 2 * np.pi, 9, endpoint=False))}
    rows = {k: [] for k in ("t_capture", "t_arrival", "id", "rho", "bearing", "true_id",
                            "true_rho", "true_bearing")}
    for k in range(5, n, 5):
        for i, m in lms.items():
            z = observe(truth[k], m)
            if z[0] < 3.5 and abs(z[1]) < 0.7:
                for key, v in zip(rows, (t[k], t[k], i, z[0], z[1], i, z[0], z[1])):
                    rows[key].append(v)
    return dataclasses.replace(run, truth=truth, camera=CameraRows(**rows))


@pytest.fixture(scope="module")
def arena():
    return load_run("arena_loop")


@pytest.mark.parametrize("method", graph.METHODS)
def test_no_noise_the_smoother_returns_the_truth(method):
    run = exact_run()
    tr = graph.smooth(run, method, Q=1e-4 * np.eye(2), R=EXACT_R)
    assert len(tr.landmark_ids) >= 6 and len(tr.t) > 100
    e = tr.error
    assert np.max(np.abs(e[:, :2])) < 5e-5 and np.max(np.abs(e[:, 2])) < 5e-5
    true_lm = {i: np.array([1.5 + 2.5 * np.cos(a), 1.0 + 2.5 * np.sin(a)])
               for i, a in enumerate(np.linspace(0, 2 * np.pi, 9, endpoint=False))}
    for i, p in tr.landmarks.items():
        np.testing.assert_allclose(p, true_lm[i], atol=5e-5)


def test_a_wrong_bearing_sign_would_not_return_the_truth():
    # the same exact run with every bearing negated: readings and odometry now disagree,
    # so the check above can fail
    run = exact_run()
    cam = dataclasses.replace(run.camera, bearing=-run.camera.bearing)
    tr = graph.smooth(dataclasses.replace(run, camera=cam), "batch", Q=1e-4 * np.eye(2),
                      R=EXACT_R)
    assert np.max(np.hypot(*tr.error[:, :2].T)) > 0.05


def test_tiny_noise_last_pose_covariance_equals_the_ekf():
    # Almost no noise in the run, moderate Q and R in the estimators: both linearise at
    # (nearly) the truth, so the EKF's final covariance (filtered) and the smoother's
    # marginal of the last pose hold the same information.
    run = scenario("arena_loop", seed=7, sigma_wheel=1e-4, sigma_range0=1e-4,
                   sigma_range_per_m=0.0, sigma_bearing=1e-5)
    Q, R = np.diag([0.01, 0.01]) ** 2, np.diag([0.05, np.radians(2.0)]) ** 2
    ekf = runner.slam(run, Q=Q, R=R, gate=None)
    g = graph.smooth(run, "batch", Q=Q, R=R)
    assert g.t[-1] == ekf.t[-1]
    P_e, P_g = ekf.P[-1], g.P[-1]
    assert np.linalg.norm(P_g - P_e) < 0.02 * np.linalg.norm(P_e)
    for i in ekf.filter.landmark_ids:
        C_e = ekf.filter.landmark_cov(i)
        assert np.linalg.norm(g.landmark_cov(i) - C_e) < 0.02 * np.linalg.norm(C_e)
    # and the smoothed earlier poses are more certain than the filter was then
    k = np.searchsorted(ekf.t, g.t[len(g.t) // 2])
    assert np.trace(g.P[len(g.t) // 2]) < np.trace(ekf.P[k])


def test_no_readings_equals_dead_reckoning(arena):
    blind = dataclasses.replace(arena, camera=CameraRows(*[np.zeros(0)] * 8))
    g = graph.smooth(blind, "batch", max_steps=100, odometry_floor=0.0)
    dr = runner.dead_reckoning(arena)
    assert len(g.t) == 31 and not g.landmark_ids
    k = np.searchsorted(dr.t, g.t)
    np.testing.assert_array_equal(dr.t[k], g.t)
    np.testing.assert_allclose(pose_error(g.x, dr.x[k]), 0.0, atol=1e-9)
    np.testing.assert_allclose(g.P, dr.P[k], rtol=1e-6, atol=1e-12)
    gi = graph.smooth(blind, "isam2", max_steps=100, odometry_floor=0.0)
    np.testing.assert_allclose(pose_error(gi.online_x, dr.x[k]), 0.0, atol=1e-9)


def test_batch_and_isam2_agree_at_the_end(arena):
    b = graph.smooth(arena, "batch")
    i = graph.smooth(arena, "isam2")
    np.testing.assert_array_equal(b.t, i.t)
    # iSAM2 re-linearises a variable only when its update exceeds 0.01: millimetres apart
    assert np.max(np.hypot(*(b.x - i.x)[:, :2].T)) < 3e-3
    assert np.max(np.abs(wrap_angle(b.x[:, 2] - i.x[:, 2]))) < 3e-3
    assert np.linalg.norm(i.P[-1] - b.P[-1]) < 0.02 * np.linalg.norm(b.P[-1])
    assert b.landmark_ids == i.landmark_ids
    np.testing.assert_allclose(i.landmark_x, b.landmark_x, atol=3e-3)
    # the online estimate of the last pose is the smoothed one (nothing came after it)
    np.testing.assert_allclose(i.online_x[-1], i.x[-1], atol=1e-3)
    assert i.step_reeliminated.shape == (len(i.t),) and np.all(i.step_reeliminated > 0)


def test_information_matrix_is_the_sparse_graph(arena):
    g = graph.smooth(arena, "batch", max_time=5.0)
    Lam, labels = graph.information_matrix(g)
    n = g.problem.n_poses
    assert Lam.shape == (3 * n + 2 * len(g.landmark_ids),) * 2 and len(labels) == n + len(
        g.landmark_ids)
    # poses two nodes apart share no factor: their block is exactly zero
    assert np.all(Lam[0:3, 6:9] == 0.0) and np.any(Lam[0:3, 3:6] != 0.0)
    # its inverse holds the marginal covariances GTSAM reported (z-up, body frame)
    C = np.linalg.inv(Lam)
    last = 3 * (n - 1)
    Sigma = graph.pose_cov_to_gtsam(g.x[-1], g.P[-1])
    np.testing.assert_allclose(C[last:last + 3, last:last + 3], Sigma, rtol=1e-6, atol=1e-14)


def test_bad_arguments(arena):
    with pytest.raises(ValueError, match="method"):
        graph.smooth(arena, "gauss")
    with pytest.raises(ValueError, match="robust"):
        graph.smooth(arena, "batch", robust="tukeyy")
    with pytest.raises(ValueError, match="max_steps"):
        graph.smooth(arena, "batch", max_steps=0)
    with pytest.raises(ValueError, match="marker_id"):
        graph.landmark_key(-1)


def test_a_robust_kernel_ignores_gross_outliers():
    # two readings of the exact run off by 1.0 and -0.8 m (20 and 16 sigma): least squares
    # bends the trajectory towards them, a Cauchy kernel all but ignores them
    run = exact_run()
    rho = run.camera.rho.copy()
    rho[40] += 1.0
    rho[150] -= 0.8
    bad = dataclasses.replace(run, camera=dataclasses.replace(run.camera, rho=rho))
    plain = graph.smooth(bad, "batch", Q=1e-4 * np.eye(2), R=EXACT_R)
    robust = graph.smooth(bad, "batch", Q=1e-4 * np.eye(2), R=EXACT_R, robust="cauchy")
    e_plain = np.max(np.hypot(*plain.error[:, :2].T))
    e_robust = np.max(np.hypot(*robust.error[:, :2].T))
    assert e_plain > 1e-4 and e_robust < 5e-5 and e_robust < 0.1 * e_plain


# --------------------------------------------------------------------------- real logs (MRCLAM)
@pytest.fixture(scope="module")
def mrclam_log():
    from slamlib.datasets import mrclam

    return mrclam.load(mrclam.EXCERPT_DIR, 4, unknown_barcodes="drop", duration=100.0)


def test_qr_marginals_equal_cholesky_where_both_work(arena):
    g = graph.smooth(arena, "batch", max_time=20.0)
    chol = graph.batch_marginals(g.graph, g.values, "cholesky")
    qr = graph.batch_marginals(g.graph, g.values, "qr")
    for key in (graph.pose_key(0), graph.pose_key(g.problem.n_poses - 1),
                graph.landmark_key(g.landmark_ids[-1])):
        np.testing.assert_allclose(qr(key), chol(key), rtol=1e-6, atol=1e-14)
    with pytest.raises(ValueError, match="factorization"):
        graph.batch_marginals(g.graph, g.values, "lu")


def test_mrclam_log_frames_ms_apart_need_the_qr_marginals(mrclam_log):
    # robot 4's first 100 s: camera frames a few ms apart make almost rigid odometry
    # factors; Cholesky calls the system indeterminate, QR gives the marginals, and they
    # are the inverse of the information matrix (computed independently, dense)
    p = graph.build_problem(mrclam_log)
    assert min(od.steps for od in p.odometry) == 1
    b = graph.smooth(mrclam_log, "batch")
    with pytest.raises(RuntimeError):
        graph.batch_marginals(b.graph, b.values, "cholesky")(graph.pose_key(0))
    Lam, _ = graph.information_matrix(b)
    n = b.problem.n_poses
    C = np.linalg.inv(Lam)
    for i in (0, n // 2, n - 1):
        Sigma = graph.pose_cov_to_gtsam(b.x[i], b.P[i])
        np.testing.assert_allclose(C[3 * i:3 * i + 3, 3 * i:3 * i + 3], Sigma, rtol=1e-4,
                                   atol=1e-10)


@pytest.mark.parametrize("density", [False, True])
def test_mrclam_log_without_readings_is_its_dead_reckoning(mrclam_log, density):
    # the loader's irregular timeline (commands and reading times): the graph's chain of
    # odometry factors is the filter's prediction over the same steps, with the textbook's Q
    # per step or with a noise density (each step its own Q_c / dt, chapter 10)
    from slamlib.datasets import mrclam

    log = mrclam_log
    if density:
        log = log.with_noise(Q_density=[[2e-4, 1.5e-4], [1.5e-4, 2e-4]])
        assert log.Q_steps(np.diff(log.enc_t)) is not None
    blind = log.select_readings(np.zeros(len(log.camera), dtype=bool))
    g = graph.smooth(blind, "batch", max_steps=400)
    dr = mrclam.dead_reckoning(log)
    assert not g.landmark_ids and len(g.t) > 10
    k = np.searchsorted(dr.t, g.t)
    np.testing.assert_array_equal(dr.t[k], g.t)
    np.testing.assert_allclose(pose_error(g.x, dr.x[k]), 0.0, atol=1e-9)
    # each odometry factor carries the default floor of 1e-10 on its diagonal (propagated)
    np.testing.assert_allclose(g.P, dr.P[k], rtol=1e-6, atol=5e-8)
    assert np.max(np.abs(g.P[-1])) > 1e-3
