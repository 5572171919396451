"""The textbook equations (slamlib.ekf_textbook) against the fast and the dense filters.

The fast filters of slamlib.ekf use the structure of the problem (blocks,
low-rank corrections, preallocated storage); slamlib.ekf_dense uses full
matrices; slamlib.ekf_textbook writes the equations one per line. Three
implementations of one filter: over random states and many steps they must
agree to round-off (1e-12 on covariances of order 1e-2..1).
"""

import math

import numpy as np
import pytest

from slamlib import ekf_textbook as tb
from slamlib import metrics
from slamlib.ekf import EKFSLAM, EKFLocalization, gate_threshold
from slamlib.ekf_dense import DenseEKFLocalization, DenseEKFSLAM
from slamlib.models import motion_jacobians, motion_model, observe, wrap_angle

Q = np.diag([0.02, 0.02]) ** 2
R = np.diag([0.05, math.radians(2.0)]) ** 2
TOL = 1e-12


def random_slam_state(rng, n_landmarks):
    """A random mean and a random, well-conditioned, fully correlated covariance."""
    n = 3 + 2 * n_landmarks
    x = np.concatenate([[rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-np.pi, np.pi)],
                        rng.uniform(-4, 4, 2 * n_landmarks)])
    M = rng.normal(0.0, 0.1, (n, n))
    return x, M @ M.T + 1e-3 * np.eye(n)


