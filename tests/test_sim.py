"""The simulator and the analytic sensor: determinism, geometry, noise statistics, encoders."""

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from slamlib.models import (
    KOBUKI_TICKS_PER_REV,
    body_velocity,
    motion_jacobians,
    motion_model,
    tick_difference,
    wrap_angle,
)
from slamlib.sensors import AnalyticMarkerSensor, Observations
from slamlib.sim import (
    KobukiParams,
    WaypointController,
    arena_loop_waypoints,
    encoder_counter,
    integrate_arc,
    scenario,
    simulate,
    wheel_commands,
)
from slamlib.worlds import Marker, World, random_world, report_arena

ARENA = report_arena()
TICK = 2 * math.pi * 0.035 / KOBUKI_TICKS_PER_REV      # metres of rim per tick


def short_run(seed=0, sigma_wheel=0.02, sensor=None, duration=12.0, **kw):
    return simulate(ARENA, WaypointController(arena_loop_waypoints()), sensor=sensor,
                    seed=seed, params=KobukiParams(sigma_wheel=sigma_wheel, **kw),
                    max_duration=duration)


def same_run(a, b):
    return (np.array_equal(a.truth, b.truth) and np.array_equal(a.ticks_R, b.ticks_R)
            and np.array_equal(a.ticks_L, b.ticks_L) and np.array_equal(a.enc_t, b.enc_t)
            and all(np.array_equal(getattr(a.camera, k), getattr(b.camera, k), equal_nan=True)
                    for k in ("t_capture", "id", "rho", "bearing", "true_rho")))


# ----------------------------------------------------------------- determinism
def test_same_seed_same_run_different_seed_different_run():
    s = AnalyticMarkerSensor(p_misread=0.1, p_outlier=0.1)
    a, b = short_run(3, sensor=s), short_run(3, sensor=s)
    c = short_run(4, sensor=s)
    assert same_run(a, b)
    assert not np.array_equal(a.truth, c.truth)
    assert not np.array_equal(a.camera.rho[:5], c.camera.rho[:5])


def test_faults_do_not_change_motion_or_noise():
    clean = short_run(5, sensor=AnalyticMarkerSensor())
    faulty = short_run(5, sensor=AnalyticMarkerSensor(p_misread=0.3))
    silent = short_run(5, sensor=None)
    assert np.array_equal(clean.truth, faulty.truth)
    assert np.array_equal(clean.truth, silent.truth)
    assert np.array_equal(clean.ticks_R, faulty.ticks_R)
    assert np.array_equal(clean.camera.rho, faulty.camera.rho)
    assert np.array_equal(clean.camera.bearing, faulty.camera.bearing)
    assert np.array_equal(clean.camera.true_id, faulty.camera.true_id)
    assert np.any(clean.camera.id != faulty.camera.id)


def test_scenario_loop_comes_back_past_the_first_marker():
    run = scenario("arena_loop")
    assert run.meta["finished"]
    duration = run.enc_t[-1]
    assert 45.0 < duration < 120.0
    first = run.camera.true_id[0]
    late = run.camera.true_id[run.camera.t_capture > duration - 10.0]
    gap = run.camera.true_id[(run.camera.t_capture > 20.0) & (run.camera.t_capture < 40.0)]
    assert first in late and first not in gap       # lost, then seen again: a loop closure
    assert len(np.unique(run.camera.true_id)) >= 8


# ----------------------------------------------------------------- motion pieces
def test_wheel_commands_inverts_body_velocity():
    for v, w in [(0.2, 0.0), (0.1, 0.7), (-0.05, -1.2), (0.0, 0.3)]:
        vb, wb = body_velocity(wheel_commands(v, w, 0.23), 0.23)
        assert vb == pytest.approx(v) and wb == pytest.approx(w)
    # z-down: a faster left wheel turns clockwise (positive w)
    assert body_velocity([0.1, 0.2])[1] > 0


@pytest.mark.parametrize("v, w", [(0.2, 0.0), (0.2, 0.5), (-0.1, -0.8), (0.0, 1.0), (0.3, 1e-12)])
def test_integrate_arc_matches_fine_euler(v, w):
    pose = np.array([1.0, -2.0, 3.1])
    exact = integrate_arc(pose, v, w, 0.5)
    x = pose.copy()
    n = 20000
    for _ in range(n):
        x = np.array([x[0] + v * math.cos(x[2]) * 0.5 / n, x[1] + v * math.sin(x[2]) * 0.5 / n,
                      x[2] + w * 0.5 / n])
    assert np.allclose(exact[:2], x[:2], atol=1e-5)
    assert wrap_angle(exact[2] - x[2]) == pytest.approx(0.0, abs=1e-9)


