"""No silent non-finite state, parameters checked when set (issue 24, points 2 and 4).

A prediction or an update whose result is not finite (finite inputs that overflow) raises
a ValueError naming the argument and changes nothing; a run that leads there fails
instead of finishing with a non-finite P. The filters' parameters are checked when they
are set. No RuntimeWarning on the way (pytest turns slamlib's into errors).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from slamlib import runner
from slamlib.confirmation import ConfirmedSLAM
from slamlib.ekf import EKFSLAM, FEJEKFSLAM, EKFLocalization
from slamlib.runs import CameraRows, load_run, save_run

Q = np.diag([0.02, 0.02]) ** 2
R = np.diag([0.05, 0.03]) ** 2
MAP = {1: [2.0, 0.5], 2: [1.0, -1.0]}


def busy(cls=EKFSLAM):
    f = (cls([0.1, 0.2, 0.3], np.eye(3) * 1e-4, Q, R) if cls is not EKFLocalization else
         EKFLocalization([0.1, 0.2, 0.3], np.eye(3) * 1e-4, Q, R, MAP))
    for k in range(5):
        f.predict(np.array([0.2, 0.25]), 0.1)
        f.update([1, 2], [[1.8, 0.1 + 0.01 * k], [1.5, -1.0]])
    return f


def snapshot(f):
    lm = getattr(f, "landmark_ids", [])
    return f.x, f.P, list(lm), f.Q, f.R, f.wheel_base, f.gate


def assert_unchanged(f, before):
    for a, b in zip(snapshot(f), before):
        if isinstance(a, np.ndarray):
            assert np.array_equal(a, b)
        else:
            assert a == b


@pytest.mark.parametrize("cls", [EKFSLAM, EKFLocalization, FEJEKFSLAM, ConfirmedSLAM])
@pytest.mark.parametrize("u, dt, word", [([1e308, -1e308], 0.1, "u"), ([1e200, 1e200], 0.1, "u"),
                                         ([0.1, 0.1], 1e300, "dt"),
                                         ([1e155, 0.0], 1e155, "u, dt")])
def test_a_prediction_that_overflows_is_refused_and_changes_nothing(cls, u, dt, word):
    f = busy(cls)
    before = snapshot(f)
    with pytest.raises(ValueError, match=word):
        f.predict(u, dt)
    assert_unchanged(f, before)
    f.predict([0.2, 0.2], 0.1)                     # and the filter still works
    assert np.isfinite(f.P).all()


@pytest.mark.parametrize("ids, z", [([9], [[1e300, 0.1]]),                     # new only
                                    ([1, 9], [[1.8, 0.1], [1e300, 0.1]]),      # fused + new
                                    ([9, 10], [[2.0, 0.1], [1e300, 0.1]]),     # a second new
                                    ([1, 2], [[1e300, 0.1], [1.5, -1.0]])])    # gated out
def test_an_update_that_overflows_is_refused_and_changes_nothing(ids, z):
    f = busy()
    before = snapshot(f)
    if z[0][0] == 1e300 and ids[0] == 1:            # a mapped id read absurdly far: rejected
        rep = f.update(ids, z)
        assert rep.status[0] == "rejected" and np.isfinite(f.P).all()
        return
    with pytest.raises(ValueError, match="z"):
        f.update(ids, z)
    assert_unchanged(f, before)
    assert f.state_size == 7


def test_an_update_whose_correction_overflows_is_refused():
    f = EKFSLAM([0.0, 0.0, 0.0], np.eye(3) * 1e-4, Q, R, gate=None)
    f.update([1], [[2.0, 0.0]])
    before = snapshot(f)
    with pytest.raises(ValueError, match="z"):      # gate None: fused, x would become inf
        f.update([1], [[1.7e308, 0.0]])
    assert_unchanged(f, before)


def test_a_run_that_leads_to_a_non_finite_state_fails(tmp_path):
    """A run file whose first reading of a marker has range 1e300: runner.slam raises (it
    used to complete with a non-finite filter.P and normal-looking metrics): the sensor's
    R of that range is not finite (refused, naming R) and, given a finite R, the new
    landmark would not be (refused, naming z)."""
    run = load_run("arena_loop")
    rho = run.camera.rho.copy()
    first = int(np.flatnonzero(run.camera.id == run.camera.id[0])[0])
    rho[first] = 1e300
    bad = dataclasses.replace(run, camera=CameraRows(**{**vars(run.camera), "rho": rho}))
    save_run(bad, tmp_path / "bad")
    with pytest.raises(ValueError, match=r"R\[0\]"):
        runner.slam(load_run(tmp_path / "bad"))
    with pytest.raises(ValueError, match="z"):
        runner.slam(load_run(tmp_path / "bad"), use_sensor_R=False)


@pytest.mark.parametrize("name, value, word", [
    ("Q", np.full((2, 2), np.nan), "Q"), ("Q", -np.eye(2), "Q"), ("Q", np.eye(3), "Q"),
    ("R", np.full((2, 2), np.nan), "R"), ("R", np.diag([1.0, -1.0]), "R"),
    ("wheel_base", 0.0, "wheel_base"), ("wheel_base", np.nan, "wheel_base"),
    ("gate", 1.5, "gate"), ("gate", np.nan, "gate"), ("new_gate", None, "new_gate"),
    ("max_nodes", 0, "max_nodes"), ("max_nodes", 2.5, "max_nodes"),
])
@pytest.mark.parametrize("cls", [EKFSLAM, EKFLocalization])
def test_parameters_are_checked_when_set(cls, name, value, word):
    f = busy(cls)
    before = snapshot(f)
    old = getattr(f, name)
    with pytest.raises(ValueError, match=word):
        setattr(f, name, value)
    assert_unchanged(f, before)
    assert np.array_equal(getattr(f, name), old)
    f.predict([0.2, 0.2], 0.1)
    assert np.isfinite(f.P).all()


def test_parameters_cannot_be_changed_behind_the_check():
    f = busy()
    with pytest.raises(ValueError, match="read-only"):
        f.Q[0, 0] = np.nan
    with pytest.raises(AttributeError):
        f.association = "nn"
    f.Q = np.eye(2) * 1e-3                          # a checked value is taken
    assert np.array_equal(f.Q, np.eye(2) * 1e-3)
