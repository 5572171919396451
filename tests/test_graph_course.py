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
