"""The compiled kernels (slamlib.kernels) against independent numpy computations, and the
runners' predictions in blocks against one prediction at a time, bit for bit (issue 9, point 1)."""

from __future__ import annotations

import numpy as np
import pytest

from slamlib import kernels, runner, sim
from slamlib.ekf import EKFSLAM, EKFLocalization
from slamlib.models import _motion_step, _wrap_scalar, motion_jacobians, motion_model

Q = np.diag([0.02 ** 2, 0.03 ** 2])


def _slam_with_landmarks(seed: int, n_landmarks: int = 6) -> EKFSLAM:
    rng = np.random.default_rng(seed)
    f = EKFSLAM(rng.normal(0, 1, 3), np.diag([1e-3, 2e-3, 1e-3]), Q, np.diag([0.01, 1e-4]))
    z = np.column_stack([rng.uniform(0.5, 3.0, n_landmarks), rng.uniform(-1, 1, n_landmarks)])
    f.update(np.arange(n_landmarks), z)
    for _ in range(5):                         # some correlation between the landmarks
        f.predict(rng.normal(0.2, 0.1, 2), 0.02)
        f.update(np.arange(n_landmarks), z + rng.normal(0, 0.01, z.shape))
    return f


def test_wrap_and_motion_terms_are_the_python_formulas_bit_for_bit():
    rng = np.random.default_rng(1)
    for a in np.concatenate([rng.normal(0, 10, 2000), np.arange(-9, 10) * np.pi]):
        assert kernels.wrap(float(a)) == _wrap_scalar(float(a))
    for _ in range(500):
        th, vr, vl, dt = rng.normal(0, 3), rng.normal(0.2, 0.2), rng.normal(0.2, 0.2), 0.02
        dx, dy, dth, hc, hs, g = kernels.motion_terms(th, vr, vl, dt, 0.23)
        v, w = 0.5 * (vr + vl), (vl - vr) / 0.23
        assert (dx, dy, dth) == (v * np.cos(th) * dt, v * np.sin(th) * dt, w * dt)
        assert (hc, hs, g) == (0.5 * np.cos(th) * dt, 0.5 * np.sin(th) * dt, dt / 0.23)


def test_predict_pose_is_A_P_AT_plus_W_Q_WT():
    rng = np.random.default_rng(2)
    for _ in range(100):
        x = rng.normal(0, 2, 3)
        M = rng.normal(size=(3, 3))
        P = M @ M.T + np.eye(3)
        u, dt = rng.normal(0.2, 0.2, 2), 0.05
        new, A, W = _motion_step(x, u, dt, 0.23)
        ref = A @ P @ A.T + W @ Q @ W.T
        xk, Pk = x.copy(), P.copy()
        a, b = kernels.predict_pose(xk, Pk, Q, u[0], u[1], dt, 0.23)
        assert np.array_equal(xk, motion_model(x, u, dt, 0.23))
        assert (a, b) == (A[0, 2], A[1, 2])
        np.testing.assert_allclose(Pk, ref, rtol=1e-13, atol=1e-15)
        assert np.array_equal(Pk, Pk.T)


@pytest.mark.parametrize("pending", [False, True])
def test_predict_block_equals_one_prediction_at_a_time(pending):
    a, b = _slam_with_landmarks(3), _slam_with_landmarks(3)
    rng = np.random.default_rng(4)
    if pending:                               # a shear already pending before the block
        u0 = rng.normal(0.2, 0.1, 2)
        a.predict(u0, 0.02)
        b.predict(u0, 0.02)
    u, dt = rng.normal(0.2, 0.1, (37, 2)), rng.uniform(0.01, 0.03, 37)
    poses, covs = a._predict_block(u, dt)
    for k in range(37):
        b.predict(u[k], float(dt[k]))
        assert np.array_equal(poses[k], b.pose) and np.array_equal(covs[k], b.pose_cov)
    assert a._shear == b._shear
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)


def test_predict_block_with_a_q_per_step_equals_one_prediction_at_a_time():
    # a noise density gives each step its own Q (Q_c / dt_k, chapter 10)
    a, b = _slam_with_landmarks(3), _slam_with_landmarks(3)
    rng = np.random.default_rng(5)
    u, dt = rng.normal(0.2, 0.1, (29, 2)), rng.uniform(0.001, 0.5, 29)
    Qc = np.array([[2e-4, 1e-4], [1e-4, 3e-4]])
    Qs = Qc[None] / dt[:, None, None]
    poses, covs = a._predict_block(u, dt, Qs)
    for k in range(29):
        P = b.pose_cov
        A, W = motion_jacobians(b.pose, u[k], float(dt[k]), b.wheel_base)
        b.predict(u[k], float(dt[k]), Qs[k])
        assert np.array_equal(poses[k], b.pose) and np.array_equal(covs[k], b.pose_cov)
        # the textbook formula with this step's Q, A and W
        np.testing.assert_allclose(b.pose_cov, A @ P @ A.T + W @ Qs[k] @ W.T, rtol=1e-12,
                                   atol=1e-15)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)
    with pytest.raises(ValueError, match="Q: expected a symmetric"):
        b.predict(u[0], 0.1, [[1.0, 0.5], [0.0, 1.0]])


