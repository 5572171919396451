"""The library's unchecked paths give the public functions' numbers bit for bit, and the
public functions still check their input (issue 9, point 1)."""

from __future__ import annotations

import numpy as np
import pytest

from slamlib import sim, studies
from slamlib.ekf import EKFSLAM
from slamlib.models import wrap, wrap_angle
from slamlib.runs import PredictEvent, UpdateEvent
from slamlib.sensors import AnalyticMarkerSensor


def _reference_wrap(a):
    """wrap_angle as it was written before the fast paths (np.mod, then the 2 pi fix)."""
    w = np.mod(np.asarray(a, dtype=float) + np.pi, 2.0 * np.pi) - np.pi
    return np.where(w >= np.pi, w - 2.0 * np.pi, w)


def test_the_wrap_of_floats_and_of_arrays_equals_the_reference_bit_for_bit():
    rng = np.random.default_rng(3)
    k = np.arange(-40, 41) * np.pi
    v = np.concatenate([rng.normal(0, 1, 20000), rng.normal(0, 1e3, 20000),
                        rng.uniform(-1e-14, 1e-14, 2000), k, np.nextafter(k, 0.0),
                        np.nextafter(k, np.inf), [0.0, -0.0, 5e-324, -5e-324, 1e12]])
    ref = _reference_wrap(v).view(np.int64)
    assert np.array_equal(np.array([wrap(float(a)) for a in v]).view(np.int64), ref)
    assert np.array_equal(np.array([wrap_angle(a) for a in v]).view(np.int64), ref)
    assert np.array_equal(wrap(v).view(np.int64), ref)
    assert np.array_equal(wrap_angle(v).view(np.int64), ref)
    with pytest.raises(ValueError, match="angle"):
        wrap_angle(float("nan"))
    with pytest.raises(ValueError, match="angle"):
        wrap_angle(np.float64("inf"))


@pytest.mark.parametrize("u, dt, name", [([0.1, np.nan], 0.02, "u"), ([0.1, 0.2, 0.3], 0.02, "u"),
                                         ([0.1, 0.2], -0.02, "dt"), ([0.1, 0.2], np.inf, "dt"),
                                         (np.array([0.1, np.inf]), 0.02, "u")])
def test_predict_still_checks_its_input(u, dt, name):
    f = EKFSLAM([0, 0, 0], np.eye(3) * 1e-4, np.eye(2) * 1e-4, np.eye(2) * 1e-3)
    x, P = f.x, f.P
    with pytest.raises(ValueError, match=name):
        f.predict(u, dt)
    assert np.array_equal(f.x, x) and np.array_equal(f.P, P)


def test_predict_fast_check_path_matches_the_general_one():
    a = EKFSLAM([1, 2, 0.3], np.eye(3) * 1e-4, np.eye(2) * 1e-4, np.eye(2) * 1e-3)
    b = EKFSLAM([1, 2, 0.3], np.eye(3) * 1e-4, np.eye(2) * 1e-4, np.eye(2) * 1e-3)
    for k in range(50):
        u = np.array([0.2 + 0.01 * k, 0.25])
        a.predict(u, 0.02)                      # float64 array and float: the fast check
        b.predict([float(u[0]), float(u[1])], np.float64(0.02))   # the general one
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)


def test_sensor_R_batch_equals_R():
    s = AnalyticMarkerSensor()
    rho = np.array([0.0, 0.3, 1.7, 3.9, 12.0])
    assert np.array_equal(s.R_batch(rho), np.stack([s.R(r) for r in rho]))
    with pytest.raises(ValueError, match="rho"):
        s.R_batch([1.0, np.nan])


def _reference_events(run, by):
    """The events as Run.events produced them before: one list, sorted on (t, kind, index)."""
    u, dt = run.controls()
    items = [(float(run.enc_t[k]), 0, k, ("predict", k, u[k - 1], float(dt[k - 1])))
             for k in range(1, run.enc_t.size)]
    for j, f in enumerate(run.frames()):
        t = f.t if by == "capture" else float(f.t_arrival)
        items.append((t, 1, j, ("update", f)))
    items.sort(key=lambda e: (e[0], e[1], e[2]))
    return [(t, e) for t, _, _, e in items]


