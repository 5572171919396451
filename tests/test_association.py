"""Association without ids (chapter 09): NN, JCBB, the filters' update(None, z), confirmation."""

import itertools

import numpy as np
import pytest
from same_record import assert_same_record

from slamlib import association as asc
from slamlib import ekf
from slamlib.confirmation import ConfirmedSLAM
from slamlib.course.association_study import association_errors, make_filter, run_without_ids
from slamlib.ekf import EKFSLAM, EKFLocalization
from slamlib.metrics import ate
from slamlib.models import observe, wrap_angle
from slamlib.runs import load_run
from slamlib.sim import scenario

Q = np.diag([1e-4, 1e-4])
R = np.diag([0.02**2, np.radians(1.0) ** 2])


# ----------------------------------------------------------------------- a two-in-one-gate world
# The estimate is at the origin, the robot really 0.15 m to the side (+y, the prior's sigma is
# 0.2 m). Landmark B sits 0.15 m from A exactly where the displaced robot sees A, so the reading
# of A falls right on B's prediction; C, far away, is seen displaced the same way.
TRUE_POSE = np.array([0.0, 0.15, 0.0])
MAP = {1: np.array([2.0, 0.0]), 2: np.array([2.0, -0.15]), 3: np.array([2.0, 2.0])}
P0 = np.diag([0.2**2, 0.2**2, 1e-8])


def _readings(ids):
    return np.array([observe(TRUE_POSE, MAP[i]) for i in ids])


def _two_in_one_gate(association):
    f = EKFLocalization(np.zeros(3), P0, Q, R, MAP, association=association)
    return f, f.update(None, _readings([1, 3]))


def test_two_landmarks_in_one_gate_nn_goes_wrong_and_jcbb_right():
    f_nn, nn = _two_in_one_gate("nn")
    f_jc, jc = _two_in_one_gate("jcbb")
    assert list(nn.matched) == [2, 3]               # the reading of A fused into B
    assert list(jc.matched) == [1, 3]
    # the numbers: both landmarks inside the reading's gate, B the nearer one ...
    z = _readings([1, 3])
    d2 = {lm: _d2(_innov(z[0], MAP[lm]), _dense_H(np.zeros(3), [MAP[lm]]), P0, R)
          for lm in (1, 2)}
    assert d2[2] < 1e-9 < 0.3 < d2[1] < 5.99
    # ... but jointly with the reading of C, A is right and B is far outside the 4-dof gate
    joint_right = _joint(np.zeros(3), [(0, 1), (1, 3)])
    joint_nn = _joint(np.zeros(3), [(0, 2), (1, 3)])
    assert joint_right < 1.0 and joint_nn > 9.49    # chi2.ppf(0.95, 4)
    # the filters moved accordingly: JCBB towards the truth, NN away from it
    err_jc, err_nn = abs(f_jc.pose[1] - TRUE_POSE[1]), abs(f_nn.pose[1] - TRUE_POSE[1])
    assert err_jc < 0.01 and err_nn > 0.05 and err_nn > 5 * err_jc


def _dense_H(pose, lms):
    """Jacobian of the readings w.r.t. the pose, by central differences (independent of slamlib)."""
    H = np.zeros((2 * len(lms), 3))
    for c in range(3):
        e = np.zeros(3)
        e[c] = 1e-6
        for k, lm in enumerate(lms):
            d = observe(pose + e, lm) - observe(pose - e, lm)
            d[1] = wrap_angle(d[1])
            H[2 * k:2 * k + 2, c] = d / 2e-6
    return H


def _d2(y, H, P, Rk):
    S = H @ P @ H.T + Rk
    return float(y @ np.linalg.solve(S, y))


def _innov(z, lm, pose=None):
    h = observe(np.zeros(3) if pose is None else pose, lm)
    return np.array([z[0] - h[0], wrap_angle(z[1] - h[1])])


def _joint(pose, pairs):
    z = _readings([1, 3])
    y = np.concatenate([_innov(z[i], MAP[lm], pose) for i, lm in pairs])
    H = _dense_H(pose, [MAP[lm] for _, lm in pairs])
    S = H @ P0 @ H.T + np.kron(np.eye(len(pairs)), R)
    return float(y @ np.linalg.solve(S, y))