def test_observe_into_against_the_formulas_and_a_landmark_on_the_robot():
    pose = np.array([1.0, -0.5, 0.7])
    L = np.array([[2.0, 1.0], [1.0, -0.5], [-1.0, 0.3]])
    h, Hp, Hl = np.empty((3, 2)), np.empty((3, 2, 3)), np.empty((3, 2, 2))
    kernels.observe_into(pose, L, h, Hp, Hl)
    for i in (0, 2):
        dx, dy = L[i] - pose[:2]
        q = dx * dx + dy * dy
        r = np.sqrt(q)
        bearing = (np.arctan2(dy, dx) - pose[2] + np.pi) % (2 * np.pi) - np.pi
        np.testing.assert_allclose(h[i], [r, bearing], rtol=1e-15, atol=1e-15)
        np.testing.assert_allclose(Hl[i], [[dx / r, dy / r], [-dy / q, dx / q]], rtol=1e-15)
        np.testing.assert_allclose(Hp[i], [[-dx / r, -dy / r, 0], [dy / q, -dx / q, -1]],
                                   rtol=1e-15)
    assert np.isnan(h[1]).all() and np.isnan(Hl[1]).all() and np.isnan(Hp[1, :, :2]).all()
    assert Hp[1, 0, 2] == 0.0 and Hp[1, 1, 2] == -1.0


def _full_H(n, slots, Hp, Hl):
    H = np.zeros((2 * len(slots), n))
    for j, s in enumerate(slots):
        H[2 * j:2 * j + 2, :3] = Hp[j]
        if s >= 0:
            H[2 * j:2 * j + 2, s:s + 2] += Hl[j]
    return H


def test_innovation_covs_and_distances_against_full_matrices():
    f = _slam_with_landmarks(5)
    rng = np.random.default_rng(6)
    P, n = f.P, f.state_size
    slots = np.array([3, 7, 11, 7], dtype=np.int64)
    Hp, Hl = rng.normal(size=(4, 2, 3)), rng.normal(size=(4, 2, 2))
    R = np.stack([np.diag(rng.uniform(1e-4, 1e-2, 2)) for _ in range(4)])
    S = np.empty((4, 2, 2))
    kernels.innovation_covs(f._P, slots, Hp, Hl, R, S)
    H = _full_H(n, slots, Hp, Hl)
    for j in range(4):
        Hj = H[2 * j:2 * j + 2]
        np.testing.assert_allclose(S[j], Hj @ P @ Hj.T + R[j], rtol=1e-12, atol=1e-16)
        assert S[j, 0, 1] == S[j, 1, 0]
    z, h = rng.normal(size=(4, 2)), rng.normal(size=(4, 2))
    y, d2 = np.empty((4, 2)), np.empty(4)
    kernels.innovation_distances(z, h, S, y, d2)
    for j in range(4):
        yj = z[j] - h[j]
        yj[1] = (yj[1] + np.pi) % (2 * np.pi) - np.pi
        np.testing.assert_allclose(y[j], yj, rtol=0, atol=1e-15)
        np.testing.assert_allclose(d2[j], yj @ np.linalg.solve(S[j], yj), rtol=1e-12)