def test_encoder_counter_wraps_both_ways():
    per_tick = 2 * math.pi / KOBUKI_TICKS_PER_REV
    assert encoder_counter(0.0, offset=65535) == 65535
    assert encoder_counter(1.5 * per_tick, offset=65535) == 0
    assert encoder_counter(-0.5 * per_tick, offset=0) == 65535
    assert tick_difference(encoder_counter(3.2 * per_tick, offset=65534), 65534) == 3
    assert tick_difference(encoder_counter(-3.2 * per_tick, offset=1), 1) == -4   # floor


def test_run_counters_are_16_bit_and_wrap():
    run = short_run(0, sensor=None, duration=20.0)
    for ticks in (run.ticks_R, run.ticks_L):
        assert ticks.min() >= 0 and ticks.max() < 65536
    assert np.any(np.diff(run.ticks_R) < -30000), "the right counter should wrap early on"
    d = tick_difference(run.ticks_R[1:], run.ticks_R[:-1])
    assert np.all(np.abs(d) < 200)          # no spurious jump of 65536 after unwrapping


def test_controller_respects_limits():
    ctl = WaypointController(arena_loop_waypoints(), v_max=0.2, w_max=0.7)
    run = simulate(ARENA, ctl, seed=0, params=KobukiParams(sigma_wheel=0.0))
    u, dt = run.controls()
    v = 0.5 * (u[:, 0] + u[:, 1])
    w = (u[:, 1] - u[:, 0]) / 0.23
    # a wheel speed from ticks is off by less than one tick per period
    assert np.all(np.abs(v) <= 0.2 + TICK / dt)
    assert np.all(np.abs(w) <= 0.7 + 2 * TICK / dt / 0.23)
    for wp in arena_loop_waypoints():
        assert np.min(np.hypot(*(run.truth[:, :2] - wp).T)) <= ctl.tolerance + 1e-3


def test_zero_noise_dead_reckoning_returns_the_truth():
    """With no slip the only differences are Euler's and the ticks' quantisation.

    Heading: the ticks floor each wheel's rim distance, an error in [0, TICK),
    so the heading from ticks differs from the truth by less than TICK/b.
    Position: the Euler step keeps the start heading, so each step's chord is
    off by (w dt/2) of its length V dt: at most (dt/2) sum |V||w| dt over the
    run; the heading error (< TICK/b) adds at most TICK/b times the distance,
    and the floored distance at most one TICK. So the position error is below
    (dt/2) sum|V||w| dt + (TICK/b) L + TICK.
    """
    run = simulate(ARENA, WaypointController(arena_loop_waypoints()), seed=0,
                   params=KobukiParams(sigma_wheel=0.0))
    u, dt = run.controls()
    x = run.start_pose
    est = [x]
    for k in range(dt.size):
        x = motion_model(x, u[k], dt[k])
        est.append(x)
    est = np.array(est)
    truth = run.truth_at_encoders()
    head = np.abs(wrap_angle(est[:, 2] - truth[:, 2]))
    assert head.max() < TICK / 0.23 + 2e-6          # + the file rounding of theta (1e-6)
    V = 0.5 * (u[:, 0] + u[:, 1])
    W = (u[:, 1] - u[:, 0]) / 0.23
    L = np.sum(np.abs(V) * dt)
    bound = 0.5 * np.max(dt) * np.sum(np.abs(V * W) * dt) + TICK / 0.23 * L + TICK + 2e-5
    pos = np.hypot(*(est[:, :2] - truth[:, :2]).T)
    assert pos.max() < bound
    assert bound < 0.05                         # the bound itself is small: a meaningful test
    # and the error is not trivially zero: Euler's lag is really there
    assert pos.max() > 1e-4


