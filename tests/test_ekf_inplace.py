"""The in-place covariance correction of EKFSLAM's update (issue 15, point 3).

``EKFSLAM._fuse`` changes P with one BLAS call over the active block of its
storage, ``P <- P - W^T W`` with ``W = L^-1 H P``, ``S = L L^T``. Checked here
against independent computations: the plain numpy formula, the textbook
equations (:mod:`slamlib.ekf_textbook`, Joseph form with an explicit gain and
full matrices) and the dense filter (:mod:`slamlib.ekf_dense`, ``(I - K H) P``);
that P stays symmetric to rounding and positive definite over long runs; and
that an update at 2000 landmarks allocates nothing of the size of P.
"""

import math
import tracemalloc

import numpy as np
import pytest

from slamlib import ekf_textbook as tb
from slamlib.ekf import EKFSLAM, _subtract_symmetric_low_rank
from slamlib.ekf_dense import DenseEKFSLAM
from slamlib.models import motion_model, observation_jacobians, observe

Q = np.diag([0.02, 0.02]) ** 2
R = np.diag([0.05, math.radians(2.0)]) ** 2
X0 = np.array([0.0, 0.0, 0.3])
P0 = np.diag([1e-4, 1e-4, 1e-5])
TOL = 1e-12


def asymmetry(P: np.ndarray) -> float:
    """max |P - P^T| / max |P|."""
    return float(np.max(np.abs(P - P.T)) / np.max(np.abs(P)))


# --------------------------------------------------------------------------- the BLAS call
@pytest.mark.parametrize("n, k, spare", [(1, 2, 0), (5, 4, 7), (127, 2, 1), (129, 20, 0),
                                         (300, 6, 33), (1001, 4, 0), (1003, 20, 5),
                                         (2080, 4, 0), (2100, 6, 9)])   # in strips of rows
def test_correction_equals_the_formula_in_place_on_the_storage_block(n, k, spare):
    rng = np.random.default_rng(n + k)
    A = rng.normal(size=(n, 40))
    P = A @ A.T / 40 + np.eye(n)
    W = rng.normal(size=(k, n)) * 0.1
    want = P - W.T @ W
    big = np.full((n + spare, n + spare), 7.0)   # the active block of a larger storage
    big[:n, :n] = P
    block = big[:n, :n]
    _subtract_symmetric_low_rank(big, n, W)
    np.testing.assert_allclose(block, want, rtol=0, atol=1e-13)
    assert asymmetry(block) <= 1e-15
    assert np.all(big[n:, :] == 7.0) and np.all(big[:, n:] == 7.0)   # nothing else written


def test_correction_rejects_storage_it_cannot_update_in_place():
    W = np.ones((2, 4))
    with pytest.raises(ValueError, match="P:"):
        _subtract_symmetric_low_rank(np.zeros((4, 4), order="F")[:, :3], 4, W)
    with pytest.raises(ValueError, match="P:"):
        _subtract_symmetric_low_rank(np.zeros((4, 4), dtype=np.float32), 4, W)
    with pytest.raises(ValueError, match="W:"):
        _subtract_symmetric_low_rank(np.zeros((4, 4)), 4, np.ones((2, 3)))


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
def test_random_steps_agree_with_the_textbook_and_the_dense_filter(n_landmarks, capacity):
    rng = np.random.default_rng(n_landmarks)
    fast, L = random_filter(rng, n_landmarks, capacity)
    dense = DenseEKFSLAM(X0, P0, Q, R)
    dense.update(np.arange(n_landmarks), np.array([observe(X0, p) for p in L]))
    n = fast.state_size
    dense._P[:n, :n] = fast.P
    x, P = fast.x, fast.P
    index = {i: 3 + 2 * i for i in range(n_landmarks)}
    truth = X0.copy()
    for _ in range(15):
        u = rng.uniform(0.1, 0.4, 2)
        truth = motion_model(truth, u, 0.1)
        x, P = tb.predict(x, P, u, 0.1, Q)
        fast.predict(u, 0.1)
        dense.predict(u, 0.1)
        m = int(rng.integers(1, min(n_landmarks, 10) + 1))
        ids = rng.choice(n_landmarks, m, replace=False)
        z = np.array([observe(truth, L[i]) for i in ids]) + rng.normal(0, [0.05, 0.03], (m, 2))
        a, b = fast.update(ids, z), dense.update(ids, z)
        x, P, index, acc = tb.update(x, P, index, ids, z, R, fast.threshold)
        np.testing.assert_array_equal(a.accepted, acc)
        np.testing.assert_array_equal(b.accepted, acc)
        for other_x, other_P in ((x, P), (dense.x, dense.P)):
            np.testing.assert_allclose(fast.x, other_x, rtol=0, atol=TOL)
            np.testing.assert_allclose(fast.P, other_P, rtol=0, atol=TOL)
        assert asymmetry(fast.P) <= 1e-15


def jacobians(x, ids):
    """The textbook's per-landmark Jacobians (chapter 03), stacked: (m, 2, 3), (m, 2, 2)."""
    pairs = [observation_jacobians(x[:3], x[3 + 2 * i:5 + 2 * i]) for i in ids]
    return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])


def test_joint_nis_is_the_textbook_one():
    rng = np.random.default_rng(2)
    fast, L = random_filter(rng, 6, 6)
    x, P = fast.x, fast.P
    ids = np.array([4, 1, 5])
    z = np.array([observe(X0, L[i]) for i in ids]) + 0.01
    rep = fast.update(ids, z)
    assert rep.n_accepted == 3
    H = tb.stacked_jacobian(x.size, [3 + 2 * i for i in ids], *jacobians(x, ids))
    y = tb.innovation(z, np.array([observe(x[:3], x[3 + 2 * i:5 + 2 * i]) for i in ids]))
    S = H @ P @ H.T + tb.block_diagonal([R] * 3)
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
    assert worst <= 1e-15
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
    S = Hc @ P_cols[cols] @ Hc.T + tb.block_diagonal([R] * ids.size)
    G = P_cols @ Hc.T
    want = before - G[rows] @ np.linalg.solve(S, G.T)
    np.testing.assert_allclose(f._P[rows, 3:n], want[:, 3:], rtol=0, atol=1e-12)
    assert asymmetry(f._P[:n, :n]) <= 1e-15        # n = 4003: the strips of rows
