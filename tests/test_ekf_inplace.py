"""The joint update's covariance correction on the blocks (issue 15, point 3; issue 23).

:func:`slamlib.ekf.joint_update` changes P in place, ``P <- P - W^T W`` with
``W = L^-1 H P``, ``S = L L^T``, one block of rows at a time. Checked here against
independent computations: the formula ``P - P H^T S^-1 H P`` with full matrices
and the dense textbook filter (tests/dense_ekf.py: Joseph form, full H); that P
stays symmetric to rounding and positive definite over long runs; and that an
update at 2000 landmarks allocates nothing of the size of P.
"""

import math
import tracemalloc

import numpy as np
import pytest
from dense_ekf import DenseEKF

from slamlib.ekf import EKFSLAM, innovation_covariance, joint_update
from slamlib.models import motion_model, observation_jacobians, observe

Q = np.diag([0.02, 0.02]) ** 2
R = np.diag([0.05, math.radians(2.0)]) ** 2
X0 = np.array([0.0, 0.0, 0.3])
P0 = np.diag([1e-4, 1e-4, 1e-5])
TOL = 1e-12


def asymmetry(P: np.ndarray) -> float:
    """max |P - P^T| / max |P|."""
    return float(np.max(np.abs(P - P.T)) / np.max(np.abs(P)))


# --------------------------------------------------------------------------- the correction
@pytest.mark.parametrize("n, k, spare", [(3, 2, 0), (5, 4, 7), (127, 2, 1), (129, 20, 0),
                                         (300, 6, 33), (1001, 4, 0), (1003, 20, 5),
                                         (2080, 4, 0)])         # several blocks of rows
def test_correction_equals_the_formula_in_place_on_the_storage_block(n, k, spare):
    rng = np.random.default_rng(n + k)
    A = rng.normal(size=(n, 40))
    P = A @ A.T / 40 + np.eye(n)
    H = rng.normal(size=(k, n)) * 0.3                 # a full H over every column
    Rb = np.diag(rng.uniform(0.5, 2.0, k))
    y = rng.normal(size=k)
    G = P @ H.T
    S = H @ G + Rb
    want_P = P - G @ np.linalg.solve(S, G.T)          # P - P H' S^-1 H P
    x = rng.normal(size=n)
    want_x = x + G @ np.linalg.solve(S, y)
    want_x[2] = (want_x[2] + np.pi) % (2 * np.pi) - np.pi
    big = np.full((n + spare, n + spare), 7.0)        # the active block of a larger storage
    big[:n, :n] = P
    xs = np.r_[x, np.full(spare, 7.0)]
    PHt, S2 = innovation_covariance(big[:n, :n], np.arange(n), H, Rb)
    nis = joint_update(xs[:n], big[:n, :n], PHt, S2, y)
    np.testing.assert_allclose(big[:n, :n], want_P, rtol=0, atol=1e-12)
    np.testing.assert_allclose(xs[:n], want_x, rtol=0, atol=1e-12)
    assert nis == pytest.approx(y @ np.linalg.solve(S, y), rel=1e-10)
    assert asymmetry(big[:n, :n]) <= 1e-15
    assert np.all(big[n:, :] == 7.0) and np.all(big[:, n:] == 7.0)   # nothing else written
    assert np.all(xs[n:] == 7.0)


def test_a_covariance_that_is_not_positive_definite_changes_nothing():
    P = np.eye(4)
    x = np.zeros(4)
    with pytest.raises(np.linalg.LinAlgError):
        joint_update(x, P, np.zeros((4, 2)), -np.eye(2), np.ones(2))
    assert np.array_equal(P, np.eye(4)) and not x.any()


# --------------------------------------------------------------------------- against the references
def random_filter(rng, n_landmarks: int, capacity: int):
    """An EKFSLAM with a random correlated P (through its storage) and its true map."""
    L = rng.uniform(-5.0, 5.0, (n_landmarks, 2))
    f = EKFSLAM(X0, P0, Q, R, capacity=capacity)
    f.update(np.arange(n_landmarks), np.array([observe(X0, p) for p in L]))
    n = f.state_size
    M = rng.normal(0.0, 0.05, (n, n))
    f._P[:n, :n] = M @ M.T + np.diag(np.r_[P0.diagonal(), np.full(n - 3, 1e-3)])
    return f, L


@pytest.mark.parametrize("n_landmarks, capacity", [(1, 1), (8, 3), (40, 100), (260, 260)])
def test_random_steps_agree_with_the_dense_filter(n_landmarks, capacity):
    rng = np.random.default_rng(n_landmarks)
    fast, L = random_filter(rng, n_landmarks, capacity)
    dense = DenseEKF(X0, P0, Q, R)
    dense.update(np.arange(n_landmarks), np.array([observe(X0, p) for p in L]))
    dense.P = fast.P
    truth = X0.copy()
    for _ in range(15):
        u = rng.uniform(0.1, 0.4, 2)
        truth = motion_model(truth, u, 0.1)
        fast.predict(u, 0.1)
        dense.predict(u, 0.1)
        m = int(rng.integers(1, min(n_landmarks, 10) + 1))
        ids = rng.choice(n_landmarks, m, replace=False)
        z = np.array([observe(truth, L[i]) for i in ids]) + rng.normal(0, [0.05, 0.03], (m, 2))
        a, b = fast.update(ids, z), dense.update(ids, z)
        np.testing.assert_array_equal(a.accepted, b["accepted"])
        np.testing.assert_allclose(fast.x, dense.x, rtol=0, atol=TOL)
        np.testing.assert_allclose(fast.P, dense.P, rtol=0, atol=TOL)
        assert asymmetry(fast.P) <= 1e-15