def filter_with_state(cls, x, P, **kwargs):
    """A filter of class ``cls`` whose state is (x, P), built through its public API only.

    The landmarks are added by readings from an exactly known pose (the first update
    of an empty map is pure augmentation), then the covariance is set through the
    private storage (the only way to start from an arbitrary correlated P).
    """
    f = cls(x[:3], np.eye(3), Q, R, **kwargs)
    ids = list(range(100, 100 + (x.size - 3) // 2))
    if ids:
        z = np.array([observe(x[:3], x[3 + 2 * j:5 + 2 * j]) for j in range(len(ids))])
        f.update(ids, z)
    n = x.size
    f._x[:n] = x
    f._P[:n, :n] = P
    return f, {mid: 3 + 2 * j for j, mid in enumerate(ids)}


# --------------------------------------------------------------------------- prediction
@pytest.mark.parametrize("n_landmarks", [0, 1, 6])
def test_block_prediction_equals_the_dense_product_and_the_fast_filter(n_landmarks):
    rng = np.random.default_rng(n_landmarks)
    for _ in range(20):
        x, P = random_slam_state(rng, n_landmarks)
        u, dt = rng.uniform(-0.4, 0.4, 2), float(rng.uniform(0.01, 0.3))
        x1, P1 = tb.predict(x, P, u, dt, Q)
        A, W = motion_jacobians(x[:3], u, dt)
        F = np.eye(x.size)
        F[:3, :3] = A
        Fw = np.zeros((x.size, 2))
        Fw[:3] = W
        np.testing.assert_allclose(P1, F @ P @ F.T + Fw @ Q @ Fw.T, rtol=0, atol=TOL)
        np.testing.assert_array_equal(x1[:3], motion_model(x[:3], u, dt))
        np.testing.assert_array_equal(x1[3:], x[3:])
        assert np.array_equal(P1, P1.T)
        fast, _ = filter_with_state(EKFSLAM, x, P)
        fast.predict(u, dt)
        np.testing.assert_allclose(fast.x, x1, rtol=0, atol=TOL)
        np.testing.assert_allclose(fast.P, P1, rtol=0, atol=TOL)


def test_prediction_does_not_change_its_inputs():
    rng = np.random.default_rng(3)
    x, P = random_slam_state(rng, 3)
    x0, P0 = x.copy(), P.copy()
    tb.predict(x, P, [0.2, 0.3], 0.1, Q)
    tb.joint_update(x, P, np.array([[1.0, 0.2]]), np.array([[1.1, 0.1]]),
                    tb.stacked_jacobian(x.size, [3], np.ones((1, 2, 3)), np.ones((1, 2, 2))), R)
    tb.augment(x, P, np.array([1.0, 0.3]), R)
    np.testing.assert_array_equal(x, x0)
    np.testing.assert_array_equal(P, P0)


# --------------------------------------------------------------------------- the pieces
def test_innovation_wraps_each_bearing_and_stacks():
    z = np.array([[2.0, np.pi - 0.05], [1.0, 0.3]])
    h = np.array([[1.9, -np.pi + 0.05], [1.2, 0.1]])
    np.testing.assert_allclose(tb.innovation(z, h), [0.1, -0.1, -0.2, 0.2], atol=1e-12)


def test_stacked_jacobian_places_each_block():
    Hp = np.arange(1.0, 13.0).reshape(2, 2, 3)
    Hl = -np.arange(1.0, 9.0).reshape(2, 2, 2)
    H = tb.stacked_jacobian(9, [5, 3], Hp, Hl)
    assert H.shape == (4, 9)
    np.testing.assert_array_equal(H[:2, :3], Hp[0])
    np.testing.assert_array_equal(H[:2, 5:7], Hl[0])
    np.testing.assert_array_equal(H[2:, 3:5], Hl[1])
    assert np.count_nonzero(H) == 2 * (6 + 4)
    H0 = tb.stacked_jacobian(3, [-1], Hp[:1], Hl[:1])       # known map: pose columns only
    np.testing.assert_array_equal(H0, Hp[0])


def test_joint_update_equals_the_information_form():
    # an independent closed form: P+ = (P^-1 + H^T R^-1 H)^-1, x+ = x + P+ H^T R^-1 y
    rng = np.random.default_rng(4)
    for _ in range(20):
        x, P = random_slam_state(rng, 4)
        m = 3
        H = rng.normal(0.0, 1.0, (2 * m, x.size))
        Rb = tb.block_diagonal([R * (1 + j) for j in range(m)])
        z = rng.normal(0.0, 1.0, (m, 2))
        h = z - rng.normal(0.0, 0.1, (m, 2))
        x1, P1 = tb.joint_update(x, P, z, h, H, Rb)
        Pi = np.linalg.inv(np.linalg.inv(P) + H.T @ np.linalg.inv(Rb) @ H)
        xi = x + Pi @ H.T @ np.linalg.inv(Rb) @ tb.innovation(z, h)
        xi[2] = wrap_angle(xi[2])
        np.testing.assert_allclose(P1, Pi, rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(x1, xi, rtol=1e-8, atol=1e-10)
        assert np.array_equal(P1, P1.T)


def test_augmentation_equals_the_stacked_jacobian_form():
    rng = np.random.default_rng(5)
    for n_lm in (0, 2, 5):
        x, P = random_slam_state(rng, n_lm)
        z = np.array([rng.uniform(0.3, 4.0), rng.uniform(-1.0, 1.0)])
        x1, P1 = tb.augment(x, P, z, R)
        from slamlib.models import inverse_observation_jacobians, inverse_observe

        J1, J2 = inverse_observation_jacobians(x[:3], z)
        Gx = np.vstack([np.eye(x.size), np.hstack([J1, np.zeros((2, x.size - 3))])])
        Gz = np.vstack([np.zeros((x.size, 2)), J2])
        np.testing.assert_allclose(P1, Gx @ P @ Gx.T + Gz @ R @ Gz.T, rtol=0, atol=TOL)
        np.testing.assert_array_equal(x1[-2:], inverse_observe(x[:3], z))
        np.testing.assert_array_equal(P1[:x.size, :x.size], P)


def test_nees_wraps_the_heading_and_is_chi_square_on_average():
    rng = np.random.default_rng(6)
    T = 20000
    L = np.linalg.cholesky(np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.02], [0.0, 0.02, 0.05]]))
    P = np.broadcast_to(L @ L.T, (T, 3, 3))
    truth = np.column_stack([rng.uniform(-3, 3, T), rng.uniform(-3, 3, T),
                             np.full(T, np.pi - 0.01)])
    est = truth + rng.standard_normal((T, 3)) @ L.T
    est[:, 2] = wrap_angle(est[:, 2])                      # half of them across the seam
    e = tb.nees(est, truth, P)
    np.testing.assert_allclose(e, metrics.nees(metrics.pose_error(est, truth), P), rtol=1e-10)
    # mean 3, standard error sqrt(6/T) = 0.017
    assert abs(e.mean() - 3.0) < 0.07
    assert np.mean(est[:, 2] < 0) > 0.3


# --------------------------------------------------------------------------- whole filters
def random_frames(rng, x_true, landmarks, ids_world, k):
    sel = rng.choice(len(landmarks), k, replace=False)
    sel = [j for j in sel if np.hypot(*(landmarks[j] - x_true[:2])) > 0.3]
    z = np.array([observe(x_true, landmarks[j]) for j in sel]).reshape(-1, 2)
    z = z + rng.normal(0.0, [0.05, math.radians(2.0)], z.shape)
    z[:, 1] = wrap_angle(z[:, 1])
    ids = ids_world[sel].copy()
    if len(ids) >= 3 and rng.uniform() < 0.2:
        ids[0] = ids[2]                                   # a misread id (gated out, mostly)
    return ids, z