def test_wheel_slip_matches_the_filters_Q():
    """Monte-Carlo over seeds: the dead-reckoning error is N(0, P) with P from Q = sigma^2 I.

    Average NEES of the final pose over 60 runs must be in the chi-square
    band (3 dof) at 99.9 %.
    """
    n, nees = 60, []
    for seed in range(n):
        run = short_run(seed, sigma_wheel=0.03, duration=10.0)
        u, dt = run.controls()
        Q = run.Q()
        x, P = run.start_pose, np.zeros((3, 3))
        for k in range(dt.size):
            A, W = motion_jacobians(x, u[k], dt[k])
            x = motion_model(x, u[k], dt[k])
            P = A @ P @ A.T + W @ Q @ W.T
        e = x - run.truth[-1]
        e[2] = wrap_angle(e[2])
        nees.append(e @ np.linalg.solve(P, e))
    mean = np.mean(nees)
    lo, hi = stats.chi2.ppf([0.0005, 0.9995], 3 * n) / n
    assert lo < mean < hi, (mean, lo, hi)


def test_simulate_rejects_bad_input():
    ctl = WaypointController(arena_loop_waypoints())
    with pytest.raises(ValueError, match="start_pose"):
        simulate(replace(ARENA, start_pose=None), ctl)
    with pytest.raises(ValueError, match="seed"):
        simulate(ARENA, ctl, seed=-1)
    with pytest.raises(ValueError, match="sigma_wheel"):
        KobukiParams(sigma_wheel=-0.1)
    with pytest.raises(ValueError, match="waypoints"):
        WaypointController(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="p_misread"):
        AnalyticMarkerSensor(p_misread=1.5)
    with pytest.raises(ValueError, match="min_range"):
        AnalyticMarkerSensor(min_range=5.0, max_range=4.0)


# ----------------------------------------------------------------- the sensor's geometry
def independent_visibility(world, pose, s):
    """The visibility rules, written again from scratch, per marker."""
    out = {}
    c, sn = math.cos(pose[2]), math.sin(pose[2])
    cx = pose[0] + c * s.camera_offset[0] - sn * s.camera_offset[1]
    cy = pose[1] + sn * s.camera_offset[0] + c * s.camera_offset[1]
    for m in world.markers:
        dx, dy = m.x - cx, m.y - cy
        dist = math.hypot(dx, dy)
        fwd = c * dx + sn * dy                       # in the robot frame
        right = -sn * dx + c * dy
        bearing = math.atan2(right, fwd)
        to_cam = (-dx / dist, -dy / dist)
        cos_view = math.cos(m.yaw) * to_cam[0] + math.sin(m.yaw) * to_cam[1]
        out[m.id] = (abs(bearing), dist, cos_view)
    return out


def test_sensor_never_reports_an_invisible_marker():
    s = AnalyticMarkerSensor(p_misread=0.0, p_outlier=0.0, max_range=3.0)
    rng = np.random.default_rng(11)
    reported, missed_sure = 0, 0
    for k in range(300):
        world = random_world(extent=(0, 6, -3, 3), count=25, seed=k % 20)
        pose = np.array([rng.uniform(0, 6), rng.uniform(-3, 3), rng.uniform(-np.pi, np.pi)])
        obs = s.read(world, pose, rng)
        geo = independent_visibility(world, pose, s)
        for i in obs.true_ids:
            b, d, cv = geo[int(i)]
            assert b < s.fov_half_angle and s.min_range <= d <= s.max_range
            assert cv > math.cos(s.max_view_angle) > 0.0   # printed side, not too oblique
            reported += 1
        # and a marker well inside every limit is reported
        for mid, (b, d, cv) in geo.items():
            sure = (b < s.fov_half_angle - 0.01 and s.min_range + 0.01 < d < s.max_range - 0.01
                    and cv > math.cos(s.max_view_angle) + 0.01)
            if sure and mid not in obs.true_ids:
                missed_sure += 1
    assert reported > 100 and missed_sure == 0


def test_back_of_a_marker_is_never_seen():
    world = World("one", (Marker(7, 2.0, 0.0, yaw=0.0),), bounds=(0, 3, -1, 1))
    s = AnalyticMarkerSensor()
    rng = np.random.default_rng(0)
    # robot behind the marker (at x < 2 looking along +x): the marker faces away
    assert len(s.read(world, [1.0, 0.0, 0.0], rng)) == 0
    # robot in front, looking back at it
    front = s.read(world, [3.0, 0.0, math.pi], rng)
    assert list(front.true_ids) == [7]
    # in front but at 80 degrees off the normal: too oblique
    pose = [2.0 + 1.0 * math.cos(math.radians(80)), 1.0 * math.sin(math.radians(80)), 0.0]
    pose[2] = math.atan2(0.0 - pose[1], 2.0 - pose[0])
    assert len(s.read(world, pose, rng)) == 0