@pytest.mark.parametrize("subtract", [True, False])
def test_fuse_is_the_textbook_joint_update(subtract):
    """K = P H^T S^-1, x + K y, P - K S K^T with full matrices; a landmark read twice."""
    f = _slam_with_landmarks(7)
    rng = np.random.default_rng(8)
    x, P, n = f.x, f.P, f.state_size
    slots = np.array([5, 9, 5], dtype=np.int64)
    Hp, Hl = rng.normal(size=(3, 2, 3)), rng.normal(size=(3, 2, 2))
    R = np.stack([np.diag(rng.uniform(1e-3, 1e-2, 2)) for _ in range(3)])
    y = rng.normal(0, 0.05, (3, 2))
    H = _full_H(n, slots, Hp, Hl)
    Rb = np.zeros((6, 6))
    for j in range(3):
        Rb[2 * j:2 * j + 2, 2 * j:2 * j + 2] = R[j]
    S = H @ P @ H.T + Rb
    K = P @ H.T @ np.linalg.inv(S)
    xk, Pk = f._x.copy(), f._P.copy()
    ok, nis, W = kernels.fuse(xk, Pk, n, slots, Hp, Hl, y, R, subtract)
    assert ok
    np.testing.assert_allclose(xk[:n], x + K @ y.reshape(-1), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(nis, y.reshape(-1) @ np.linalg.solve(S, y.reshape(-1)), rtol=1e-11)
    if subtract:
        np.testing.assert_allclose(Pk[:n, :n], P - K @ S @ K.T, rtol=1e-10, atol=1e-15)
        assert np.array_equal(Pk[:n, :n], Pk[:n, :n].T)
    else:
        assert np.array_equal(Pk, f._P)
        np.testing.assert_allclose(W.T @ W, K @ S @ K.T, rtol=1e-10, atol=1e-15)


def test_fuse_refuses_a_non_positive_definite_S_and_changes_nothing():
    f = EKFLocalization([0, 0, 0], np.eye(3) * 1e-4, Q, np.eye(2) * 1e-3, landmarks={1: [2, 0]})
    x, P = f._x.copy(), f._P.copy()
    Hp = np.zeros((1, 2, 3))
    R = np.array([[[-1.0, 0.0], [0.0, 1e-3]]])              # S = R, not positive definite
    ok, nis, _ = kernels.fuse(f._x, f._P, 3, np.array([-1]), Hp, np.zeros((1, 2, 2)),
                              np.array([[0.1, 0.0]]), R, True)
    assert not ok and np.isnan(nis)
    assert np.array_equal(f._x, x) and np.array_equal(f._P, P)
    with pytest.raises(np.linalg.LinAlgError, match="positive definite"):
        f._fuse(np.array([-1]), Hp, np.zeros((1, 2, 2)), np.array([[0.1, 0.0]]), R)
    assert np.array_equal(f._x, x) and np.array_equal(f._P, P)


class _OneByOne(EKFSLAM):
    """EKFSLAM whose public predict is its own: the runner then predicts step by step."""

    def predict(self, u, dt):
        super().predict(u, dt)


@pytest.mark.parametrize("max_time", [None, 23.456])
def test_run_filter_in_blocks_equals_one_event_at_a_time(max_time):
    run = sim.scenario("arena_loop", seed=11)
    a = runner.run_filter(run, runner.make_filter(EKFSLAM, run), max_time=max_time)
    b = runner.run_filter(run, runner.make_filter(_OneByOne, run), max_time=max_time)
    assert np.array_equal(a.t, b.t) and np.array_equal(a.kind, b.kind)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)
    assert np.array_equal(a.filter.x, b.filter.x) and np.array_equal(a.filter.P, b.filter.P)
    if max_time is not None:
        assert a.t[-1] <= max_time < run.enc_t[-1]


class _PythonLoopController(sim.WaypointController):
    """The waypoint controller under another type: KobukiSim.drive then runs its Python loop."""


@pytest.mark.parametrize("faults", [{}, {"p_misread": 0.1, "p_outlier": 0.3}])
def test_compiled_drive_equals_the_python_loop_bit_for_bit(faults):
    from slamlib.sensors import AnalyticMarkerSensor
    from slamlib.worlds import load_world

    world = load_world("report_arena")
    ctl = sim.WaypointController(sim.arena_loop_waypoints())
    slow = _PythonLoopController(sim.arena_loop_waypoints())
    a = sim.simulate(world, ctl, sensor=AnalyticMarkerSensor(**faults), seed=21)
    b = sim.simulate(world, slow, sensor=AnalyticMarkerSensor(**faults), seed=21)
    for name in ("truth_t", "truth", "enc_t", "ticks_R", "ticks_L"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    for name in ("t_capture", "t_arrival", "id", "rho", "bearing", "true_id"):
        assert np.array_equal(getattr(a.camera, name), getattr(b.camera, name)), name
    assert a.meta["finished"] and b.meta["finished"]
    # no camera at all: the same motion
    c = sim.simulate(world, ctl, seed=21)
    assert np.array_equal(c.truth, a.truth) and len(c.camera) == 0


def test_a_step_with_a_non_finite_wheel_speed_is_refused():
    from slamlib.worlds import load_world

    s = sim.KobukiSim(load_world("report_arena"), seed=1)
    with pytest.raises(ValueError, match="wheel speeds"):
        s.step(0.1, float("nan"))
    assert s.k == 0 and not s._slip          # nothing drawn, nothing moved


def test_solve_lower_is_the_inverse_of_a_lower_triangular_matrix():
    rng = np.random.default_rng(9)
    for m, k in [(1, 1), (2, 2), (6, 3), (12, 40)]:
        L = np.tril(rng.normal(size=(m, m))) + m * np.eye(m)
        B = rng.normal(size=(m, k))
        X = B.copy()
        kernels.solve_lower(L, X)
        np.testing.assert_allclose(L @ X, B, rtol=1e-12, atol=1e-12)
