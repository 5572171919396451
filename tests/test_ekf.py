"""The filters of slamlib.ekf: semantics, agreement with the dense textbook EKF, bad input.

The filters (slamlib.ekf, the blocks of the state) and the dense textbook EKF
written in this folder (tests/dense_ekf.py: full F, H, G and the Joseph form)
must make the same decisions and agree to round-off over any sequence of
predicts and updates: that is the main check of the algebra on the blocks. The
other tests pin down the update's semantics (gate against the prior, one joint
update, new landmarks from the updated pose, duplicates, unknown ids) against
independent computations, and that bad input fails before anything changes.
"""

import math

import numpy as np
import pytest
from dense_ekf import DenseEKF
from hypothesis import given
from hypothesis import strategies as st

from slamlib.ekf import EKFSLAM, EKFLocalization, gate_threshold
from slamlib.models import (
    inverse_observation_jacobians,
    inverse_observe,
    motion_jacobians,
    motion_model,
    observation_jacobians,
    observe,
    observe_landmarks,
    wrap_angle,
)

Q = np.diag([0.02, 0.02]) ** 2
R = np.diag([0.05, math.radians(2.0)]) ** 2
P0 = np.diag([1e-4, 1e-4, 1e-5])
X0 = np.array([0.5, -0.3, 3.1])