def jacobians(x, ids):
    """The per-landmark Jacobians (chapter 03), stacked: (m, 2, 3), (m, 2, 2)."""
    pairs = [observation_jacobians(x[:3], x[3 + 2 * i:5 + 2 * i]) for i in ids]
    return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])


def test_joint_nis_is_the_one_of_the_full_matrices():
    rng = np.random.default_rng(2)
    fast, L = random_filter(rng, 6, 6)
    x, P = fast.x, fast.P
    ids = np.array([4, 1, 5])
    z = np.array([observe(X0, L[i]) for i in ids]) + 0.01
    rep = fast.update(ids, z)
    assert rep.n_accepted == 3
    Hp, Hl = jacobians(x, ids)
    H = np.zeros((6, x.size))
    for j, i in enumerate(ids):
        H[2 * j:2 * j + 2, :3], H[2 * j:2 * j + 2, 3 + 2 * i:5 + 2 * i] = Hp[j], Hl[j]
    y = (z - np.array([observe(x[:3], x[3 + 2 * i:5 + 2 * i]) for i in ids])).reshape(-1)
    y[1::2] = (y[1::2] + np.pi) % (2 * np.pi) - np.pi
    S = H @ P @ H.T + np.kron(np.eye(3), R)
    assert rep.joint_nis == pytest.approx(y @ np.linalg.solve(S, y), rel=1e-12)


def test_long_run_keeps_p_symmetric_to_rounding_and_positive_definite():
    rng = np.random.default_rng(11)
    N = 300                                   # n = 603: sizes where OpenBLAS's order varies
    L = rng.uniform(-6.0, 6.0, (N, 2))
    f = EKFSLAM(X0, P0, Q, R, capacity=8)    # the storage grows (n < capacity most of the time)
    truth = X0.copy()
    worst = 0.0
    for step in range(400):
        u = np.array([0.3, 0.33])
        truth = motion_model(truth, u, 0.1)
        f.predict(u, 0.1)
        ids = rng.choice(N, 12, replace=False) if step else np.arange(N)
        z = np.array([observe(truth, L[i]) for i in ids]) + rng.normal(0, [0.05, 0.03],
                                                                        (len(ids), 2))
        f.update(ids, z, R)
        if step % 20 == 0:
            worst = max(worst, asymmetry(f.P))
    P = f.P
    worst = max(worst, asymmetry(P))
    # above n = 512 the joint update subtracts W'W in blocks of rows, and the two halves of P
    # are rounded in their own order: a few ulps of asymmetry (1.0e-15 measured here at 400
    # steps)
    assert worst <= 1e-14
    assert np.min(np.linalg.eigvalsh(0.5 * (P + P.T))) > 0.0
    np.linalg.cholesky(P)


# --------------------------------------------------------------------------- memory
def test_update_at_2000_landmarks_allocates_nothing_the_size_of_p():
    rng = np.random.default_rng(5)
    N = 2000
    L = rng.uniform(-10.0, 10.0, (N, 2))
    f = EKFSLAM(X0, P0, Q, R, capacity=N + 10)     # the storage will not grow here
    f.update(np.arange(N), np.array([observe(X0, p) for p in L]))
    u = np.array([0.3, 0.32])
    f.predict(u, 0.1)
    n = f.state_size
    P_bytes = 8 * n * n
    ids = np.arange(0, 20, 2)
    z = np.array([observe(f.pose, f.landmark(int(i))) for i in ids]) + 1e-3
    rows = np.r_[3:8, 1001:1006, n - 5:n]          # landmark rows: predict leaves them
    cols = np.concatenate([np.arange(3)] + [3 + 2 * i + np.arange(2) for i in ids])
    before = f._P[rows, :n].copy()
    P_cols = f._P[:n, cols].copy()                  # n x 23
    x_prior = f.x
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        rep = f.update(ids, z)
        _, peak_update = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        f.predict(u, 0.1)
        _, peak_predict = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert rep.n_accepted == ids.size
    assert peak_update < 0.5 * P_bytes, (peak_update, P_bytes)
    assert peak_predict < 0.5 * P_bytes, (peak_predict, P_bytes)
    # and the update did what the textbook says on those rows (columns 3: , which the
    # predict after it did not touch): P+ = P - G S^-1 G^T, G = P H^T, H on its columns
    Hp, Hl = jacobians(x_prior, ids)
    Hc = np.zeros((2 * ids.size, cols.size))
    for j in range(ids.size):
        Hc[2 * j:2 * j + 2, :3] = Hp[j]
        Hc[2 * j:2 * j + 2, 3 + 2 * j:5 + 2 * j] = Hl[j]
    S = Hc @ P_cols[cols] @ Hc.T + np.kron(np.eye(ids.size), R)
    G = P_cols @ Hc.T
    want = before - G[rows] @ np.linalg.solve(S, G.T)
    np.testing.assert_allclose(f._P[rows, 3:n], want[:, 3:], rtol=0, atol=1e-12)
    assert asymmetry(f._P[:n, :n]) <= 1e-15        # n = 4003: blocks of rows
