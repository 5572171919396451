"""slamlib.studies against independent computations (chapter 06).

- the Monte-Carlo average of NEES samples drawn from a known Gaussian is its
  degrees of freedom, inside the chi-square band (a linear-Gaussian toy);
- sampling a trace on a time grid picks the state after the last event;
- the NEES study and the density sweep return what a hand-made run gives;
- the loop-closure finder and the landmark placement agree with the filter.
"""

import numpy as np
import pytest

from slamlib import runner, studies
from slamlib.course import studies_ch06
from slamlib.metrics import chi2_band
from slamlib.models import wrap_angle
from slamlib.sensors import AnalyticMarkerSensor
from slamlib.sim import KobukiParams, WaypointController, loop_waypoints, scenario, simulate
from slamlib.worlds import random_world


def _toy_trace(rng, T=200, scale=1.0):
    """A trace whose errors are drawn from N(0, scale * P): a linear-Gaussian toy."""
    t = np.arange(T) * 0.1
    A = rng.normal(size=(T, 3, 3)) * 0.1
    P = A @ np.transpose(A, (0, 2, 1)) + np.diag([1e-3, 2e-3, 1e-4])
    truth = np.column_stack([rng.uniform(-3, 3, T), rng.uniform(-3, 3, T),
                             rng.uniform(-np.pi, np.pi, T)])
    e = np.einsum("tij,tj->ti", np.linalg.cholesky(scale * P), rng.normal(size=(T, 3)))
    x = truth + e
    x[:, 2] = wrap_angle(x[:, 2])
    return runner.Trace(t=t, kind=np.array(["predict"] * T), x=x, P=P, truth=truth)


@pytest.mark.parametrize("scale, consistent", [(1.0, True), (2.0, False), (0.5, False)])
def test_average_nees_of_a_gaussian_toy_is_its_dof(scale, consistent):
    rng = np.random.default_rng(7)
    n = 50
    traces = [_toy_trace(rng, scale=scale) for _ in range(n)]
    grid = traces[0].t[1:]
    sampled = [studies.sample_trace(tr, grid) for tr in traces]
    avg = np.mean([a for a, _ in sampled], axis=0)
    avg_h = np.mean([b for _, b in sampled], axis=0)
    lo, hi = chi2_band(3, n, 0.95)
    inside = np.mean((avg > lo) & (avg < hi))
    if consistent:
        assert abs(avg.mean() - 3.0) < 0.1 and abs(avg_h.mean() - 1.0) < 0.05
        assert 0.9 < inside <= 1.0          # 95 % expected, independent instants
    else:                                   # a covariance off by 2 is caught
        assert abs(avg.mean() - 3.0 * scale) < 0.15 * scale
        assert inside < 0.2


def test_sample_trace_takes_the_state_after_the_last_event():
    rng = np.random.default_rng(1)
    tr = _toy_trace(rng, T=10)
    tr.t = np.array([0.0, 0.02, 0.04, 0.1, 0.1, 0.3, 0.5, 0.5, 0.7, 1.0])
    nees, nees_h = studies.sample_trace(tr, [0.1, 0.5, 0.6, 1.0])
    for g, k in zip([0.1, 0.5, 0.6, 1.0], [4, 7, 7, 9]):
        e = tr.x[k] - tr.truth[k]
        e[2] = wrap_angle(e[2])
        i = [0.1, 0.5, 0.6, 1.0].index(g)
        assert nees[i] == pytest.approx(e @ np.linalg.solve(tr.P[k], e))
        assert nees_h[i] == pytest.approx(e[2] ** 2 / tr.P[k, 2, 2])
    with pytest.raises(ValueError, match="t_grid"):
        studies.sample_trace(tr, [-1.0])


def test_monte_carlo_equals_runs_made_by_hand():
    study = studies.monte_carlo("arena_loop", ("localization", "slam"), seeds=(5, 6), step=2.0)
    assert set(study) == {"localization", "slam"}
    s = study["slam"]
    assert s.nees.shape == (2, s.t.size) and s.t[0] == 2.0 and np.all(np.diff(s.t) == 2.0)
    tr = runner.slam(scenario("arena_loop", seed=6))
    for j, g in enumerate(s.t):
        k = np.flatnonzero(tr.t <= g + 1e-9)[-1]
        assert s.nees[1, j] == pytest.approx(tr.nees[k], rel=1e-12)
    assert s.ate[1] == pytest.approx(runner.ate(tr.x, tr.truth).position)
    assert len(s.reobservations) == 2 and study["localization"].reobservations == ()
    assert np.allclose(s.average(), s.nees.mean(axis=0))
    assert s.band() == chi2_band(3, 2) and s.band(heading=True) == chi2_band(1, 2)
    one = studies.monte_carlo_nees("arena_loop", "localization", seeds=(5,), step=2.0)
    np.testing.assert_array_equal(one.nees[0], study["localization"].nees[0])
    with pytest.raises(ValueError, match="methods"):
        studies.monte_carlo("arena_loop", ("dead_reckoning",), seeds=(1,))