def test_fov_is_tested_from_the_camera_and_bearing_from_the_robot():
    # a marker straight ahead of the camera (left of the robot's axis by 0.033 m)
    world = World("one", (Marker(1, 2.122, -0.033, yaw=math.pi),), bounds=(0, 3, -1, 1))
    s = AnalyticMarkerSensor(sigma_range0=0, sigma_range_per_m=0, sigma_bearing=0)
    obs = s.read(world, [0.0, 0.0, 0.0], np.random.default_rng(0))
    assert obs.z[0, 0] == pytest.approx(math.hypot(2.122, 0.033))
    assert obs.z[0, 1] == pytest.approx(math.atan2(-0.033, 2.122))   # left: negative
    # the default half field of view is atan(320/525)
    assert math.degrees(s.fov_half_angle) == pytest.approx(31.37, abs=0.01)


# ----------------------------------------------------------------- the sensor's noise
def repeated_readings(s, n=4000, distance=2.5, seed=3):
    world = World("one", (Marker(5, distance, 0.4, yaw=math.pi),), bounds=(0, 4, -1, 1))
    rng = np.random.default_rng(seed)
    rows = [s.read(world, [0.0, 0.0, 0.1], rng) for _ in range(n)]
    z = np.vstack([r.z for r in rows if len(r)])
    zt = np.vstack([r.z_true for r in rows if len(r)])
    return z, zt


@pytest.mark.parametrize("bias", [0.0, 0.01])
def test_noise_matches_its_parameters(bias):
    s = AnalyticMarkerSensor(sigma_range0=0.02, sigma_range_per_m=0.01, sigma_bearing=0.015,
                             range_bias_per_m2=bias)
    z, zt = repeated_readings(s)
    n = z.shape[0]
    rho = zt[0, 0]
    er, eb = z[:, 0] - zt[:, 0], wrap_angle(z[:, 1] - zt[:, 1])
    sr, sb = 0.02 + 0.01 * rho, 0.015
    # means within 4.5 standard errors, standard deviations within 4.5 of theirs
    assert abs(er.mean() - bias * rho ** 2) < 4.5 * sr / math.sqrt(n)
    assert abs(eb.mean()) < 4.5 * sb / math.sqrt(n)
    assert abs(er.std(ddof=1) / sr - 1) < 4.5 / math.sqrt(2 * n)
    assert abs(eb.std(ddof=1) / sb - 1) < 4.5 / math.sqrt(2 * n)
    assert np.allclose(s.R(rho), np.diag([sr ** 2, sb ** 2]))
    # the normalised errors are Gaussian (Kolmogorov-Smirnov)
    assert stats.kstest((er - bias * rho ** 2) / sr, "norm").pvalue > 1e-3


def test_misreads_and_outliers_at_their_rates():
    world = random_world(extent=(0, 4, -2, 2), count=12, seed=2)
    s = AnalyticMarkerSensor(p_misread=0.2, p_outlier=0.3, misread_in_world=0.5)
    rng = np.random.default_rng(8)
    n_read = n_mis = n_in_world = n_frames = n_out = 0
    for _ in range(3000):
        pose = np.array([rng.uniform(0, 4), rng.uniform(-2, 2), rng.uniform(-np.pi, np.pi)])
        obs = s.read(world, pose, rng)
        n_frames += 1
        real = obs.true_ids >= 0
        n_out += int(np.sum(~real))
        n_read += int(real.sum())
        mis = real & (obs.ids != obs.true_ids)
        n_mis += int(mis.sum())
        n_in_world += int(np.isin(obs.ids[mis], world.ids).sum())
        for z in obs.z[~real]:                              # outliers look plausible
            assert s.min_range <= z[0] <= s.max_range and abs(z[1]) <= s.fov_half_angle
        assert np.all((obs.ids >= 0) & (obs.ids < 1024))
        assert isinstance(obs, Observations)
    assert n_read > 1000

    def within(k, n, p):
        return abs(k - n * p) < 4.5 * math.sqrt(n * p * (1 - p))

    assert within(n_mis, n_read, 0.2)
    assert within(n_out, n_frames, 0.3)
    # misreads into the world: half by choice, plus random ids that happen to be in it
    p_world = 0.5 + 0.5 * (len(world.ids) - 1) / 1023
    assert within(n_in_world, n_mis, p_world)