# ----------------------------------------------------------------------- JCBB against brute force
def _brute_force(y, d2, C, Rk, gate):
    """Every hypothesis; keep those whose every prefix is jointly compatible; most pairs, then
    smallest joint distance (the definition of the answer in slamlib.association)."""
    from scipy.stats import chi2

    k, N = d2.shape
    thr1 = chi2.ppf(gate, 2)
    best, best_key = None, None
    for hyp in itertools.product(range(-1, N), repeat=k):
        paired = [(i, j) for i, j in enumerate(hyp) if j >= 0]
        js = [j for _, j in paired]
        if len(set(js)) < len(js) or any(d2[i, j] >= thr1 for i, j in paired):
            continue
        ok, D = True, 0.0
        for m in range(1, len(paired) + 1):
            sub = paired[:m]
            idx = np.concatenate([[2 * j, 2 * j + 1] for _, j in sub])
            S = C[np.ix_(idx, idx)] + np.kron(np.eye(m), np.zeros((2, 2)))
            for q, (i, _) in enumerate(sub):
                S[2 * q:2 * q + 2, 2 * q:2 * q + 2] += Rk[i]
            yv = np.concatenate([y[i, j] for i, j in sub])
            D = float(yv @ np.linalg.solve(S, yv))
            if D >= chi2.ppf(gate, 2 * m):
                ok = False
                break
        if not ok:
            continue
        key = (-len(paired), D)
        if best_key is None or key < best_key:
            best, best_key = np.array(hyp), key
    return best, -best_key[0], best_key[1]


def _random_case(rng, k, N):
    pose_sigma = rng.uniform(0.05, 0.3)
    A = rng.normal(size=(2 * N, 3)) * pose_sigma
    L = rng.normal(size=(2 * N, 2 * N)) * 0.05
    C = A @ A.T + L @ L.T + 1e-4 * np.eye(2 * N)
    Rk = np.array([np.diag(rng.uniform(0.01, 0.05, 2) ** 2) for _ in range(k)])
    truth = rng.permutation(N)[:k] if k <= N else rng.integers(0, N, k)
    shift = A @ rng.normal(size=3)
    y = np.zeros((k, N, 2))
    for i in range(k):
        for j in range(N):
            y[i, j] = (shift[2 * j:2 * j + 2] * (j == truth[i])
                       + rng.normal(size=2) * (0.05 if j == truth[i] else 0.3))
    S = np.array([[C[2 * j:2 * j + 2, 2 * j:2 * j + 2] + Rk[i] for j in range(N)]
                  for i in range(k)])
    return y, asc.individual_d2(y, S), C, Rk


@pytest.mark.parametrize("seed", range(60))
def test_jcbb_equals_brute_force_on_small_random_cases(seed):
    rng = np.random.default_rng(seed)
    k, N = int(rng.integers(1, 5)), int(rng.integers(1, 5))
    y, d2, C, Rk = _random_case(rng, k, N)
    gate = 0.95 if seed % 3 else 0.99
    res = asc.jcbb(y, d2, C, Rk, gate)
    want, pairs, D = _brute_force(y, d2, C, Rk, gate)
    assert res.complete
    assert res.pairs == pairs
    assert np.isclose(res.d2, D, rtol=1e-9, atol=1e-12)
    assert list(res.assignment) == list(want)


def test_the_random_cases_are_not_trivial():
    # the brute-force comparison means something only if many cases have several hypotheses
    ambiguous = 0
    for seed in range(60):
        rng = np.random.default_rng(seed)
        k, N = int(rng.integers(1, 5)), int(rng.integers(1, 5))
        _, d2, _, _ = _random_case(rng, k, N)
        ambiguous += int(np.any(np.sum(d2 < 5.99, axis=1) >= 2))
    assert ambiguous >= 15


def test_jcbb_budget_returns_the_best_found_flagged_incomplete():
    rng = np.random.default_rng(3)
    k = N = 7
    C = 0.01 * np.eye(2 * N) + 0.05
    Rk = np.array([np.eye(2) * 1e-3] * k)
    y = rng.normal(size=(k, N, 2)) * 0.02                    # everything compatible with everything
    d2 = asc.individual_d2(y, np.broadcast_to(C[:2, :2] + Rk[0], (k, N, 2, 2)))
    full = asc.jcbb(y, d2, C, Rk, 0.95)
    cut = asc.jcbb(y, d2, C, Rk, 0.95, max_nodes=20)
    assert full.complete and not cut.complete
    assert cut.nodes <= 21 < full.nodes
    assert cut.pairs <= full.pairs and (cut.pairs < full.pairs or cut.d2 >= full.d2)
    assert cut.pairs >= 1                                     # at least the first leaf


