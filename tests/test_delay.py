"""Tests of slamlib.delay: late camera frames fused at their capture time (chapter 08).

The reference everywhere is the plain filter driven by runner.run_filter
with frames delivered at their capture time (a camera without delay), which
does not use slamlib.delay at all.
"""

import math

import numpy as np
import pytest

from slamlib import runner, sim
from slamlib.delay import (
    DelayedEKF,
    compensate_readings,
    history_index,
    late_reading_error,
    latency_study,
    make_filter,
    run_compensated,
    run_delayed,
)
from slamlib.models import observe
from slamlib.runs import CameraRows, Run


@pytest.fixture(scope="module")
def late_run():
    return sim.scenario("arena_loop", latency=0.3)


@pytest.fixture(scope="module")
def off_tick_run():
    # 7 frames per second: capture times fall between encoder times
    return sim.scenario("arena_loop", latency=0.23, rate=7.0, seed=3)


def _assert_traces_equal(a, b, tol=1e-9):
    assert np.array_equal(a.t, b.t)
    assert list(a.kind) == list(b.kind)
    assert np.max(np.abs(a.x - b.x)) <= tol
    assert np.max(np.abs(a.P - b.P)) <= tol


def _assert_filters_equal(f, g, tol=1e-9):
    assert f.state_size == g.state_size
    assert np.max(np.abs(f.x - g.x)) <= tol
    assert np.max(np.abs(f.P - g.P)) <= tol
    assert list(f.landmark_ids) == list(g.landmark_ids)


# --------------------------------------------------------------------------- the main property
@pytest.mark.parametrize("kind", ["slam", "localization"])
def test_zero_latency_wrapper_equals_plain_filter(kind):
    run = sim.scenario("arena_loop", latency=0.0)
    plain = runner.run_filter(run, make_filter(run, kind), by="arrival")
    d = run_delayed(run, make_filter(run, kind))
    assert d.wrapper.replays == 0
    _assert_traces_equal(d.realtime, plain, tol=0.0)
    _assert_traces_equal(d.settled, plain, tol=0.0)
    _assert_filters_equal(d.wrapper.filter, plain.filter, tol=0.0)


@pytest.mark.parametrize("kind", ["slam", "localization"])
@pytest.mark.parametrize("which", ["late_run", "off_tick_run"])
def test_late_frames_by_arrival_equal_plain_filter_by_capture(kind, which, request):
    run = request.getfixturevalue(which)
    ref = runner.run_filter(run, make_filter(run, kind), by="capture")
    d = run_delayed(run, make_filter(run, kind), max_delay=1.0, by="arrival")
    assert d.statuses() == {"fused": len(ref.reports)}
    assert d.wrapper.replays > 0                      # it really went back in time
    _assert_traces_equal(d.settled, ref)
    _assert_filters_equal(d.wrapper.filter, ref.filter)
    # the same decisions at every frame
    assert [r.status for _, r in d.settled.reports] == [r.status for _, r in ref.reports]
    # and the estimate known in real time is not the settled one (the frames were late)
    assert np.max(np.abs(d.realtime.x[-1] - ref.x[-1])) <= 1e-9
    assert d.realtime.t.size == ref.t.size


def test_naive_filter_differs_and_fixed_does_not(late_run):
    ref = runner.run_filter(late_run, make_filter(late_run, "localization"), by="capture")
    naive = runner.run_filter(late_run, make_filter(late_run, "localization"), by="arrival")
    fixed = run_delayed(late_run, make_filter(late_run, "localization")).realtime
    a_ref, a_naive, a_fixed = (tr.metrics()["ate_xy"] for tr in (ref, naive, fixed))
    assert a_naive > 4 * a_ref                     # 0.3 s late frames hurt the naive filter
    assert a_fixed < 1.5 * a_ref                   # the fix is as good as no delay, nearly


def test_out_of_order_arrivals_are_put_back_in_order(late_run):
    # jittered latencies: frames overtake each other
    rng = np.random.default_rng(7)
    c = late_run.camera
    frames = late_run.frames()
    lat = rng.uniform(0.0, 0.45, size=len(frames))
    per_row = np.concatenate([np.full(len(f), la) for f, la in zip(frames, lat)])
    cam = CameraRows(c.t_capture, c.t_capture + per_row, c.id, c.rho, c.bearing, c.true_id,
                     c.true_rho, c.true_bearing)
    run = Run(late_run.name, late_run.truth_t, late_run.truth, late_run.enc_t, late_run.ticks_R,
              late_run.ticks_L, cam, late_run.meta)
    arrivals = [ev.obs.t for ev in run.events(by="arrival") if ev.kind == "update"]
    assert np.any(np.diff(arrivals) < 0)           # some frames really arrive out of order
    ref = runner.run_filter(run, make_filter(run, "slam"), by="capture")
    d = run_delayed(run, make_filter(run, "slam"), max_delay=0.5)
    _assert_traces_equal(d.settled, ref)
    _assert_filters_equal(d.wrapper.filter, ref.filter)