def test_events_are_in_the_same_order_as_a_plain_sort():
    run = sim.scenario("arena_loop", seed=5, latency=0.13)
    for by in ("capture", "arrival"):
        ref = _reference_events(run, by)
        got = list(run.events(by=by))
        assert len(ref) == len(got)
        for (t, e), ev in zip(ref, got):
            assert ev.t == t
            if e[0] == "predict":
                assert isinstance(ev, PredictEvent) and ev.k == e[1]
                assert np.array_equal(ev.u, e[2]) and ev.dt == e[3]
            else:
                assert isinstance(ev, UpdateEvent) and ev.obs.t == e[1].t
                assert np.array_equal(ev.obs.z, e[1].z)


def test_monte_carlo_same_numbers_with_one_and_two_workers():
    kw = dict(seeds=range(40, 44), step=1.0)
    one = studies.monte_carlo("arena_loop", ("slam", "localization"), workers=1, **kw)
    two = studies.monte_carlo("arena_loop", ("slam", "localization"), workers=2, **kw)
    for m in one:
        assert np.array_equal(one[m].t, two[m].t)
        assert np.array_equal(one[m].nees, two[m].nees)
        assert np.array_equal(one[m].nees_heading, two[m].nees_heading)
        assert np.array_equal(one[m].ate, two[m].ate)
    assert [r.d2 for r in one["slam"].reobservations] == \
        [r.d2 for r in two["slam"].reobservations]
    with pytest.raises(ValueError, match="workers"):
        studies.monte_carlo("arena_loop", ("slam",), seeds=(1,), workers=0)


def test_a_run_with_a_bad_reading_is_refused_when_made():
    """The runners give a run's readings to the filter unchecked: CameraRows checks them once."""
    from slamlib.runs import CameraRows

    good = dict(t_capture=[0.1, 0.1], t_arrival=[0.1, 0.1], id=[1, 2], rho=[1.0, 2.0],
                bearing=[0.1, -0.1], true_id=[1, 2], true_rho=[1.0, 2.0],
                true_bearing=[0.1, -0.1])
    CameraRows(**good)
    with pytest.raises(ValueError, match="finite"):
        CameraRows(**{**good, "rho": [1.0, np.nan]})
    with pytest.raises(ValueError, match="ranges >= 0"):
        CameraRows(**{**good, "rho": [1.0, -0.5]})


@pytest.mark.parametrize("faults", [{}, {"p_misread": 0.2, "p_outlier": 0.3}])
def test_frames_read_at_the_end_equal_frames_read_one_by_one(faults):
    """simulate() reads the analytic sensor's frames all at once at the end; a KobukiSim that
    reads each frame when it is captured gives the same run, bit for bit."""
    from dataclasses import replace

    from slamlib.sim import KobukiSim, WaypointController, arena_loop_waypoints, simulate
    from slamlib.worlds import load_world

    world = load_world("report_arena")
    sensor = AnalyticMarkerSensor(**faults)
    ctl = WaypointController(arena_loop_waypoints())
    run = simulate(world, ctl, sensor=sensor, seed=9, max_duration=20.0)
    s = KobukiSim(world, sensor=sensor, seed=9)
    c = replace(ctl)
    c.reset()
    while s.k < 20.0 * s.params.encoder_rate and not c.done:
        s.step(*c.command(s.pose, s.params.dt, s.params.wheel_base))
    one_by_one = s.record()
    assert len(run.camera) > 50
    for name in ("t_capture", "t_arrival", "id", "rho", "bearing", "true_id", "true_rho",
                 "true_bearing"):
        np.testing.assert_array_equal(getattr(run.camera, name), getattr(one_by_one.camera, name))
    np.testing.assert_array_equal(run.truth, one_by_one.truth)