# --------------------------------------------------------------------------- the other pieces
def test_nearest_neighbour_takes_the_closest_pair_first_one_reading_per_landmark():
    d2 = np.array([[1.0, 4.0], [0.5, 3.0], [9.0, 8.0]])
    # reading 1 is closest to landmark 0; reading 0 then gets landmark 1; reading 2 is outside
    assert list(asc.nearest_neighbour(d2, 5.99)) == [1, 0, -1]
    assert list(asc.nearest_neighbour(np.array([[np.nan, 2.0]]), 5.99)) == [1]


def test_predicted_readings_covariance_equals_dense_H_P_H_T():
    f = EKFSLAM(np.array([0.3, -0.2, 0.4]), np.diag([0.01, 0.02, 0.003]), Q, R)
    f.update([5, 6, 7], np.array([[2.0, 0.3], [1.5, -0.4], [3.0, 0.1]]))
    for _ in range(5):
        f.predict([0.2, 0.25], 0.1)
    f.update([5, 6, 7], np.array([[2.0, 0.31], [1.45, -0.38], [3.02, 0.12]]))
    lms = [7, 5]
    slots = np.array([f.landmark_index(i) for i in lms])
    h, Hp, Hl = f.jacobians("observation", ids=lms)            # the filter's own hook
    idx, Hc = ekf.stacked_jacobian(slots, Hp, Hl)
    _, C = ekf.innovation_covariance(f.P, idx, Hc, 0.0)         # what the association uses
    # dense: H (4 x n) by finite differences of observe over the whole state
    x, P = f.x, f.P
    H = np.zeros((4, x.size))
    for c in range(x.size):
        e = np.zeros(x.size)
        e[c] = 1e-6
        for q, s in enumerate(slots):
            d = observe((x + e)[:3], (x + e)[s:s + 2]) - observe((x - e)[:3], (x - e)[s:s + 2])
            d[1] = wrap_angle(d[1])
            H[2 * q:2 * q + 2, c] = d / 2e-6
    assert np.allclose(C, H @ P @ H.T, rtol=1e-6, atol=1e-10)


def test_joint_distance_is_the_stacked_mahalanobis_distance_not_the_sum():
    C = np.array([[1.0, 0, 0.9, 0], [0, 1.0, 0, 0.9], [0.9, 0, 1.0, 0], [0, 0.9, 0, 1.0]])
    y = np.array([[1.0, 0.0], [-1.0, 0.0]])                 # opposite shifts, correlated
    d = asc.joint_distance(y, C)
    assert np.isclose(d, 2.0 / (1.0 - 0.9))          # [1, -1] against [[1, .9], [.9, 1]]
    assert d > asc.individual_d2(y[:, None], np.broadcast_to(np.eye(2), (2, 1, 2, 2))).sum()


# --------------------------------------------------------------------------- argument errors
def test_update_without_ids_on_an_ids_filter_is_an_error_that_says_what_to_use():
    f = EKFSLAM(np.zeros(3), np.eye(3) * 1e-4, Q, R)
    f.update([4], [[2.0, 0.1]])
    x, P = f.x, f.P
    with pytest.raises(ValueError, match="association='nn' or association='jcbb'"):
        f.update(None, [[2.0, 0.1]])
    assert np.array_equal(f.x, x) and np.array_equal(f.P, P)


@pytest.mark.parametrize("association", ["nn", "jcbb"])
@pytest.mark.parametrize("cls", [EKFSLAM, ConfirmedSLAM])
def test_ids_given_to_an_associating_filter_is_an_error(cls, association):
    f = cls(np.zeros(3), np.eye(3) * 1e-4, Q, R, association=association)
    f.update(None, [[2.0, 0.1]])
    f.update(None, [[2.0, 0.1]])
    x, P, lms = f.x, f.P, f.landmark_ids
    with pytest.raises(ValueError, match=r"update\(None, z\)"):
        f.update([1], [[2.0, 0.1]])
    assert np.array_equal(f.x, x) and np.array_equal(f.P, P) and f.landmark_ids == lms
    with pytest.raises(ValueError, match="z: expected"):
        f.update(None, [[2.0, np.nan]])
    assert np.array_equal(f.x, x) and np.array_equal(f.P, P)


