"""Chapter 07: the closed loop steered by the SLAM estimate, coverage, frontiers, return rule."""

import math
from dataclasses import replace

import numpy as np
import pytest

from slamlib import runner
from slamlib.explore import (
    CoverageGrid,
    Explorer,
    exploration_world,
    explore,
    in_field_of_view,
    position_sigma,
    run_closed_loop,
)
from slamlib.sensors import AnalyticMarkerSensor, visible_markers
from slamlib.sim import (
    KobukiParams,
    KobukiSim,
    WaypointController,
    arena_loop_waypoints,
    simulate,
)
from slamlib.worlds import random_world, report_arena

WORLD = exploration_world(seed=5)


@pytest.fixture(scope="module")
def run_with_return():
    return explore(WORLD, seed=5, duration=120.0, explorer=Explorer(sigma_return=0.1))


class FollowWaypoints:
    """A minimal policy: a WaypointController that looks at the filter's estimate."""

    def __init__(self, waypoints):
        self.ctl = WaypointController(waypoints)

    def reset(self, world):
        self.ctl.reset()

    def command(self, t, filt, dt, wheel_base):
        return self.ctl.command(filt.pose, dt, wheel_base)

    def after_frame(self, t, filt, report):
        pass

    @property
    def finished(self):
        return self.ctl.done

    def params(self):
        return self.ctl.params()


# ----------------------------------------------------------------- the simulator, stepped
def test_stepping_kobukisim_by_hand_is_simulate():
    # the closed loop uses KobukiSim.step; driven by the same controller it must be simulate()
    sensor = AnalyticMarkerSensor(p_misread=0.1)
    ctl = WaypointController(arena_loop_waypoints())
    ref = simulate(report_arena(), ctl, sensor=sensor, seed=3, max_duration=20.0)
    sim = KobukiSim(report_arena(), sensor=sensor, seed=3)
    mine = WaypointController(arena_loop_waypoints())
    frames = []
    while sim.k < 1000:
        frames += sim.step(*mine.command(sim.pose, sim.params.dt, sim.params.wheel_base))
    run = sim.record()
    assert np.array_equal(run.truth, ref.truth)
    assert np.array_equal(run.ticks_R, ref.ticks_R) and np.array_equal(run.ticks_L, ref.ticks_L)
    assert np.array_equal(run.camera.rho, ref.camera.rho)
    assert np.array_equal(run.camera.id, ref.camera.id)
    assert len(frames) == len(ref.frames()) + sum(len(f) == 0 for f in frames)


def test_set_waypoints_keeps_the_speeds():
    ctl = WaypointController([[5.0, 0.0]])
    pose = np.zeros(3)
    for _ in range(50):
        ctl.command(pose, 0.02)
    v_before = ctl._v
    ctl.set_waypoints([[0.0, 5.0]])
    VR, VL = ctl.command(pose, 0.02)
    assert ctl.index == 0 and v_before > 0.15
    assert abs(0.5 * (VR + VL) - v_before) <= ctl.accel * 0.02 + 1e-12   # no jump in speed
    with pytest.raises(ValueError, match="waypoints"):
        ctl.set_waypoints(np.zeros((0, 2)))


# ----------------------------------------------------------------- geometry and grid
def test_in_field_of_view_against_a_point_by_point_computation():
    rng = np.random.default_rng(0)
    for _ in range(30):
        pose = np.array([*rng.uniform(-2, 2, 2), rng.choice([rng.uniform(-np.pi, np.pi),
                                                             np.pi - 0.05, -np.pi + 0.05])])
        pts = rng.uniform(-4, 4, (50, 2))
        half, rmax = rng.uniform(0.2, 1.5), rng.uniform(0.5, 4.0)
        got = in_field_of_view(pose, pts, half, rmax)
        for p, g in zip(pts, got):
            dx, dy = p[0] - pose[0], p[1] - pose[1]
            # the angle between the heading and the direction to the point, via the dot product
            ang = math.acos(max(-1.0, min(1.0, (dx * math.cos(pose[2]) + dy * math.sin(pose[2]))
                                          / math.hypot(dx, dy))))
            assert g == (math.hypot(dx, dy) <= rmax and ang <= half)


def test_in_field_of_view_agrees_with_the_sensor_without_offset_and_view_angle():
    world = random_world(count=40, seed=2)
    rng = np.random.default_rng(1)
    for _ in range(20):
        pose = np.array([*rng.uniform(0, 6, 1), *rng.uniform(-3, 3, 1), rng.uniform(-np.pi, np.pi)])
        sensor_says = visible_markers(world, pose, fov_half_angle=0.55, min_range=0.0,
                                      max_range=3.0, max_view_angle=np.pi, camera_offset=(0, 0))
        assert np.array_equal(in_field_of_view(pose, world.positions, 0.55, 3.0), sensor_says)