# --------------------------------------------------------------------------- bounded history
def test_frames_older_than_max_delay_are_rejected(late_run):
    d = run_delayed(late_run, make_filter(late_run, "slam"), max_delay=0.25)
    for u in d.updates:
        assert u.status == ("too_old" if u.delay > 0.25 else "fused")
        assert (u.report is None) == (u.status == "too_old")
    # every frame is 0.3 s late, except the last two, which arrive after the encoders stop
    # (the filter's clock stays at the last prediction, 0.1 and 0.2 s after their capture)
    assert d.statuses() == {"too_old": len(d.updates) - 2, "fused": 2}
    # so the map was made from the last two frames only, at the end of a dead-reckoned drive
    dr = runner.dead_reckoning(late_run)
    before = d.realtime.x[d.realtime.t <= late_run.enc_t[-1] - 0.3]
    assert np.allclose(before[-1], dr.x[dr.t <= late_run.enc_t[-1] - 0.3][-1], atol=1e-12)


def test_history_is_bounded_and_boundary_delay_is_fused():
    run = sim.scenario("arena_loop", latency=0.3)
    filt = make_filter(run, "localization")
    w = DelayedEKF(filt, max_delay=0.3)
    longest = 0
    statuses = set()
    for ev in run.events(by="arrival"):
        if ev.kind == "predict":
            w.predict(ev.u, ev.dt, ev.t)
        elif len(ev.obs):
            statuses.add(w.update(ev.obs.ids, ev.obs.z, t_capture=ev.obs.t).status)
        longest = max(longest, w.history_length)
    # 50 Hz encoders and 10 Hz frames over 0.3 s, plus the events at the window's edge
    assert longest <= 0.3 * 60 + 3
    assert statuses == {"fused"}                      # a delay of exactly max_delay is fine
    assert w.history_start >= w.t - 0.3 - 0.02 - 1e-9


def test_future_frame_is_not_fused():
    f = make_filter(sim.scenario("arena_loop", latency=0.0), "localization")
    w = DelayedEKF(f, max_delay=1.0)
    w.predict([0.1, 0.1], 0.02, 0.02)
    x, P = w.x, w.P
    res = w.update([0], [[2.0, 0.1]], t_capture=0.05)
    assert res.status == "future" and res.report is None
    assert np.array_equal(w.x, x) and np.array_equal(w.P, P)


def test_empty_frame():
    f = make_filter(sim.scenario("arena_loop", latency=0.0), "slam")
    w = DelayedEKF(f)
    assert w.update([], np.zeros((0, 2)), t_capture=0.0).status == "empty"
    assert w.history_length == 0


# --------------------------------------------------------------------------- bad input
def test_bad_input_errors_and_nothing_changes():
    run = sim.scenario("arena_loop", latency=0.0)
    with pytest.raises(ValueError, match="max_delay"):
        DelayedEKF(make_filter(run, "slam"), max_delay=0.0)
    with pytest.raises(ValueError, match="max_delay"):
        DelayedEKF(make_filter(run, "slam"), max_delay=float("nan"))
    with pytest.raises(ValueError, match="filt"):
        DelayedEKF(object())
    with pytest.raises(ValueError, match="t0"):
        DelayedEKF(make_filter(run, "slam"), t0=float("inf"))
    w = DelayedEKF(make_filter(run, "slam"), max_delay=1.0)
    for k in range(1, 11):
        w.predict([0.2, 0.25], 0.02, 0.02 * k)
    w.update([0, 1], [[1.0, 0.2], [2.0, -0.3]], t_capture=0.1)
    x, P, n = w.x, w.P, w.history_length
    with pytest.raises(ValueError, match="t_capture"):
        w.update([0], [[1.0, 0.1]], t_capture=float("nan"))
    with pytest.raises(ValueError, match="z"):                  # late frame, bad shape
        w.update([0], [[1.0, 0.1, 3.0]], t_capture=0.05)
    with pytest.raises(ValueError, match="z"):                  # late frame, NaN reading
        w.update([0], [[np.nan, 0.1]], t_capture=0.05)
    with pytest.raises(ValueError, match="ids"):
        w.update([[0]], [[1.0, 0.1]], t_capture=0.2)
    with pytest.raises(ValueError, match="t:"):
        w.predict([0.2, 0.2], 0.02, 0.1)                        # back in time
    with pytest.raises(ValueError, match="u"):
        w.predict([0.2, np.nan], 0.02, 0.3)
    assert np.array_equal(w.x, x) and np.array_equal(w.P, P) and w.history_length == n
    with pytest.raises(ValueError, match="record"):
        w.settled()


def test_latency_study_rejects_bad_arguments():
    with pytest.raises(ValueError, match="methods"):
        latency_study((0.1,), methods=("magic",))
    with pytest.raises(ValueError, match="latencies"):
        latency_study((-0.1,))
    with pytest.raises(ValueError, match="kind"):
        make_filter(sim.scenario("arena_loop", latency=0.0), "mapping")


