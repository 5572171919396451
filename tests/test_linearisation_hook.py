"""Where EKF SLAM linearises, one link at a time, through one hook (chapter 06; issue 23).

LinearisedEKFSLAM evaluates each link (motion, observation, initialisation, innovation)
at the estimate, the first estimate or the truth through one hook,
``EKFLocalization.jacobians``; FEJEKFSLAM and IdealEKFSLAM are its presets. Checked here:
the presets and the all-"estimate" filter give the same numbers as their definitions,
bit for bit; a one-factor variant changes its own link only (every other Jacobian the
same, bit for bit, at every call of a run); the options are checked.
"""

from __future__ import annotations

import numpy as np
import pytest

from slamlib import runner, sim
from slamlib.ekf import EKFSLAM, FEJEKFSLAM, IdealEKFSLAM, LinearisedEKFSLAM
from slamlib.models import inverse_observation_jacobians, observe_landmarks

T_END = 30.0


@pytest.fixture(scope="module")
def run():
    return sim.scenario("arena_loop", seed=1003, sigma_wheel=0.08)


def _truth(run) -> dict:
    return {"truth": runner.truth_function(run), "landmarks": run.world().landmarks(),
            "t0": float(run.enc_t[0])}


def _trace(run, cls, **kw):
    return runner.run_filter(run, runner.make_filter(cls, run, **kw), max_time=T_END)


def _same(a, b) -> None:
    """Two traces of the same run with the same numbers, bit for bit."""
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)
    assert np.array_equal(a.filter.x, b.filter.x) and np.array_equal(a.filter.P, b.filter.P)
    for (_, ra), (_, rb) in zip(a.reports, b.reports):
        assert ra.status == rb.status
        assert np.array_equal(ra.d2, rb.d2, equal_nan=True)


def test_all_estimate_is_ekf_slam_bit_for_bit(run):
    slam = _trace(run, EKFSLAM)
    _same(_trace(run, LinearisedEKFSLAM), slam)
    _same(_trace(run, LinearisedEKFSLAM, **_truth(run)), slam)   # the truth given, not used
    assert slam.counts()["accepted"] > 400


def test_fej_is_its_preset_bit_for_bit(run):
    _same(_trace(run, FEJEKFSLAM),
          _trace(run, LinearisedEKFSLAM, motion="first", observation="first"))


@pytest.mark.parametrize("innovation, landmark_init", [("truth", "estimate"),
                                                       ("estimate", "truth")])
def test_the_ideal_filter_is_its_preset_bit_for_bit(run, innovation, landmark_init):
    _same(_trace(run, IdealEKFSLAM, innovation=innovation, landmark_init=landmark_init,
                 **_truth(run)),
          _trace(run, LinearisedEKFSLAM, motion="truth", observation="truth",
                 initialisation=landmark_init, innovation=innovation, **_truth(run)))


def _links(hook_output: tuple, link: str) -> dict:
    """The hook's output, by the spec's links: the observation hook gives the predicted
    readings (the innovation link) and their Jacobians (the observation link)."""
    if link == "observation":
        return {"innovation": hook_output[:1], "observation": hook_output[1:]}
    return {link: hook_output}


@pytest.mark.parametrize("link, choice", [("initialisation", "truth"),
                                          ("observation", "first"), ("motion", "first"),
                                          ("motion", "truth"), ("observation", "truth"),
                                          ("innovation", "truth")])
