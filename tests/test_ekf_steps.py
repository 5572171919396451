"""Each step of slamlib.ekf (the functions the chapters print) against the same step written
here with full matrices: the prediction ``F P F' + F_w Q F_w'``, the stacked H (2m x n),
``S = H P H' + R``, the gate, ``K = P H' S^-1`` with the Joseph form, and the augmentation
``G_x P G_x' + G_z R G_z'``; and h and H against their formulas."""

import math

import numpy as np
import pytest

from slamlib import ekf
from slamlib.models import (
    inverse_observation_jacobians,
    inverse_observe,
    motion_jacobians,
    motion_model,
    observe_landmarks,
    wrap_angle,
)

Q = np.diag([0.02, 0.02]) ** 2
R = np.diag([0.05, math.radians(2.0)]) ** 2
TOL = 1e-12


def random_state(rng, n_landmarks):
    """A random mean and a random, well-conditioned, fully correlated covariance."""
    n = 3 + 2 * n_landmarks
    x = np.concatenate([[rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-np.pi, np.pi)],
                        rng.uniform(-4, 4, 2 * n_landmarks)])
    M = rng.normal(0.0, 0.1, (n, n))
    return x, M @ M.T + 1e-3 * np.eye(n)


def full_H(n, slots, Hp, Hl):
    """The stacked H with a column per state entry (a known map: slot -1)."""
    H = np.zeros((2 * len(slots), n))
    for j, s in enumerate(slots):
        H[2 * j:2 * j + 2, :3] = Hp[j]
        if s >= 0:
            H[2 * j:2 * j + 2, s:s + 2] += Hl[j]
    return H


# --------------------------------------------------------------------------- prediction
@pytest.mark.parametrize("n_landmarks", [0, 1, 6])
def test_prediction_on_the_blocks_equals_the_dense_product(n_landmarks):
    rng = np.random.default_rng(n_landmarks)
    for _ in range(20):
        x, P = random_state(rng, n_landmarks)
        u, dt = rng.uniform(-0.4, 0.4, 2), float(rng.uniform(0.01, 0.3))
        A, W = motion_jacobians(x[:3], u, dt)
        F, Fw = np.eye(x.size), np.zeros((x.size, 2))
        F[:3, :3], Fw[:3] = A, W
        want = F @ P @ F.T + Fw @ Q @ Fw.T
        x1, P1 = x.copy(), P.copy()
        ekf.predict(x1, P1, u, dt, 0.23, Q, A, W)
        np.testing.assert_allclose(P1, want, rtol=0, atol=TOL)
        np.testing.assert_array_equal(x1[:3], motion_model(x[:3], u, dt))
        np.testing.assert_array_equal(x1[3:], x[3:])
        np.testing.assert_array_equal(P1[3:, 3:], P[3:, 3:])        # the map block is untouched
        assert np.array_equal(P1, P1.T)


# --------------------------------------------------------------------------- h and H
def test_observation_and_its_jacobians_against_the_formulas_and_a_landmark_on_the_robot():
    pose = np.array([1.0, -0.5, 0.7])
    L = np.array([[2.0, 1.0], [1.0, -0.5], [-1.0, 0.3]])
    h, Hp, Hl = observe_landmarks(pose, L)
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


def test_innovation_wraps_each_bearing():
    z = np.array([[1.0, -3.1], [2.0, 0.5]])
    h = np.array([[0.9, 3.1], [2.1, 0.4]])
    y = ekf.innovation(z, h)
    np.testing.assert_allclose(y, [[0.1, 2 * np.pi - 6.2], [-0.1, 0.1]], atol=1e-12)
    assert np.all(np.abs(y[:, 1]) < np.pi)


# --------------------------------------------------------------------------- S, the gate
def test_stacked_jacobian_and_S_equal_the_full_matrices_with_a_landmark_read_twice():
    rng = np.random.default_rng(6)
    x, P = random_state(rng, 5)
    slots = np.array([3, 7, 11, 7])
    Hp, Hl = rng.normal(size=(4, 2, 3)), rng.normal(size=(4, 2, 2))
    Rk = np.stack([np.diag(rng.uniform(1e-4, 1e-2, 2)) for _ in range(4)])
    idx, H = ekf.stacked_jacobian(slots, Hp, Hl)
    Hf = full_H(x.size, slots, Hp, Hl)
    Hd = np.zeros_like(Hf)
    np.add.at(Hd.T, idx, H.T)                        # the kept columns, put in place
    np.testing.assert_array_equal(Hd, Hf)
    Rb = ekf.block_diagonal(Rk)
    PHt, S = ekf.innovation_covariance(P, idx, H, Rb)
    np.testing.assert_allclose(PHt, P @ Hf.T, rtol=0, atol=TOL)
    np.testing.assert_allclose(S, Hf @ P @ Hf.T + Rb, rtol=0, atol=TOL)
    assert np.array_equal(S, S.T)
    y = rng.normal(0, 0.1, (4, 2))
    d2, S_i, acc = ekf.gate(y, S, 5.99)
    np.testing.assert_array_equal(acc, d2 < 5.99)
    for j in range(4):
        Hj = Hf[2 * j:2 * j + 2]
        np.testing.assert_allclose(S_i[j], Hj @ P @ Hj.T + Rk[j], rtol=0, atol=TOL)
        assert d2[j] == pytest.approx(y[j] @ np.linalg.solve(S_i[j], y[j]), rel=1e-12)