def test_bad_association_arguments():
    with pytest.raises(ValueError, match="association: expected one of"):
        EKFSLAM(np.zeros(3), np.eye(3), Q, R, association="nearest")
    with pytest.raises(ValueError, match="gate: association='jcbb' needs a gate"):
        EKFSLAM(np.zeros(3), np.eye(3), Q, R, gate=None, association="jcbb")
    f = EKFLocalization(np.zeros(3), np.eye(3), Q, R, MAP, association="nn")
    with pytest.raises(ValueError, match="needs a gate"):     # refused when set (issue 24)
        f.gate = None
    assert f.gate == 0.95


def test_matched_with_ids():
    f = EKFSLAM(np.zeros(3), np.eye(3) * 1e-6, Q, R)
    f.update([3, 4], [[2.0, 0.1], [1.0, -0.3]])
    rep = f.update([3, 9, 4], [[2.0, 0.1], [1.0, 0.5], [1.4, -0.3]])    # 4 far off: rejected
    assert list(rep.matched) == [3, 9, -1]


def test_filter_names_new_landmarks_and_fuses_readings_in_order_given():
    f = EKFSLAM(np.zeros(3), np.eye(3) * 1e-6, Q, R, association="nn")
    z = np.array([[2.0, 0.1], [1.0, -0.3]])
    rep = f.update(None, z)
    assert list(rep.matched) == [0, 1] and rep.status == ("new", "new")
    rep = f.update(None, z[::-1] + [0.01, 0.0])
    assert list(rep.matched) == [1, 0] and rep.status == ("accepted", "accepted")


# --------------------------------------------------------------------------- whole runs
@pytest.fixture(scope="module")
def random_loop_traces():
    run = load_run("random_loop")
    return run, {m: run_without_ids(run, make_filter(run, m), max_time=40.0)
                 for m in ("ids", "nn", "jcbb")}


def test_well_separated_world_nn_and_jcbb_recover_the_ids_trajectory(random_loop_traces):
    run, traces = random_loop_traces
    ref = traces["ids"][0]
    for m in ("nn", "jcbb"):
        tr, tid = traces[m]
        sc = association_errors(tr, tid)
        assert sc.wrong == 0 and sc.clutter_landmarks == 0 and sc.duplicates == 0
        assert sc.fused > 0.9 * association_errors(*traces["ids"]).fused
        gap = np.max(np.hypot(*(tr.x[:, :2] - ref.x[:, :2]).T))
        assert gap < 0.02, (m, gap)
        assert abs(ate(tr.x, tr.truth).position - ate(ref.x, ref.truth).position) < 0.005


def test_clutter_never_enters_the_map_as_a_confirmed_landmark():
    # the arena with a clutter reading in 10 % of the frames (chapter 09's study); a confirmation
    # needs two consistent sightings, so a coincidence of two clutter readings a few cm apart
    # within two frames could still pass: chapter 09 counts those over 100 seeds
    for seed in range(3):
        run = scenario("arena_loop", seed=seed, p_outlier=0.1)
        for m in ("nn", "jcbb"):
            tr, tid = run_without_ids(run, make_filter(run, m), max_time=30.0)
            sc = association_errors(tr, tid)
            assert sc.clutter > 15
            assert sc.clutter_landmarks == 0 and sc.clutter_fused == 0
    # the scenario is a test: without confirmation the same clutter does enter the map
    tr, tid = run_without_ids(run, make_filter(run, "nn", confirmed=False), max_time=30.0)
    assert association_errors(tr, tid).clutter_landmarks > 10


def test_stored_study_is_regenerated_by_the_code():
    # data/studies/association_study.json is written by `make association-study`; recompute a
    # sample (two seeds, every method) and compare row for row
    from slamlib.course.association_study import load_study, study_row

    settings, rows = load_study()
    assert len(rows) == len(settings["seeds"]) * len(settings["methods"]) >= 300
    for seed in (settings["seeds"][0], settings["seeds"][37]):
        for m in settings["methods"]:
            stored = next(r for r in rows if r["seed"] == seed and r["method"] == m)
            assert_same_record(study_row(seed, m, settings), stored, f"{seed} {m}")


def test_stored_drift_study_is_regenerated_by_the_code():
    # data/studies/association_drift.json (`make association-study`): recompute two seeds, every
    # (method, gate), row for row; seed 1 is chapter 09's drifted run (scenario's default seed)
    from slamlib.course.association_study import drift_row, load_drift_study

    settings, rows = load_drift_study()
    assert len(rows) == len(settings["seeds"]) * len(settings["configs"]) >= 500
    assert settings["seeds"][0] == 1
    for seed in (settings["seeds"][0], settings["seeds"][63]):
        for m, g in settings["configs"]:
            stored = next(r for r in rows if r["seed"] == seed and r["method"] == m
                          and r["gate"] == g)
            assert_same_record(drift_row(seed, m, g, settings), stored, f"{seed} {m} {g}")
    # the scoring after the closure is a part of the whole: never more wrong late than in all
    assert all(0 <= r["wrong_late"] <= r["wrong"] <= r["fused"] for r in rows)