# --------------------------------------------------------------------------- pieces
def test_history_index():
    times = [0.0, 0.02, 0.04, 0.04, 0.06]
    assert history_index(times, -1.0) == 0
    assert history_index(times, 0.0) == 1           # after the event at the same instant
    assert history_index(times, 0.03) == 2
    assert history_index(times, 0.04) == 4          # after both events at 0.04
    assert history_index(times, 0.07) == 5
    assert history_index([], 1.0) == 0


def test_late_reading_error_matches_geometry():
    # a robot moving along an arc, a marker: the reading then minus the reading now
    from slamlib.sim import integrate_arc

    rng = np.random.default_rng(3)
    for _ in range(20):
        v, w = rng.uniform(0.0, 0.3), rng.uniform(-0.7, 0.7)
        pose0 = np.array([rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-3, 3)])
        lm = pose0[:2] + rng.uniform(1.0, 3.0) * np.array([np.cos(a := rng.uniform(-3, 3)),
                                                           np.sin(a)])
        delay = 1e-3
        z_then = observe(pose0, lm)
        z_now = observe(integrate_arc(pose0, v, w, delay), lm)
        d = np.array([z_then[0] - z_now[0], math.remainder(z_then[1] - z_now[1], 2 * math.pi)])
        got = np.array(late_reading_error(v, w, z_then[0], z_then[1], delay))
        assert np.allclose(got, d, rtol=1e-2, atol=1e-6)   # second order: v w delay^2 ~ 1e-7


def test_compensate_readings_is_exact_with_exact_poses():
    rng = np.random.default_rng(4)
    a = np.array([1.0, -0.5, 0.4])
    b = np.array([1.3, -0.2, 0.9])
    lms = rng.uniform(-3, 3, size=(5, 2))
    z_a = np.array([observe(a, m) for m in lms])
    got = compensate_readings(z_a, a, b)
    want = np.array([observe(b, m) for m in lms])
    assert np.allclose(got, want, atol=1e-12)
    # a shifted origin does not matter: only the relative motion does
    shift = np.array([0.7, -1.1])
    got2 = compensate_readings(z_a, a + np.r_[shift, 0.0], b + np.r_[shift, 0.0])
    assert np.allclose(got2, want, atol=1e-12)


def test_run_compensated_is_close_to_the_fix(late_run):
    world = late_run.world()
    comp = run_compensated(late_run, make_filter(late_run, "slam"))
    ref = runner.run_filter(late_run, make_filter(late_run, "slam"), by="capture")
    naive = runner.run_filter(late_run, make_filter(late_run, "slam"), by="arrival")
    m_c, m_r, m_n = comp.metrics(world), ref.metrics(world), naive.metrics(world)
    assert m_c["map_rmse"] < 2 * m_r["map_rmse"] < m_n["map_rmse"]
    assert m_c["ate_xy"] < 2 * m_r["ate_xy"]


def test_latency_study_cache_is_used_and_filled(monkeypatch):
    import slamlib.delay as d

    plain = latency_study((0.1,), kind="localization", methods=("naive", "compensated"))
    cache = {}
    first = latency_study((0.1,), kind="localization", methods=("naive", "compensated"),
                          cache=cache)
    assert first == plain
    assert set(cache) == {(0.1, "naive", "localization"), (0.1, "compensated", "localization")}

    def boom(*args, **kwargs):
        raise AssertionError("recomputed a cached trace")

    monkeypatch.setattr(d, "run_method", boom)
    again = latency_study((0.1,), kind="localization", methods=("naive", "compensated"),
                          cache=cache)
    assert again == plain
    # the naive filter at 0.1 s is already worse than the compensated one
    assert plain[0]["ate_xy"] > 2 * plain[1]["ate_xy"]


class _DensityRun:
    """``late_run`` whose noise is a density, as a real log's (chapter 10): each step's Q is
    ``Q_c / dt`` (:meth:`Run.Q_steps`), with ``Q_c`` a hundredth of a second's nominal Q."""

    def __init__(self, run):
        self._run = run

    def __getattr__(self, name):
        return getattr(self._run, name)

    def Q_steps(self, dt):
        dt = np.asarray(dt, dtype=float)
        return (0.01 * self._run.Q())[None] * (0.02 / dt)[:, None, None]


def test_late_frames_on_a_density_log_equal_plain_filter_by_capture(late_run):
    """The wrapper gives each step the run's own Q, as runner.run_filter does: the settled
    trace of a density log is still the plain filter's by capture time (and differs from
    the same run with the filter's fixed Q)."""
    run = _DensityRun(late_run)
    ref = runner.run_filter(run, make_filter(run, "slam"), by="capture")
    fixed_Q = runner.run_filter(late_run, make_filter(late_run, "slam"), by="capture")
    d = run_delayed(run, make_filter(run, "slam"), max_delay=1.0, by="arrival")
    _assert_traces_equal(d.settled, ref)
    assert np.max(np.abs(ref.P - fixed_Q.P)) > 1e-6