def test_density_sweep_equals_a_run_made_by_hand():
    rows = studies_ch06.density_sweep((6,), seeds=(3,))
    assert len(rows) == 1
    r = rows[0]
    world = random_world(extent=(0.0, 6.0, -3.0, 3.0), count=6, seed=3)
    wp = loop_waypoints(world.bounds, margin=1.0)
    run = simulate(world, WaypointController(wp[1:]), sensor=AnalyticMarkerSensor(), seed=3,
                   params=KobukiParams(sigma_wheel=0.02), start_pose=[wp[0, 0], wp[0, 1],
                                                                       -np.pi / 2])
    tr = runner.slam(run)
    m = tr.metrics(world)
    assert (r.count, r.seed, r.landmarks) == (6, 3, int(m["landmarks"]))
    assert r.ate == pytest.approx(m["ate_xy"]) and r.final_error == pytest.approx(
        m["final_xy_error"])
    if r.landmarks:
        assert r.map_rmse == pytest.approx(runner.map_error(tr.filter, world)[0])
    assert len(r.placements) == r.landmarks


def test_reobservation_of_the_recorded_run():
    tr = runner.slam(scenario("arena_loop"))
    r = studies.reobservation(tr)
    assert r.marker_id == tr.filter.landmark_ids[0]
    # by hand: the readings of that id, their longest gap
    times = [t for t, rep in tr.reports if r.marker_id in rep.ids]
    g = int(np.argmax(np.diff(times)))
    assert (r.t_last, r.t_again) == (times[g], times[g + 1]) and r.t_again - r.t_last > 20
    rep = dict(tr.reports)[r.t_again]
    i = list(rep.ids).index(r.marker_id)
    y, S = rep.innovation[i], rep.S[i]
    assert r.d2 == pytest.approx(y @ np.linalg.solve(S, y))
    assert r.status == "accepted" and r.closed and r.t_accepted == r.t_again
    assert r.threshold == pytest.approx(5.991, abs=1e-3)
    assert np.isfinite(r.nees_before) and r.nees_before > 0


def test_reobservation_rejected_when_the_filter_underestimates_the_drift():
    # wheels slip 4x more than the filter's Q says: the true marker fails the gate
    run = scenario("arena_loop", seed=1, sigma_wheel=0.08)
    tr = runner.slam(run, Q=scenario("arena_loop", seed=1).Q())
    r = studies.reobservation(tr)
    assert r.rejected and r.d2 > r.threshold
    assert not r.closed and r.n_rejected > 50
    assert r.nees_before > 20      # the filter is far overconfident when the gate decides


def test_landmark_placement_equals_the_filter_when_added():
    run = scenario("arena_loop")
    world = run.world()
    tr = runner.slam(run)
    rows = studies_ch06.landmark_placement(tr, world)
    assert [p.marker_id for p in rows] == tr.filter.landmark_ids
    true = world.landmarks()
    for p in rows[3:6]:
        early = runner.slam(run, max_time=p.t_added)       # stops right after that frame
        got = early.filter.landmark(p.marker_id)
        assert p.error_added == pytest.approx(np.hypot(*(got - true[p.marker_id])), abs=1e-12)
        assert p.pose_error == pytest.approx(np.hypot(*early.error[-1, :2]), abs=1e-12)
    _, final = runner.map_error(tr.filter, world)
    assert all(p.error_final == pytest.approx(final[p.marker_id]) for p in rows)


# ----------------------------------------------------------------- arguments refused (issue 24.6)
@pytest.mark.parametrize("seeds", [[1.7, 1.2], [1, 2.0], [True], ["3"], [-1], [np.float64(3.0)]])
def test_seeds_that_are_not_non_negative_integers_are_refused(seeds):
    # [1.7, 1.2] became two identical runs of seed 1
    with pytest.raises(ValueError, match="seeds"):
        studies.monte_carlo_nees("arena_loop", "localization", seeds=seeds, step=5.0)


@pytest.mark.parametrize("t_end", [1e6, 61.0, float("inf"), float("nan"), -1.0, 0.0, "30"])
def test_a_grid_beyond_the_runs_or_not_a_time_is_refused(t_end):
    # t_end=1e6 gave two million samples repeating the last value past the run's end
    with pytest.raises(ValueError, match="t_end"):
        studies.monte_carlo_nees("arena_loop", "localization", seeds=[1], step=5.0,
                                 t_end=t_end)


def test_a_grid_within_the_runs_still_works():
    st = studies.monte_carlo_nees("arena_loop", "localization", seeds=[1, np.int64(2)],
                                  step=5.0, t_end=59.8)
    assert st.t[-1] == 55.0 and st.nees.shape == (2, 11) and st.seeds == (1, 2)
