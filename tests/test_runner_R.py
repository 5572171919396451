"""The filter runners never fall back silently to a default reading noise (issue 9, point 7)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from slamlib import runner, sim
from slamlib.vision import NoiseModel


@pytest.fixture(scope="module")
def run():
    return sim.scenario("arena_loop", seed=2)


def _with_sensor(run, meta_sensor):
    r = copy.copy(run)
    r.meta = {**run.meta, "sensor": meta_sensor}
    return r


def _delayed_slam(run):
    from slamlib import delay
    return delay.make_filter(run, "slam")


def _confirmed(run):
    from slamlib.confirmation import confirmed_slam
    return confirmed_slam(run)


@pytest.mark.parametrize("run_with", [runner.slam, runner.localization, runner.fej_slam,
                                      _delayed_slam, _confirmed])
def test_unknown_sensor_with_readings_raises_saying_what_to_pass(run, run_with):
    r = _with_sensor(run, {"type": "SomeoneElsesSensor"})
    with pytest.raises(ValueError, match=r"R: run .*SomeoneElsesSensor.*pass R="):
        run_with(r)


def test_unknown_sensor_with_an_explicit_R_runs_and_uses_it(run):
    r = _with_sensor(run, {"type": "SomeoneElsesSensor"})
    R = np.diag([0.03, 0.01]) ** 2
    tr = runner.slam(r, R=R)
    assert np.array_equal(tr.filter.R, R)
    assert np.array_equal(runner.slam(run, R=R).x, tr.x)   # the same as the analytic run with R


def test_camera_runs_take_the_noise_model_they_were_recorded_with(run):
    nm = {"bias_coef": 0.004, "bias_coef3": 0.0, "sigma_range_a": 0.004,
          "sigma_range_b": 0.002, "sigma_bearing": 0.0005, "corrected": True}
    r = _with_sensor(run, {"type": "CameraMarkerSensor", "noise_model": nm})
    model = NoiseModel(**nm)
    assert np.array_equal(runner.default_R(r), model.R(2.0))
    tr = runner.run_filter(r, runner.make_filter(runner.EKFSLAM, r), until=20.0)
    p = tr.pending
    assert np.array_equal(p.R, np.stack([model.R(rho) for rho in p.obs.z[:, 0]]))


def test_dead_reckoning_and_runs_without_readings_need_nodefault_R(run):
    r = _with_sensor(run, {"type": "SomeoneElsesSensor"})
    assert np.array_equal(runner.dead_reckoning(r).x, runner.dead_reckoning(run).x)
    quiet = sim.scenario("arena_loop", seed=2, max_range=0.21, min_range=0.2)
    quiet = _with_sensor(quiet, {})
    assert len(quiet.camera) == 0
    assert runner.slam(quiet).filter.n_landmarks == 0


def test_the_filter_checks_the_R_the_runner_gives(run):
    """A sensor whose range sigma can be zero gives a zero variance: the update refuses it."""
    from slamlib.sensors import AnalyticMarkerSensor

    flat = AnalyticMarkerSensor(sigma_range0=0.0, sigma_range_per_m=0.0)
    r = sim.scenario("arena_loop", seed=2, sensor=flat)
    filt = runner.make_filter(runner.EKFSLAM, r, R=np.diag([1e-4, 1e-4]))     # a valid default R
    with pytest.raises(ValueError, match=r"R\[0\]"):              # the frame's own R: zero
        runner.run_filter(r, filt)