def scripted_sequence(seed=0, steps=300, n_landmarks=25, k=5):
    """A random but reproducible drive past random landmarks with every kind of reading.

    Yields ``(u, dt, ids, z, R_or_None)``: noisy wheel speeds, and readings
    with noise, gross misread ids (rejected by the gate), a new id read twice
    in a call, a mapped id read twice, and per-reading R now and then. The
    heading crosses the +-pi seam (x0 heads at 3.1 rad and the robot turns).
    Every 50 steps an extra id appears, read twice in the same call.
    """
    rng = np.random.default_rng(seed)
    L = rng.uniform(-4, 4, (n_landmarks, 2))
    ids_world = rng.choice(1000, n_landmarks, replace=False)
    x = X0.copy()
    for t in range(steps):
        u = np.array([0.30, 0.34]) if (t // 60) % 2 == 0 else np.array([0.34, 0.28])
        dt = 0.1
        x = motion_model(x, u, dt)
        u_meas = u + rng.normal(0.0, 0.02, 2)
        sel = rng.choice(n_landmarks, k, replace=False)
        sel = np.array([j for j in sel if np.hypot(*(L[j] - x[:2])) > 0.3], dtype=int)
        z = np.array([observe(x, L[j]) for j in sel]).reshape(-1, 2)
        z = z + rng.normal(0.0, [0.05, math.radians(2.0)], z.shape)
        z[:, 1] = wrap_angle(z[:, 1])
        ids = ids_world[sel].copy()
        if t % 9 == 4 and len(ids) >= 2:         # a misread id: another landmark's id
            ids[0] = ids_world[(sel[0] + 7) % n_landmarks]
        if t % 13 == 6 and len(ids) >= 2:        # the same id twice in one call
            ids[1] = ids[0]
        if t % 50 == 3:                          # a new id, read twice in the same call
            p = x[:2] + rng.uniform(-2, 2, 2)
            z2 = np.array([observe(x, p), observe(x, p)]) + rng.normal(0, 0.02, (2, 2))
            ids = np.concatenate([ids, [5000 + t, 5000 + t]])
            z = np.vstack([z, z2])
        Rk = None
        if t % 5 == 0 and len(ids):
            Rk = np.stack([R * (1.0 + 0.3 * zz[0]) for zz in z])
        yield u_meas, dt, ids, z, Rk


def assert_same_report(a, b):
    """``a`` an UpdateReport, ``b`` the dense filter's dict."""
    assert a.status == tuple(b["status"])
    np.testing.assert_array_equal(a.accepted, b["accepted"])
    np.testing.assert_array_equal(a.new, b["new"])
    np.testing.assert_allclose(a.d2, b["d2"], rtol=1e-9, atol=1e-9, equal_nan=True)


def dense_slam(x0, P0, Q, R, gate=0.95, wheel_base=0.23):
    return DenseEKF(x0, P0, Q, R, None, wheel_base=wheel_base, gate=gate)


def dense_localization(x0, P0, Q, R, landmarks, gate=0.95, wheel_base=0.23):
    return DenseEKF(x0, P0, Q, R, landmarks, wheel_base=wheel_base, gate=gate)


# --------------------------------------------------------------------------- fast == dense
@pytest.mark.parametrize("gate", [0.95, None])
def test_slam_equals_dense_textbook_filter(gate):
    fast = EKFSLAM(X0, P0, Q, R, gate=gate, capacity=1)   # forces many reallocations
    dense = dense_slam(X0, P0, Q, R, gate=gate)
    counts = {"accepted": 0, "rejected": 0, "new": 0, "duplicate": 0}
    for u, dt, ids, z, Rk in scripted_sequence():
        fast.predict(u, dt)
        dense.predict(u, dt)
        a = fast.update(ids, z, Rk)
        b = dense.update(ids, z, Rk)
        assert_same_report(a, b)
        for s in a.status:
            counts[s] = counts.get(s, 0) + 1
        assert fast.landmark_ids == dense.landmark_ids
        np.testing.assert_allclose(fast.x, dense.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.P, dense.P, rtol=0, atol=1e-9)
    # the sequence exercised every branch
    assert counts["accepted"] > 500 and counts["new"] == 25 + 6 and counts["duplicate"] > 0
    if gate is None:
        assert counts["rejected"] == 0
    else:
        assert counts["rejected"] > 10


def test_localization_equals_dense_textbook_filter():
    rng = np.random.default_rng(1)
    world = {int(i): p for i, p in zip(rng.choice(500, 25, replace=False),
                                       rng.uniform(-4, 4, (25, 2)))}
    fast = EKFLocalization(X0, P0, Q, R, world)
    dense = dense_localization(X0, P0, Q, R, world)
    for u, dt, ids, z, Rk in scripted_sequence(seed=2):
        ids = ids.copy()
        # the scripted ids are not this map's: half map ids (with their true readings
        # replaced below), half unknown
        fast.predict(u, dt)
        dense.predict(u, dt)
        known = list(world)[: len(ids)]
        ids[: len(ids) // 2] = known[: len(ids) // 2]
        for j in range(len(ids) // 2):
            z[j] = observe(fast.pose, world[int(ids[j])]) + rng.normal(0, [0.05, 0.03])
        a = fast.update(ids, z, Rk)
        b = dense.update(ids, z, Rk)
        assert_same_report(a, b)
        np.testing.assert_allclose(fast.x, dense.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.P, dense.P, rtol=0, atol=1e-9)


# --------------------------------------------------------------------------- semantics
def test_predict_touches_only_the_robot_rows_and_columns():
    f = EKFSLAM(X0, P0, Q, R)
    f.update([1, 2, 3], [[1.0, 0.2], [2.0, -0.3], [1.5, 1.0]])
    before, before_pose = f.P, f.pose
    f.predict([0.3, 0.2], 0.1)
    after = f.P
    np.testing.assert_array_equal(after[3:, 3:], before[3:, 3:])
    A, _ = motion_jacobians(before_pose, [0.3, 0.2], 0.1)
    np.testing.assert_allclose(after[:3, 3:], A @ before[:3, 3:], atol=1e-15)
    np.testing.assert_array_equal(after, after.T)


def test_predict_matches_motion_model_and_covariance_growth():
    f = EKFLocalization(X0, P0, Q, R, {})
    u, dt = np.array([0.4, 0.3]), 0.2
    A, W = motion_jacobians(X0, u, dt)
    f.predict(u, dt)
    np.testing.assert_allclose(f.pose, motion_model(X0, u, dt), atol=1e-15)
    np.testing.assert_allclose(f.pose_cov, A @ P0 @ A.T + W @ Q @ W.T, atol=1e-15)


def independent_d2(X, P, slot_of, ids, z, Rs):
    """Each reading's d2 from the full H built by hand from models.observation_jacobians."""
    n, pose = P.shape[0], X[:3]
    out = []
    for mid, zz, Ri in zip(ids, z, Rs):
        s = slot_of[mid]
        lm = np.array([X[s], X[s + 1]])
        Hp, Hl = observation_jacobians(pose, lm)
        H = np.zeros((2, n))
        H[:, :3] = Hp
        H[:, s:s + 2] = Hl
        y = zz - observe(pose, lm)
        y[1] = wrap_angle(y[1])
        out.append(float(y @ np.linalg.solve(H @ P @ H.T + Ri, y)))
    return np.array(out)


def test_d2_equals_an_independent_computation():
    f = EKFSLAM(X0, P0, Q, R)
    seq = list(scripted_sequence(seed=3, steps=120))
    for u, dt, ids, z, Rk in seq[:100]:
        f.predict(u, dt)
        f.update(ids, z, Rk)
    checked = 0
    for u, dt, ids, z, _ in seq[100:]:
        f.predict(u, dt)
        X, P = f.x, f.P
        slot_of = {m: f.landmark_index(m) for m in f.landmark_ids}
        Rs = [R * (1 + 0.1 * i) for i in range(len(ids))]
        rep = f.update(ids, z, np.array(Rs).reshape(-1, 2, 2))
        mapped = np.array([m in slot_of for m in ids], dtype=bool)
        want = independent_d2(X, P, slot_of, ids[mapped], z[mapped],
                              [r for r, k in zip(Rs, mapped) if k])
        np.testing.assert_allclose(rep.d2[mapped], want, rtol=1e-10)
        thr = -2.0 * math.log(1.0 - 0.95)
        np.testing.assert_array_equal(rep.accepted[mapped], want < thr)
        assert np.all(np.isnan(rep.d2[~mapped]))
        checked += mapped.sum()
    assert checked > 50


def test_gate_threshold_is_the_chi_square_quantile():
    from scipy.stats import chi2
    for g in (0.5, 0.9, 0.95, 0.99, 0.999):
        assert gate_threshold(g) == pytest.approx(chi2.ppf(g, 2), rel=1e-12)
        assert gate_threshold(g, dof=3) == pytest.approx(chi2.ppf(g, 3), rel=1e-12)
    assert gate_threshold(None) == math.inf
    for bad in (0.0, 1.0, -0.1, float("nan")):
        with pytest.raises(ValueError, match="gate"):
            EKFSLAM(X0, P0, Q, R, gate=bad)


def test_joint_update_then_new_landmarks_from_the_updated_pose():
    f = EKFSLAM(X0, P0, Q, R)
    f.update([10, 11], [[2.0, 0.3], [1.5, -0.4]])
    f.predict([0.3, 0.3], 0.5)
    x_prior, P_prior = f.x, f.P
    z = np.array([[1.9, 0.35], [3.0, 0.1], [1.45, -0.35], [2.5, 0.7]])
    rep = f.update([10, 20, 11, 20], z)
    assert rep.status == ("accepted", "new", "accepted", "duplicate")
    np.testing.assert_array_equal(rep.new, [False, True, False, False])
    np.testing.assert_array_equal(rep.accepted, [True, False, True, False])
    assert np.isnan(rep.d2[[1, 3]]).all() and np.isfinite(rep.d2[[0, 2]]).all()
    assert f.landmark_ids == [10, 11, 20]
    # the joint update, by hand, with the prior
    H = np.zeros((4, 7))
    y = np.zeros(4)
    for r, (mid, zz) in enumerate([(10, z[0]), (11, z[2])]):
        s = 3 + 2 * [10, 11].index(mid)
        Hp, Hl = observation_jacobians(x_prior[:3], x_prior[s:s + 2])
        H[2 * r:2 * r + 2, :3], H[2 * r:2 * r + 2, s:s + 2] = Hp, Hl
        yy = zz - observe(x_prior[:3], x_prior[s:s + 2])
        y[2 * r:2 * r + 2] = [yy[0], wrap_angle(yy[1])]
    S = H @ P_prior @ H.T + np.kron(np.eye(2), R)
    K = P_prior @ H.T @ np.linalg.inv(S)
    x_post = x_prior + K @ y
    x_post[2] = wrap_angle(x_post[2])
    P_post = (np.eye(7) - K @ H) @ P_prior
    np.testing.assert_allclose(f.x[:7], x_post, atol=1e-12)
    np.testing.assert_allclose(f.P[:7, :7], P_post, atol=1e-12)
    assert rep.joint_nis == pytest.approx(y @ np.linalg.solve(S, y), rel=1e-10)
    # the new landmark: from the updated pose and the first of its two readings
    np.testing.assert_allclose(f.landmark(20), inverse_observe(x_post[:3], z[1]), atol=1e-12)
    J1, J2 = inverse_observation_jacobians(x_post[:3], z[1])
    np.testing.assert_allclose(f.landmark_cov(20),
                               J1 @ P_post[:3, :3] @ J1.T + J2 @ R @ J2.T, atol=1e-12)
    np.testing.assert_allclose(f.P[7:9, :7], J1 @ P_post[:3, :], atol=1e-12)
    np.testing.assert_allclose(f.P[:7, 7:9], (J1 @ P_post[:3, :]).T, atol=1e-12)


def test_new_ids_are_added_in_the_order_given():
    f = EKFSLAM(X0, P0, Q, R)
    f.update([7, 3, 5], [[1.0, 0.0], [2.0, 0.5], [1.5, -0.5]])
    assert f.landmark_ids == [7, 3, 5]
    assert [f.landmark_index(i) for i in (7, 3, 5)] == [3, 5, 7]
    with pytest.raises(ValueError, match="marker_id"):
        f.landmark(99)


def test_a_mapped_id_read_twice_is_gated_and_fused_twice():
    f = EKFSLAM(X0, P0, Q, R)
    f.update([4], [[2.0, 0.1]])
    d = dense_slam(X0, P0, Q, R)
    d.update([4], [[2.0, 0.1]])
    z = [[2.02, 0.11], [1.97, 0.09]]
    a, b = f.update([4, 4], z), d.update([4, 4], z)
    assert a.status == ("accepted", "accepted")
    assert_same_report(a, b)
    np.testing.assert_allclose(f.P, d.P, atol=1e-12)


def test_gate_none_accepts_everything_and_the_gate_rejects_a_gross_misread():
    z_map = [[2.0, 0.1], [2.5, -0.8]]
    z_bad = [[2.0, 0.1], [0.5, 1.2]]         # id 2 read where id 2 cannot be
    for gate, want in ((None, [True, True]), (0.95, [True, False]), (0.999999, [True, False])):
        f = EKFSLAM(X0, P0, Q, R, gate=gate)
        f.update([1, 2], z_map)
        rep = f.update([1, 2], z_bad)
        np.testing.assert_array_equal(rep.accepted, want)
        assert rep.d2[1] > 100
        assert rep.status[1] == ("accepted" if want[1] else "rejected")
        if gate is None:
            assert rep.threshold == math.inf


def test_localization_rejects_an_unknown_id():
    world = {1: [2.0, 0.0], 2: [0.0, 2.0]}
    f = EKFLocalization([0, 0, 0], P0, Q, R, world)
    g = EKFLocalization([0, 0, 0], P0, Q, R, world)
    z1 = observe([0, 0, 0], world[1])
    rep = f.update([99, 1, 98], [[1.0, 0.2], z1 + [0.01, 0.0], [3.0, -1.0]])
    assert rep.status == ("unknown", "accepted", "unknown")
    np.testing.assert_array_equal(rep.accepted, [False, True, False])
    np.testing.assert_array_equal(rep.new, [False, False, False])
    assert np.isnan(rep.d2[[0, 2]]).all()
    g.update([1], [z1 + [0.01, 0.0]])
    np.testing.assert_array_equal(f.x, g.x)         # the unknown ones changed nothing
    np.testing.assert_array_equal(f.P, g.P)
    rep = f.update([5], [[1.0, 0.0]])
    assert rep.status == ("unknown",) and f.x.shape == (3,)


def test_the_report_says_what_happened():
    f = EKFSLAM(X0, P0, Q, R)
    rep = f.update([], np.zeros((0, 2)))
    assert len(rep) == 0 and math.isnan(rep.joint_nis)
    f.update([1], [[2.0, 0.1]])
    rep = f.update([1, 2, 2], [[2.0, 0.1], [1.0, 0.3], [1.1, 0.3]])
    text = rep.table()
    assert "accepted" in text and "new" in text and "duplicate" in text
    assert rep.n_accepted == 1
    np.testing.assert_array_equal(rep.rejected, [False, False, False])
    assert rep.S.shape == (3, 2, 2) and rep.innovation.shape == (3, 2)


# --------------------------------------------------------------------------- covariance health
def test_covariance_stays_exactly_symmetric_and_positive_definite():
    f = EKFSLAM(X0, P0, Q, R, capacity=0)
    for u, dt, ids, z, Rk in scripted_sequence(seed=4, steps=600, k=6):
        f.predict(u, dt)
        f.update(ids, z, Rk)
        P = f.P
        assert np.array_equal(P, P.T)
        assert -math.pi <= f.x[2] < math.pi
    np.linalg.cholesky(P)
    assert np.min(np.linalg.eigvalsh(P)) > 0


def test_storage_doubles_and_the_accessors_return_copies():
    f = EKFSLAM(X0, P0, Q, R, capacity=1)
    caps = []
    for i in range(40):
        f.update([i], [[1.0 + 0.01 * i, -1.0 + 0.05 * i]])
        caps.append(f.capacity)
    assert f.state_size == 83 and f.n_landmarks == 40
    assert len(set(caps)) <= 7                                  # geometric growth
    assert all(b in (a, 2 * a) for a, b in zip(caps, caps[1:]))
    x, P = f.x, f.P
    x[:] = 0.0
    P[:] = 0.0
    assert f.x[0] == X0[0] and f.P[0, 0] == P0[0, 0]
    lm = f.landmarks
    lm[0][:] = 99.0
    assert f.landmark(0)[0] != 99.0


@given(st.floats(-5, 5), st.floats(-5, 5), st.floats(-math.pi, math.pi),
       st.lists(st.tuples(st.floats(-10, 10), st.floats(-10, 10)), min_size=1, max_size=6))
def test_vectorised_predicted_readings_equal_the_models(x, y, th, pts):
    pose = np.array([x, y, th])
    L = np.array(pts)
    h, Hp, Hl = observe_landmarks(pose, L)
    for j, lm in enumerate(L):
        if np.hypot(*(lm - pose[:2])) < 1e-6:
            continue
        np.testing.assert_allclose(h[j], observe(pose, lm), atol=1e-12)
        a, b = observation_jacobians(pose, lm)
        np.testing.assert_allclose(Hp[j], a, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(Hl[j], b, rtol=1e-12, atol=1e-12)


def test_a_landmark_on_top_of_the_robot_is_not_used():
    f = EKFSLAM([0, 0, 0], P0, Q, R)
    f.update([1], [[0.0, 0.0]])                  # range 0: the landmark is at the robot
    x, P = f.x, f.P
    rep = f.update([1], [[0.1, 0.0]])
    assert rep.status == ("degenerate",) and not rep.accepted[0]
    np.testing.assert_array_equal(f.x, x)
    np.testing.assert_array_equal(f.P, P)


# --------------------------------------------------------------------------- bad input
def busy_filter(cls=EKFSLAM):
    f = cls(X0, P0, Q, R)
    for u, dt, ids, z, Rk in scripted_sequence(seed=5, steps=30):
        f.predict(u, dt)
        f.update(ids, z, Rk)
    return f


BAD_UPDATES = [
    (([1, 2], [[1.0, 0.1]]), "z"),                                # too few rows
    (([1, 2], [[1.0, 0.1, 0.0], [1.0, 0.1, 0.0]]), "z"),         # three columns
    (([1], [[float("nan"), 0.1]]), "z"),
    (([1], [[1.0, float("inf")]]), "z"),
    (([1, 2], [[1.0, 0.1], [-0.5, 0.2]]), "range"),               # negative range
    (([1.0, float("nan")], [[1.0, 0.1], [1.0, 0.2]]), "ids"),
    (([1.5], [[1.0, 0.1]]), "ids"),
    ((["a"], [[1.0, 0.1]]), "ids"),
    (([[1, 2]], [[1.0, 0.1], [1.0, 0.2]]), "ids"),
    ((5, [[1.0, 0.1]]), "ids"),
]


@pytest.mark.parametrize("args,word", BAD_UPDATES)
def test_bad_readings_raise_and_change_nothing(args, word):
    f = busy_filter()
    x, P, ids = f.x, f.P, f.landmark_ids
    with pytest.raises(ValueError, match=word):
        f.update(*args)
    np.testing.assert_array_equal(f.x, x)
    np.testing.assert_array_equal(f.P, P)
    assert f.landmark_ids == ids


@pytest.mark.parametrize("R_bad,word", [
    (np.diag([1.0, -1.0]), "R"),
    (np.array([[1.0, 2.0], [2.0, 1.0]]), "R"),
    (np.eye(3), "R"),
    (np.stack([R, np.diag([0.01, 0.0])]), r"R\[1\]"),
    (np.stack([R, R, R]), "R"),
    (np.array([[1.0, float("nan")], [float("nan"), 1.0]]), "R"),
])
def test_bad_per_call_noise_raises_and_changes_nothing(R_bad, word):
    f = busy_filter()
    x, P = f.x, f.P
    known = f.landmark_ids[0]
    with pytest.raises(ValueError, match=word):
        f.update([known, 12345], [[1.0, 0.1], [2.0, 0.2]], R_bad)
    np.testing.assert_array_equal(f.x, x)
    np.testing.assert_array_equal(f.P, P)


@pytest.mark.parametrize("u,dt,word", [
    ([float("nan"), 0.1], 0.1, "u"), ([0.1], 0.1, "u"), ([0.1, float("inf")], 0.1, "u"),
    ([0.1, 0.1], -0.1, "dt"), ([0.1, 0.1], float("nan"), "dt"),
])
def test_bad_controls_raise_and_change_nothing(u, dt, word):
    f = busy_filter()
    x, P = f.x, f.P
    with pytest.raises(ValueError, match=word):
        f.predict(u, dt)
    np.testing.assert_array_equal(f.x, x)
    np.testing.assert_array_equal(f.P, P)


NOT_PD = np.diag([1.0, 1.0, -1e-6])


@pytest.mark.parametrize("kwargs,word", [
    ({"P0": NOT_PD}, "P0"), ({"P0": np.zeros((3, 3))}, "P0"), ({"P0": np.eye(2)}, "P0"),
    ({"P0": np.array([[1, 0.5, 0], [0, 1, 0], [0, 0, 1.0]])}, "P0"),
    ({"Q": np.diag([0.1, 0.0])}, "Q"), ({"Q": np.full((2, 2), np.nan)}, "Q"),
    ({"R": -np.eye(2)}, "R"), ({"R": np.eye(3)}, "R"),
    ({"x0": [0, 0]}, "x0"), ({"x0": [0, np.nan, 0]}, "x0"),
    ({"wheel_base": 0.0}, "wheel_base"),
])
@pytest.mark.parametrize("cls", [EKFSLAM, EKFLocalization])
def test_bad_construction_names_the_argument(cls, kwargs, word):
    args = {"x0": X0, "P0": P0, "Q": Q, "R": R} | kwargs
    extra = {"landmarks": {1: [0.0, 0.0]}} if cls is EKFLocalization else {}
    with pytest.raises(ValueError, match=word):
        cls(**args, **extra)


@pytest.mark.parametrize("landmarks,word", [
    ([[0.0, 0.0]], "dict"), ({1.5: [0.0, 0.0]}, "integer"), ({"a": [0.0, 0.0]}, "integer"),
    ({True: [0.0, 0.0]}, "integer"), ({1: [0.0, np.nan]}, r"landmarks\[1\]"),
    ({1: [0.0, 0.0, 0.0]}, r"landmarks\[1\]"),
])
def test_bad_maps_name_the_argument(landmarks, word):
    with pytest.raises(ValueError, match=word):
        EKFLocalization(X0, P0, Q, R, landmarks)


def test_the_map_accepts_numpy_ids_and_is_copied():
    pos = np.array([1.0, 2.0])
    f = EKFLocalization(X0, P0, Q, R, {np.int64(3): pos})
    pos[0] = 9.0
    np.testing.assert_array_equal(f.landmarks[3], [1.0, 2.0])
    assert f.landmark_ids == [3]


# --------------------------------------------------------------------------- the blocked algebra
# (the in-place BLAS correction itself: tests/test_ekf_inplace.py)
def test_slam_with_a_large_map_equals_dense():
    """Over 128 state entries the structured update works in several strips."""
    rng = np.random.default_rng(8)
    L = rng.uniform(-6, 6, (90, 2))
    fast, dense = EKFSLAM(X0, P0, Q, R, capacity=4), dense_slam(X0, P0, Q, R)
    ids = np.arange(90)
    z0 = np.array([observe(X0, p) for p in L])
    for f in (fast, dense):
        f.update(ids, z0)
    x = X0.copy()
    for _ in range(8):
        u = np.array([0.3, 0.33])
        x = motion_model(x, u, 0.1)
        sel = rng.choice(90, 12, replace=False)
        z = np.array([observe(x, L[j]) for j in sel]) + rng.normal(0, [0.05, 0.03], (12, 2))
        for f in (fast, dense):
            f.predict(u, 0.1)
        a, b = fast.update(sel, z), dense.update(sel, z)
        assert_same_report(a, b)
        assert a.n_accepted >= 10
    assert fast.state_size == 183
    np.testing.assert_allclose(fast.x, dense.x, atol=1e-9)
    np.testing.assert_allclose(fast.P, dense.P, atol=1e-9)
    assert np.array_equal(fast.P, fast.P.T)


def test_the_gate_can_be_changed_between_updates():
    f = EKFSLAM(X0, P0, Q, R)
    assert f.threshold == pytest.approx(-2 * math.log(0.05))
    f.gate = 0.99
    assert f.threshold == pytest.approx(-2 * math.log(0.01))
    f.gate = None
    assert f.threshold == math.inf
    with pytest.raises(ValueError, match="gate"):
        f.gate = 1.5
    assert f.gate is None


# --------------------------------------------------------------------------- the public hook
class _FlippedMixin:
    """A teaching variant: H_pose[1,1] with the report's sign, through the public hook only."""

    def reading_model(self, pose, positions):
        h, Hp, Hl = super().reading_model(pose, positions)
        Hp[:, 1, 1] = -Hp[:, 1, 1]
        return h, Hp, Hl


class _FlippedLocalization(_FlippedMixin, EKFLocalization):
    pass


class _FlippedDense(_FlippedMixin, DenseEKF):
    pass


class _FlippedSLAM(_FlippedMixin, EKFSLAM):
    pass


def test_reading_model_default_is_observe_landmarks():
    f = EKFLocalization(X0, P0, Q, R, {1: [1.0, 2.0]})
    L = np.array([[1.0, 2.0], [-3.0, 0.5]])
    for a, b in zip(f.reading_model(X0, L), observe_landmarks(X0, L)):
        assert np.array_equal(a, b)


def test_reading_model_override_is_used_by_gate_and_update():
    # one reading, computed by hand with the flipped H: d2, posterior mean and covariance
    lm = np.array([2.6, 0.9])
    x0 = np.array([0.4, -0.2, 0.3])
    z = observe(x0, lm) + np.array([0.03, -0.02])
    Hp, _ = observation_jacobians(x0, lm)
    Hp[1, 1] = -Hp[1, 1]
    y = z - observe(x0, lm)
    y[1] = wrap_angle(y[1])
    S = Hp @ P0 @ Hp.T + R
    K = P0 @ Hp.T @ np.linalg.inv(S)
    x_want = x0 + K @ y
    I_KH = np.eye(3) - K @ Hp
    P_want = I_KH @ P0 @ I_KH.T + K @ R @ K.T
    for f in (_FlippedLocalization(x0, P0, Q, R, {5: lm}, gate=None),
              _FlippedDense(x0, P0, Q, R, {5: lm}, gate=None)):
        rep = f.update([5], z[None, :])
        d2 = rep.d2[0] if hasattr(rep, "d2") else rep["d2"][0]
        assert d2 == pytest.approx(float(y @ np.linalg.solve(S, y)), rel=1e-10)
        np.testing.assert_allclose(f.x, x_want, atol=1e-12)
        np.testing.assert_allclose(f.P, P_want, atol=1e-12)
    # and it differs from the right filter
    g = EKFLocalization(x0, P0, Q, R, {5: lm}, gate=None)
    g.update([5], z[None, :])
    assert np.abs(g.x - x_want).max() > 1e-6


def test_reading_model_override_is_the_same_in_the_dense_reference():
    fast, dense = _FlippedSLAM(X0, P0, Q, R, capacity=1), _FlippedDense(X0, P0, Q, R)
    for u, dt, ids, z, Rk in scripted_sequence(seed=4, steps=120):
        fast.predict(u, dt)
        dense.predict(u, dt)
        assert_same_report(fast.update(ids, z, Rk), dense.update(ids, z, Rk))
        np.testing.assert_allclose(fast.x, dense.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.P, dense.P, rtol=0, atol=1e-9)