def test_stored_dense_study_is_regenerated_by_the_code():
    # data/studies/association_dense.json (`make association-study`): 100 dense random worlds;
    # recompute two of them (seed 1 is chapter 09's world), both methods, row for row
    from slamlib.course.association_study import dense_row, load_dense_study

    settings, rows = load_dense_study()
    assert len(rows) == len(settings["seeds"]) * len(settings["methods"]) >= 200
    for seed in (settings["seeds"][0], settings["seeds"][41]):
        for m in settings["methods"]:
            stored = next(r for r in rows if r["seed"] == seed and r["method"] == m)
            assert_same_record(dense_row(seed, m, settings), stored, f"{seed} {m}")


def test_confirmed_slam_without_ids_errors_and_copies():
    import copy

    f = ConfirmedSLAM(np.zeros(3), np.eye(3) * 1e-4, Q, R)
    with pytest.raises(ValueError, match="association='nn' or association='jcbb'"):
        f.update(None, [[2.0, 0.1]])
    assert f.frame == 0
    g = ConfirmedSLAM(np.zeros(3), np.eye(3) * 1e-4, Q, R, association="jcbb")
    g.update(None, [[2.0, 0.1]])
    h = copy.deepcopy(g)
    rep = h.update(None, [[2.0, 0.1]])                 # the copy's own candidates, not g's
    assert rep.status == ("new",) and h.frame == 2 and g.frame == 1 and g.n_landmarks == 0


def test_wrong_associations_lists_exactly_the_counted_ones_with_their_gates():
    # chapter 09 section 8: why JCBB's remaining wrong associations had no right answer to choose
    from slamlib.course.association_study import study_row, wrong_associations

    res = wrong_associations(2088, "jcbb")
    row = study_row(2088, "jcbb")
    assert len(res["wrong"]) == row["wrong"] > 0
    for w in res["wrong"]:
        assert w["label"] != w["marker"] and w["in_gate"] >= 1 and w["others"] >= 0
        assert 0.0 <= w["t"] <= 30.0
    lm = res["landmarks"]
    # every fused reading of a real marker sits in exactly one landmark's count, besides the births
    fused = sum(n for d in lm.values() for mk, n in d["readings"].items() if mk >= 0)
    births = sum(1 for d in lm.values() if d["origin"] is not None and d["origin"] >= 0)
    assert fused - births == row["fused"]
    assert len(lm) == row["landmarks"]
    # the gates recorded: with ids nothing is gated by association, so all zeros
    run = scenario("arena_loop", seed=2088, p_outlier=0.1)
    gates: list = []
    tr, tid = run_without_ids(run, make_filter(run, "ids"), max_time=2.0, gates=gates)
    assert len(gates) == len(tid) == len(tr.reports) and all(np.all(g == 0) for g in gates)


def test_solve_lower_is_the_inverse_of_a_lower_triangular_matrix():
    rng = np.random.default_rng(9)
    for m, k in [(1, 1), (2, 2), (6, 3), (12, 40)]:
        L = np.tril(rng.normal(size=(m, m))) + m * np.eye(m)
        B = rng.normal(size=(m, k))
        X = asc.solve_lower(L, B)
        np.testing.assert_allclose(L @ X, B, rtol=1e-12, atol=1e-12)
        assert not np.shares_memory(X, B)


@pytest.mark.parametrize("shape", [(7,), (3, 4)])
def test_individual_d2_is_y_S_inverse_y(shape):
    # one formula for the gate with ids (m readings) and every pair without (k x N)
    rng = np.random.default_rng(len(shape))
    y = rng.normal(size=shape + (2,))
    A = rng.normal(size=shape + (2, 2))
    S = A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(2)
    want = np.einsum("...i,...ij,...j->...", y, np.linalg.inv(S), y)
    np.testing.assert_allclose(asc.individual_d2(y, S), want, rtol=1e-12)


def test_individual_d2_refuses_vectors_that_are_not_2d():
    with pytest.raises(ValueError, match="y \\(..., 2\\)"):
        asc.individual_d2(np.ones((4, 3)), np.broadcast_to(np.eye(3), (4, 3, 3)))