@pytest.mark.parametrize("gate", [0.95, None])
def test_textbook_update_drives_the_same_slam_as_the_fast_and_the_dense_filter(gate):
    rng = np.random.default_rng(7)
    landmarks = rng.uniform(-4, 4, (15, 2))
    ids_world = rng.choice(1000, 15, replace=False)
    x0, P0 = np.array([0.5, -0.3, 3.1]), np.diag([1e-4, 1e-4, 1e-5])
    fast = EKFSLAM(x0, P0, Q, R, gate=gate, capacity=1)
    dense = DenseEKFSLAM(x0, P0, Q, R, gate=gate)
    x, P, index = x0.copy(), P0.copy(), {}
    threshold = gate_threshold(gate)
    x_true = x0.copy()
    n_acc = n_rej = 0
    for step in range(150):
        u = np.array([0.30, 0.36]) if (step // 40) % 2 == 0 else np.array([0.34, 0.28])
        x_true = motion_model(x_true, u, 0.1)
        u_meas = u + rng.normal(0.0, 0.02, 2)
        fast.predict(u_meas, 0.1)
        dense.predict(u_meas, 0.1)
        x, P = tb.predict(x, P, u_meas, 0.1, Q)
        ids, z = random_frames(rng, x_true, landmarks, ids_world, 4)
        Rk = np.stack([R * (1.0 + 0.3 * zz[0]) for zz in z]) if step % 3 == 0 else None
        rep = fast.update(ids, z, Rk)
        dense.update(ids, z, Rk)
        x, P, index, acc = tb.update(x, P, index, ids, z, R if Rk is None else Rk, threshold)
        np.testing.assert_array_equal(acc, rep.accepted)
        n_acc += int(acc.sum())
        n_rej += int(np.sum(rep.rejected))
        assert list(index) == fast.landmark_ids
        scale = max(1.0, np.abs(P).max())
        np.testing.assert_allclose(fast.x, x, rtol=0, atol=1e-10)
        np.testing.assert_allclose(fast.P, P, rtol=0, atol=TOL * scale)
        np.testing.assert_allclose(dense.P, P, rtol=0, atol=TOL * scale)
        np.testing.assert_allclose(dense.x, x, rtol=0, atol=1e-10)
    assert len(index) == 15 and n_acc > 300
    assert (n_rej > 5) if gate is not None else (n_rej == 0)


def test_textbook_update_equals_the_localisation_filters():
    rng = np.random.default_rng(8)
    world = {int(i): p for i, p in zip(rng.choice(500, 12, replace=False),
                                       rng.uniform(-4, 4, (12, 2)))}
    ids_world = np.array(list(world))
    landmarks = np.array([world[i] for i in ids_world])
    x0, P0 = np.array([0.2, 0.1, -3.0]), np.diag([1e-2, 1e-2, 1e-3])
    fast = EKFLocalization(x0, P0, Q, R, world)
    dense = DenseEKFLocalization(x0, P0, Q, R, world)
    x, P, x_true = x0.copy(), P0.copy(), x0.copy()
    threshold = gate_threshold(0.95)
    for _step in range(150):
        u = np.array([0.30, 0.36])
        x_true = motion_model(x_true, u, 0.1)
        u_meas = u + rng.normal(0.0, 0.02, 2)
        fast.predict(u_meas, 0.1)
        dense.predict(u_meas, 0.1)
        x, P = tb.predict(x, P, u_meas, 0.1, Q)
        ids, z = random_frames(rng, x_true, landmarks, ids_world, 3)
        rep = fast.update(ids, z)
        dense.update(ids, z)
        # the same gate and joint update with a known map: slots -1, pose columns only
        keep, h, Hp = [], [], []
        from slamlib.models import observation_jacobians
        for i, mid in enumerate(ids):
            hi = observe(x, world[int(mid)])
            Hpi, _ = observation_jacobians(x, world[int(mid)])
            yi = tb.innovation(z[i], hi)
            if yi @ np.linalg.solve(Hpi @ P @ Hpi.T + R, yi) < threshold:
                keep.append(i)
                h.append(hi)
                Hp.append(Hpi)
        np.testing.assert_array_equal(np.isin(np.arange(len(ids)), keep), rep.accepted)
        if keep:
            H = tb.stacked_jacobian(3, [-1] * len(keep), Hp, np.zeros((len(keep), 2, 2)))
            x, P = tb.joint_update(x, P, z[keep], np.array(h), H,
                                   tb.block_diagonal([R] * len(keep)))
        np.testing.assert_allclose(fast.x, x, rtol=0, atol=1e-10)
        np.testing.assert_allclose(fast.P, P, rtol=0, atol=TOL)
        np.testing.assert_allclose(dense.P, P, rtol=0, atol=TOL)