def test_positive_bearing_is_to_the_right_in_z_down():
    # heading +x, a point at +y (to the right, seen from above in z-down) with a 60-degree wedge
    # turned right: inside only if the wedge is measured with bearing = atan2(dy, dx) - theta
    pose = np.array([0.0, 0.0, 0.5])
    assert in_field_of_view(pose, [[1.0, 1.0]], 0.3, 2.0)[0]
    assert not in_field_of_view(pose, [[1.0, -1.0]], 0.3, 2.0)[0]


def test_grid_cells_frontier_and_mark():
    g = CoverageGrid((0.0, 3.0, -1.0, 1.0), cell=0.5)
    assert g.shape == (4, 6) and g.centres.shape == (24, 2)
    assert np.allclose(g.centres[0], [0.25, -0.75]) and np.allclose(g.centres[7], [0.75, -0.25])
    g.seen[1, 2] = True
    f = g.frontier()
    assert sorted(zip(*np.nonzero(f))) == [(0, 2), (1, 1), (1, 3), (2, 2)]
    n = g.mark([0.0, 0.0, 0.0], 0.4, 1.5)
    inside = in_field_of_view([0.0, 0.0, 0.0], g.centres, 0.4, 1.5)
    assert n == int(inside.sum()) - int(inside[1 * 6 + 2])
    assert np.array_equal(g.seen.reshape(-1), inside | (np.arange(24) == 8))
    assert g.coverage == pytest.approx(g.seen.sum() / 24)


def test_position_sigma():
    assert position_sigma(np.diag([0.03, 0.04, 9.0])) == pytest.approx(math.sqrt(0.07))


# ----------------------------------------------------------------- the closed loop
def test_same_seed_same_exploration_other_seed_other(run_with_return):
    again = explore(WORLD, seed=5, duration=120.0, explorer=Explorer(sigma_return=0.1))
    assert np.array_equal(again.run.truth, run_with_return.run.truth)
    assert np.array_equal(again.trace.x, run_with_return.trace.x)
    assert again.policy.history == run_with_return.policy.history
    other = explore(WORLD, seed=6, duration=30.0, explorer=Explorer(sigma_return=0.1))
    n = other.run.truth.shape[0]
    assert not np.array_equal(other.run.truth, run_with_return.run.truth[:n])


def test_replaying_the_recorded_run_gives_the_same_estimates(run_with_return):
    # the filter in the loop saw exactly the data the run recorded, in the order run_filter uses
    ex = run_with_return
    replay = runner.slam(ex.run)
    assert np.array_equal(replay.kind, ex.trace.kind)
    assert np.allclose(replay.t, ex.trace.t, atol=1e-6)
    # readings are rounded to 10 um / 1 urad in a Run: the estimates agree to that level
    assert np.max(np.abs(replay.x - ex.trace.x)) < 1e-4
    assert replay.filter.landmark_ids == ex.filter.landmark_ids


def test_the_robot_goes_where_the_estimate_says():
    # no markers, no slip: the filter dead-reckons from the initial estimate it is given;
    # a wrong initial estimate moves the TRUE path by the same offset
    world = replace(random_world(count=0, seed=0), start_pose=(1.0, 0.0, 0.0))
    wp = np.array([[3.0, 0.0], [3.0, 1.5], [4.5, 1.5]])
    params = KobukiParams(sigma_wheel=0.0)
    offset = np.array([0.5, -0.4, 0.0])
    right = run_closed_loop(world, FollowWaypoints(wp), params=params, duration=60.0)
    fooled = run_closed_loop(world, FollowWaypoints(wp), params=params, duration=60.0,
                             initial_estimate=np.array(world.start_pose) + offset)
    for ex in (right, fooled):
        assert ex.run.meta["finished"]
        assert np.hypot(*(ex.trace.x[-1, :2] - wp[-1])) < 0.12      # the estimate got there
    assert np.hypot(*(right.trace.truth[-1, :2] - wp[-1])) < 0.15
    # the truth stopped where the waypoint is, minus the offset of the belief
    assert np.hypot(*(fooled.trace.truth[-1, :2] - (wp[-1] - offset[:2]))) < 0.15
    assert np.hypot(*(fooled.trace.truth[-1, :2] - wp[-1])) > 0.45
    # and the belief stayed offset by exactly what it was told, all along the way
    assert np.allclose(fooled.trace.x[:, :2] - fooled.trace.truth[:, :2], offset[:2], atol=0.05)