def test_a_known_maps_readings_have_pose_columns_only():
    rng = np.random.default_rng(7)
    Hp, Hl = rng.normal(size=(3, 2, 3)), rng.normal(size=(3, 2, 2))
    idx, H = ekf.stacked_jacobian(np.full(3, -1), Hp, Hl)
    np.testing.assert_array_equal(idx, [0, 1, 2])
    np.testing.assert_array_equal(H, full_H(3, [-1] * 3, Hp, Hl))


# --------------------------------------------------------------------------- the joint update
def test_joint_update_is_the_textbook_one_with_the_joseph_form():
    """K = P H' S^-1, x + K y (heading wrapped), (I - K H) P (I - K H)' + K R K'."""
    rng = np.random.default_rng(8)
    x, P = random_state(rng, 4)
    x[2] = np.pi - 1e-4                               # the update crosses the seam
    slots = np.array([5, 9, 5])
    Hp, Hl = rng.normal(size=(3, 2, 3)), rng.normal(size=(3, 2, 2))
    Rb = ekf.block_diagonal(np.stack([np.diag(rng.uniform(1e-3, 1e-2, 2)) for _ in range(3)]))
    y = rng.normal(0, 0.05, 6)
    H = full_H(x.size, slots, Hp, Hl)
    S = H @ P @ H.T + Rb
    K = P @ H.T @ np.linalg.inv(S)
    x_want = x + K @ y
    x_want[2] = wrap_angle(x_want[2])
    IKH = np.eye(x.size) - K @ H
    P_want = IKH @ P @ IKH.T + K @ Rb @ K.T
    idx, Hc = ekf.stacked_jacobian(slots, Hp, Hl)
    xk, Pk = x.copy(), P.copy()
    nis = ekf.joint_update(xk, Pk, *ekf.innovation_covariance(Pk, idx, Hc, Rb), y)
    np.testing.assert_allclose(xk, x_want, rtol=0, atol=TOL)
    np.testing.assert_allclose(Pk, P_want, rtol=0, atol=TOL)
    assert nis == pytest.approx(y @ np.linalg.solve(S, y), rel=1e-11)
    assert np.array_equal(Pk, Pk.T) and -np.pi <= xk[2] < np.pi


# --------------------------------------------------------------------------- augmentation
@pytest.mark.parametrize("n_landmarks", [0, 3])
def test_augmentation_equals_the_stacked_jacobian_form(n_landmarks):
    rng = np.random.default_rng(9 + n_landmarks)
    x, P = random_state(rng, n_landmarks)
    z = np.array([2.3, -0.4])
    n = x.size
    J1, J2 = inverse_observation_jacobians(x[:3], z)
    Gx, Gz = np.zeros((n + 2, n)), np.zeros((n + 2, 2))
    Gx[:n], Gx[n:, :3], Gz[n:] = np.eye(n), J1, J2
    want = Gx @ P @ Gx.T + Gz @ R @ Gz.T
    xs, Ps = np.full(n + 4, 7.0), np.full((n + 4, n + 4), 7.0)      # storage with room
    xs[:n], Ps[:n, :n] = x, P
    ekf.augment(xs, Ps, n, inverse_observe(x[:3], z), J1, J2, R)
    np.testing.assert_allclose(Ps[:n + 2, :n + 2], want, rtol=0, atol=TOL)
    np.testing.assert_array_equal(Ps[:n, :n], P)                    # the old block untouched
    np.testing.assert_array_equal(xs[n:n + 2], inverse_observe(x[:3], z))
    assert np.array_equal(Ps[:n + 2, :n + 2], Ps[:n + 2, :n + 2].T)
    assert np.all(Ps[n + 2:] == 7.0) and np.all(xs[n + 2:] == 7.0)


def test_augmentation_covariance_matches_monte_carlo():
    """``J1 P_rr J1' + J2 R J2'`` is the linearised covariance of g(x_r, z): 200,000 samples."""
    rng = np.random.default_rng(10)
    pose, z = np.array([0.5, -1.0, 0.8]), np.array([1.5, 0.3])
    P_rr = np.diag([0.01, 0.02, 0.001]) ** 2
    J1, J2 = inverse_observation_jacobians(pose, z)
    C = ekf.landmark_covariance(J1, P_rr, J2, R)
    X = pose + rng.multivariate_normal(np.zeros(3), P_rr, 200_000)
    Z = z + rng.multivariate_normal(np.zeros(2), R, 200_000)
    a = X[:, 2] + Z[:, 1]
    M = X[:, :2] + Z[:, :1] * np.column_stack([np.cos(a), np.sin(a)])
    np.testing.assert_allclose(np.cov(M.T), C, rtol=0.03, atol=4e-5)   # ~6 standard errors