def test_a_one_factor_variant_changes_its_own_link_only(run, link, choice):
    """At every call of the hook during a run, the variant's answer and EKF SLAM's answer at
    the variant's own state: equal bit for bit for the other links, different (somewhere)
    for this one."""
    f = runner.make_filter(LinearisedEKFSLAM, run, **{link: choice}, **_truth(run))
    differs = {"motion": 0, "observation": 0, "initialisation": 0, "innovation": 0}
    calls = dict.fromkeys(differs, 0)
    hook = f.jacobians

    def compare(name, **kw):
        base = _links(EKFSLAM.jacobians(f, name, **kw), name)     # at this state, estimate
        got = hook(name, **kw)
        for k, v in _links(got, name).items():
            calls[k] += 1
            same = all(np.array_equal(a, b, equal_nan=True) for a, b in zip(v, base[k]))
            differs[k] += not same
        return got

    f.jacobians = compare
    runner.run_filter(run, f, max_time=T_END)
    assert all(calls.values()), calls
    assert differs[link] > 0, differs
    assert all(n == 0 for k, n in differs.items() if k != link), differs


def test_a_landmark_not_in_the_true_map_is_linearised_at_the_estimate():
    truth = {"truth": lambda t: np.array([0.0, 0.0, 0.0]), "landmarks": {7: [2.0, 1.0]}}
    f = LinearisedEKFSLAM([0.05, -0.03, 0.04], np.diag([1e-3, 2e-3, 3e-3]), np.eye(2) * 1e-4,
                          np.diag([0.01, 1e-3]), motion="truth", observation="truth",
                          initialisation="truth", innovation="truth", **truth)
    z = np.array([[2.3, 0.41], [1.5, -0.7]])
    m, J1, J2 = f.jacobians("initialisation", ids=np.array([7, 8]), z=z)
    base = EKFSLAM.jacobians(f, "initialisation", ids=np.array([7, 8]), z=z)
    zt = observe_landmarks(np.zeros(3), np.array([[2.0, 1.0]]))[0][0]
    np.testing.assert_array_equal(J1[0], inverse_observation_jacobians(np.zeros(3), zt)[0])
    for a, b in zip((m, J1, J2), base):                 # id 8 is not in the true map
        np.testing.assert_array_equal(a[1], b[1])
        assert not np.array_equal(a[0], b[0])
    f.update([7, 8], z)
    got = f.jacobians("observation", ids=np.array([7, 8]))
    base = EKFSLAM.jacobians(f, "observation", ids=np.array([7, 8]))
    for a, b in zip(got, base):
        np.testing.assert_array_equal(a[1], b[1])
        assert not np.array_equal(a[0], b[0])


X = (np.zeros(3), np.eye(3) * 1e-4, np.eye(2) * 1e-4, np.eye(2) * 1e-3)


@pytest.mark.parametrize("kw, words", [
    ({"motion": "first-ish"}, r"motion: expected one of \('estimate', 'first', 'truth'\)"),
    ({"observation": 3}, "observation: expected one of"),
    ({"initialisation": "first"}, r"initialisation: expected one of \('estimate', 'truth'\)"),
    ({"innovation": "first"}, r"innovation: expected one of \('estimate', 'truth'\)"),
    ({"motion": "truth", "landmarks": {}}, "truth: "),
    ({"innovation": "truth", "truth": lambda t: np.zeros(3)}, "landmarks: "),
    ({"observation": "truth", "truth": "not callable", "landmarks": {}}, "truth: "),
    ({"t0": float("nan")}, "t0"),
])
def test_bad_options_name_the_option_and_the_allowed_values(kw, words):
    with pytest.raises(ValueError, match=words):
        LinearisedEKFSLAM(*X, **kw)


def test_the_choices_are_read_only_and_the_presets_say_what_they_are():
    f = FEJEKFSLAM(*X)
    assert (f.motion, f.observation, f.initialisation, f.innovation) == \
        ("first", "first", "estimate", "estimate")
    with pytest.raises(AttributeError):
        f.motion = "estimate"
    g = IdealEKFSLAM(*X, truth=lambda t: np.zeros(3), landmarks={})
    assert (g.motion, g.observation, g.initialisation, g.innovation) == \
        ("truth", "truth", "estimate", "truth")
    assert isinstance(f, EKFSLAM) and isinstance(g, LinearisedEKFSLAM)
