"""Chapter 11's course machinery: the exercise checker and the stored 100-seed study."""

import numpy as np
import pytest

from slamlib.course import checkers_ch11, graph_study
from slamlib.graph import pose_cov_to_gtsam


def test_checker_accepts_the_library_and_names_each_mistake(capsys):
    assert checkers_ch11.check_pose_cov_to_gtsam(pose_cov_to_gtsam)
    M = np.diag([1.0, -1.0, -1.0])

    def G(th):
        c, s = np.cos(th), np.sin(th)
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    wrong = {"did not rotate": lambda p, P: M @ P @ M,
             "wrong way": lambda p, P: M @ G(p[2]) @ P @ G(p[2]).T @ M,
             "mirror is missing": lambda p, P: G(p[2]).T @ P @ G(p[2]),
             "unchanged": lambda p, P: P,
             "entry": lambda p, P: pose_cov_to_gtsam(p, P) + 1e-3}
    for hint, fn in wrong.items():
        capsys.readouterr()
        assert not checkers_ch11.check_pose_cov_to_gtsam(fn)
        assert hint in capsys.readouterr().out

    def stub(pose, P):
        raise NotImplementedError

    assert not checkers_ch11.check_pose_cov_to_gtsam(stub)
    assert "not written yet" in capsys.readouterr().out


def _turn(P, L):
    # the whole estimate turned about the origin: d/da of R(a) p is (-y, x), every heading +1
    return np.concatenate([np.column_stack([-P[:, 1], P[:, 0], np.ones(len(P))]).ravel(),
                           np.column_stack([-L[:, 1], L[:, 0]]).ravel()])


def test_rotation_checker_accepts_any_rigid_turn_and_names_each_mistake(capsys):
    assert checkers_ch11.check_rotation_direction(_turn)
    out = capsys.readouterr().out
    assert "(unobservable)" in out and "looks observed" in out

    def about_another_point(P, L):                  # a turn about (1, -2), scaled by 3
        v = _turn(P, L)
        n = len(P)
        v[0:3 * n:3] += 2.0
        v[1:3 * n:3] += 1.0
        v[3 * n::2] += 2.0
        v[3 * n + 1::2] += 1.0
        return 3.0 * v

    assert checkers_ch11.check_rotation_direction(about_another_point)
    n_pose = lambda P: len(P)                       # noqa: E731
    wrong = {
        "landmarks do not move": lambda P, L: np.concatenate(
            [_turn(P, L)[:3 * n_pose(P)], np.zeros(2 * len(L))]),
        "other way": lambda P, L: np.concatenate(
            [np.column_stack([P[:, 1], -P[:, 0], np.ones(len(P))]).ravel(),
             np.column_stack([L[:, 1], -L[:, 0]]).ravel()]),
        "heading component is zero": lambda P, L: np.concatenate(
            [np.tile([1.0, 0.0, 0.0], len(P)), np.tile([1.0, 0.0], len(L))]),
        "heading components differ": lambda P, L: _turn(P, L) * np.r_[np.arange(1, 3 * len(P) + 1),
                                                            np.ones(2 * len(L))],
        "factors see this direction": lambda P, L: _turn(P, L) + np.r_[
            np.zeros(3 * len(P)), 0.3, np.zeros(2 * len(L) - 1)],
        "expected a vector": lambda P, L: np.zeros(3),
    }
    for hint, fn in wrong.items():
        capsys.readouterr()
        assert not checkers_ch11.check_rotation_direction(fn), hint
        assert hint in capsys.readouterr().out


def test_jacobian_along_a_turn_vanishes_only_at_one_point():
    # an independent check of the lesson: the finite-difference J v against the closed form
    rng = np.random.default_rng(0)
    P = np.column_stack([rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3), rng.uniform(-3, 3, 3)])
    L = rng.uniform(-4, 4, (2, 2))
    v = _turn(P, L)
    assert np.max(np.abs(checkers_ch11.jacobian_along(P, L, v))) < 1e-7
    offsets = rng.normal(0.0, 0.03, (3, 2, 2))
    assert np.max(np.abs(checkers_ch11.jacobian_along(P, L, v, offsets))) > 1e-3
    shift = np.r_[np.tile([1.0, 0.0, 0.0], 3), np.tile([1.0, 0.0], 2)]
    assert np.max(np.abs(checkers_ch11.jacobian_along(P, L, shift, offsets))) < 1e-7
    # a range's derivative along a pure move of one landmark: d|l - p| = u . dl
    dl = np.r_[np.zeros(9), 1.0, 0.0, 0.0, 0.0]
    Jv = checkers_ch11.jacobian_along(P, L, dl)
    d = L[0] - P[0, :2]
    assert np.isclose(Jv[6], d[0] / np.hypot(*d), atol=1e-8)


@pytest.fixture(scope="module")
def stored():
    return graph_study.load()


def test_stored_study_has_every_seed(stored):
    assert stored.seeds == graph_study.SEEDS and len(stored.seeds) >= 100
    np.testing.assert_array_equal(stored.grid, graph_study.GRID)
    for c in graph_study.CASES:
        assert [r["seed"] for r in stored.runs(c)] == list(graph_study.SEEDS)
        assert stored.sigma_wheel(c) == graph_study.CASES[c]


@pytest.mark.parametrize("case,index", [("nominal", 0), ("high_slip", -1)])
def test_stored_study_is_what_the_code_computes(stored, case, index):
    # a sample of the 200 runs recomputed now: a change in the simulator, the EKF or the
    # smoother that changes the numbers needs `make graph-study`
    row = stored.runs(case)[index]
    fresh = graph_study.run_seed(case, row["seed"])
    for est in graph_study.ESTIMATES:
        for key, v in row[est].items():
            np.testing.assert_allclose(fresh[est][key], v, rtol=2e-5, atol=1e-12,
                                       err_msg=f"{case} seed {row['seed']} {est} {key}")


def test_save_and_load_round_trip(tmp_path, stored):
    small = {**stored.data, "cases": {c: {**d, "runs": d["runs"][:3]}
                                      for c, d in stored.data["cases"].items()}}
    graph_study.save(small, tmp_path / "s.json")
    back = graph_study.load(tmp_path / "s.json")
    assert back.data == small
    with pytest.raises(ValueError, match="format"):
        graph_study.Study({"format": "other"})


def test_spread_names_the_seeds_that_dominate(stored):
    v = np.array([1.0, 2.0, 30.0, 3.0, 2.0])
    s = graph_study.spread(v, [10, 11, 12, 13, 14])
    assert s.top == ((12, 30.0), (13, 3.0), (11, 2.0))
    assert s.mean == pytest.approx(7.6) and s.median == 2.0
    assert s.mean_without_top == pytest.approx(2.0)
    assert s.se == pytest.approx(np.std(v, ddof=1) / np.sqrt(5))
    with pytest.raises(ValueError, match="seeds"):
        graph_study.spread(v, [1, 2])
    # a paired spread is the spread of the seed-by-seed difference
    d = stored.spread("nominal", "ekf", minus="ekf_ungated")
    diff = stored.values("nominal", "ekf", "mean_nees") - \
        stored.values("nominal", "ekf_ungated", "mean_nees")
    assert d.mean == pytest.approx(diff.mean()) and d.median == pytest.approx(np.median(diff))