def test_coverage_grows_and_matches_the_estimated_poses(run_with_return):
    ex = run_with_return
    h = ex.history()
    assert np.all(np.diff(h["coverage"]) >= 0.0)
    assert h["coverage"][-1] > 0.5 and h["coverage"][0] < 0.1
    # recompute the seen cells from the estimate at each frame time, independently
    pol = ex.policy
    seen = np.zeros(pol.grid.centres.shape[0], dtype=bool)
    for t in h["t"]:
        k = np.searchsorted(ex.trace.t, t, side="right") - 1
        seen |= in_field_of_view(ex.trace.x[k], pol.grid.centres, pol.fov_half_angle,
                                 pol.view_range)
    assert np.array_equal(seen, pol.grid.seen.reshape(-1))


@pytest.mark.parametrize("seed", [0, 3, 4])
def test_the_robot_stays_inside_the_world(seed):
    world = exploration_world(seed=seed)
    ex = explore(world, seed=seed, duration=120.0, explorer=Explorer(sigma_return=0.1, margin=0.5))
    xmin, xmax, ymin, ymax = world.bounds
    for poses, slack in ((ex.trace.x, 0.25), (ex.trace.truth, 0.1)):
        # goals are 0.5 m inside; the controller may overshoot a little, the truth drift a bit
        assert poses[:, 0].min() > xmin + slack and poses[:, 0].max() < xmax - slack
        assert poses[:, 1].min() > ymin + slack and poses[:, 1].max() < ymax - slack


def test_returns_start_above_the_threshold(run_with_return):
    pol = run_with_return.policy
    assert len(pol.returns) >= 2
    for t0, t1, anchor, s0, _ in pol.returns:
        assert s0 > pol.sigma_return and t1 > t0
        assert anchor in run_with_return.filter.landmark_ids
    h = run_with_return.history()
    assert set(h["mode"]) >= {"explore", "return"}
    # starts are at least `cooldown` apart from the end of the previous return
    for (_, e, *_), (s, *_) in zip(pol.returns[:-1], pol.returns[1:]):
        assert s - e > pol.cooldown


def test_without_the_rule_there_is_no_return():
    ex = explore(WORLD, seed=5, duration=40.0, explorer=Explorer(sigma_return=None))
    assert ex.policy.returns == [] and "return" not in ex.policy.history["mode"]


def test_return_rule_lowers_the_position_error_over_seeds():
    rms = {True: [], False: []}
    max_sigma = {True: [], False: []}
    for seed in range(4):
        world = exploration_world(seed=seed)
        for rule in (True, False):
            ex = explore(world, seed=seed, duration=120.0,
                         explorer=Explorer(sigma_return=0.1 if rule else None))
            rms[rule].append(ex.metrics()["rms_xy_error"])
            max_sigma[rule].append(ex.history()["sigma_xy"].max())
    # measured (seeds 0-3, 120 s): mean RMS error 0.051 m with the rule, 0.086 m without;
    # the largest sigma_xy 0.18 m against 0.25 m
    assert np.mean(rms[True]) < 0.75 * np.mean(rms[False])
    assert np.mean(max_sigma[True]) < np.mean(max_sigma[False])


def test_stops_at_the_coverage_target():
    ex = explore(WORLD, seed=5, duration=180.0,
                 explorer=Explorer(sigma_return=None, coverage_target=0.5))
    assert ex.run.meta["finished"]
    assert 0.5 <= ex.policy.grid.coverage < 0.6
    assert ex.trace.t[-1] < 100.0


def test_the_filter_gets_the_q_it_is_given():
    params = KobukiParams(sigma_wheel=0.04)
    default = explore(WORLD, seed=1, duration=2.0, params=params)
    assert default.filter.Q[0, 0] > 0.04 ** 2 and default.filter.Q[0, 1] == 0.0
    assert np.array_equal(default.filter.Q, default.run.Q(params.dt))
    small = explore(WORLD, seed=1, duration=2.0, params=params, Q=0.02 ** 2 * np.eye(2))
    assert np.array_equal(small.filter.Q, 0.02 ** 2 * np.eye(2))


def test_bad_input():
    with pytest.raises(ValueError, match="margin"):
        explore(WORLD, explorer=Explorer(margin=5.0), duration=1.0)
    with pytest.raises(ValueError, match="duration"):
        explore(WORLD, duration=-1.0)
    with pytest.raises(ValueError, match="initial_estimate"):
        explore(WORLD, duration=1.0, initial_estimate=[0.0, 0.0])
    with pytest.raises(ValueError, match="cell"):
        CoverageGrid((0, 1, 0, 1), cell=0.0)
