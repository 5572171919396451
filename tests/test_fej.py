"""First-Estimates-Jacobian and ideal EKF SLAM (issue 9, point 2; chapter 06)."""

from __future__ import annotations

import numpy as np
import pytest

from slamlib import runner, sim, studies
from slamlib.ekf import EKFSLAM, FEJEKFSLAM, IdealEKFSLAM
from slamlib.metrics import chi2_band
from slamlib.models import motion_model, observe, observe_landmarks

Q = np.diag([0.05, 0.05]) ** 2
R = np.diag([0.03, np.radians(1.0)]) ** 2
LANDMARKS = {1: np.array([2.0, 0.5]), 2: np.array([1.0, -1.5]), 3: np.array([-0.5, 1.0])}


def _drive(filt, steps=60, seed=0):
    """Predict at 50 Hz, update with the three landmarks every 5th step (noisy readings)."""
    rng = np.random.default_rng(seed)
    truth = np.array([0.0, 0.0, 0.1])
    states = []
    for k in range(steps):
        u = np.array([0.22, 0.25])
        truth = motion_model(truth, u + rng.normal(0, 0.05, 2), 0.02)
        filt.predict(u, 0.02)
        states.append(("predict", filt.pose))
        if k % 5 == 4:
            ids = np.array(sorted(LANDMARKS))
            z = np.array([observe(truth, LANDMARKS[i]) for i in ids])
            z += rng.normal(0, [0.03, np.radians(1.0)], z.shape)
            filt.update(ids, z)
            states.append(("update", filt.pose))
    return states


def _corner(A):
    return np.array([A[0, 2], A[1, 2]])


def _spy(filt, link: str, out: list) -> None:
    """Record what the filter's linearisation hook returns for ``link`` (on the instance)."""
    hook = filt.jacobians

    def spy(name, **kw):
        got = hook(name, **kw)
        if name == link:
            out.append(tuple(np.array(a, copy=True) for a in got))
        return got

    filt.jacobians = spy


def _motion_jacobians_over_a_drive(filt, pose_of):
    """Drive ``filt`` 40 steps with an update every 5th; the motion Jacobian A of every
    prediction (spied on the hook) and ``pose_of(filt)`` before and after each."""
    got, poses = [], [pose_of(filt)]
    _spy(filt, "motion", got)
    rng = np.random.default_rng(1)
    for k in range(40):
        filt.predict(np.array([0.2, 0.26]), 0.02)
        poses.append(pose_of(filt))
        if k % 5 == 4:
            ids = np.array(sorted(LANDMARKS))
            z = np.array([observe(filt.pose, LANDMARKS[i]) for i in ids]) + \
                rng.normal(0, 0.05, (3, 2))
            filt.update(ids, z)
    return [A for A, _ in got], poses


def _product(As):
    prod = np.eye(3)
    for A in As:
        prod = A @ prod
    return prod


def test_fej_motion_jacobians_chain_over_an_interval_with_updates():
    f = FEJEKFSLAM([0.0, 0.0, 0.1], np.eye(3) * 1e-6, Q, R)
    As, props = _motion_jacobians_over_a_drive(f, lambda g: g.propagated_pose)
    # the product over steps a..b-1 is the A of the whole interval: x_{b|b-1} - x_{a|a-1}
    for a, b in [(0, 40), (3, 17), (4, 5), (9, 31)]:
        d = props[b] - props[a]
        whole = np.array([[1.0, 0.0, -d[1]], [0.0, 1.0, d[0]], [0.0, 0.0, 1.0]])
        assert np.allclose(_product(As[a:b]), whole, atol=1e-12), (a, b)


def test_standard_motion_jacobians_do_not_chain_after_updates():
    f = EKFSLAM([0.0, 0.0, 0.1], np.eye(3) * 1e-6, Q, R)
    As, props = _motion_jacobians_over_a_drive(f, lambda g: g.pose)   # the pose after predict
    prod = _product(As)
    d = props[-1] - props[0]
    assert abs(prod[0, 2] + d[1]) + abs(prod[1, 2] - d[0]) > 1e-4   # the updates broke the chain


def test_fej_observation_jacobians_at_first_estimates_by_finite_differences():
    f = FEJEKFSLAM([0.0, 0.0, 0.1], np.eye(3) * 1e-4, Q, R)
    _drive(f, steps=30)
    got = []
    _spy(f, "observation", got)
    f.predict(np.array([0.2, 0.2]), 0.02)
    pose = f.propagated_pose
    ids = np.array(sorted(LANDMARKS))
    rep = f.update(ids, np.array([observe(pose, LANDMARKS[i]) for i in ids]))
    assert rep.accepted.all() and len(got) == 1
    seen = {"Hp": got[0][1], "Hl": got[0][2]}
    eps = 1e-6
    for j, mid in enumerate(ids):
        m0 = f.first_estimate(mid)
        assert not np.allclose(m0, f.landmark(mid))          # the estimate has moved since
        Hp_fd = np.column_stack([(observe(pose + eps * e, m0) - observe(pose - eps * e, m0))
                                 / (2 * eps) for e in np.eye(3)])
        Hl_fd = np.column_stack([(observe(pose, m0 + eps * e) - observe(pose, m0 - eps * e))
                                 / (2 * eps) for e in np.eye(2)])
        assert np.allclose(seen["Hp"][j], Hp_fd, atol=1e-6)
        assert np.allclose(seen["Hl"][j], Hl_fd, atol=1e-6)
        _, Hp_now, _ = observe_landmarks(pose, f.landmark(mid)[None, :])
        assert not np.allclose(seen["Hp"][j], Hp_now[0], atol=1e-6)


def test_fej_means_move_like_ekf_slam_until_the_jacobians_differ():
    a = FEJEKFSLAM([0.0, 0.0, 0.1], np.eye(3) * 1e-6, Q, R)
    b = EKFSLAM([0.0, 0.0, 0.1], np.eye(3) * 1e-6, Q, R)
    for _ in range(10):                                       # no update: same A, same P
        a.predict(np.array([0.2, 0.25]), 0.02)
        b.predict(np.array([0.2, 0.25]), 0.02)
    assert np.allclose(a.P, b.P, rtol=1e-12, atol=1e-18) and np.array_equal(a.x, b.x)
    rep = a.update([7], [[1.0, 0.2]])
    assert rep.new[0] and a.landmark_ids == [7]


def test_ideal_jacobians_are_the_truths():
    run = sim.scenario("arena_loop", seed=3)
    truth = runner.truth_function(run)
    f = IdealEKFSLAM(run.start_pose, runner.DEFAULT_P0, run.Q(), run.sensor().R(2.0),
                     truth=truth, landmarks=run.world().landmarks())
    got = []
    _spy(f, "motion", got)
    As = [A for A, _ in got]
    u, dt = run.controls()
    for k in range(20):
        f.predict(u[k], float(dt[k]))
        As.append(got[-1][0])
    d = run.truth[20] - run.truth[0]
    prod = np.eye(3)
    for A in As:
        prod = A @ prod
    assert np.allclose(prod[:2, 2], [-d[1], d[0]], atol=1e-12)
    assert abs(f.t - run.enc_t[20]) < 1e-9
    assert np.array_equal(truth(run.enc_t[20]), run.truth[20])
    assert np.allclose(truth(0.011), run.truth_at(0.011), atol=1e-12)
    with pytest.raises(ValueError, match="truth"):
        IdealEKFSLAM(run.start_pose, runner.DEFAULT_P0, run.Q(), run.sensor().R(2.0), truth=None,
                     landmarks={})


def test_ideal_landmark_initialisation_at_the_truth():
    """landmark_init="truth": J1, J2 at the true pose and reading, the mean by the first-order
    expansion about the truth; by default the estimate's initialisation, as in EKF SLAM."""
    from slamlib.models import inverse_observation_jacobians, inverse_observe, observe

    truth = {0: np.array([0.0, 0.0, 0.0])}
    marks = {7: np.array([2.0, 1.0])}
    x0 = np.array([0.05, -0.03, 0.04])                   # the estimate, off the truth
    P0, Qm, Rm = np.diag([1e-3, 2e-3, 3e-3]), np.eye(2) * 1e-4, np.diag([0.01, 1e-3])
    z = np.array([2.3, 0.41])
    kw = dict(truth=lambda t: truth[0], landmarks=marks)
    ideal = IdealEKFSLAM(x0, P0, Qm, Rm, landmark_init="truth", **kw)
    ideal.update([7], [z])
    zt = observe(truth[0], marks[7])
    J1, J2 = inverse_observation_jacobians(truth[0], zt)
    assert not np.allclose(J1, inverse_observation_jacobians(x0, z)[0])
    np.testing.assert_allclose(ideal.P[3:, 3:], J1 @ P0 @ J1.T + J2 @ Rm @ J2.T, rtol=1e-12)
    np.testing.assert_allclose(ideal.P[3:, :3], J1 @ P0, rtol=1e-12)
    expansion = marks[7] + J1 @ (x0 - truth[0]) + J2 @ (z - zt)
    np.testing.assert_allclose(ideal.x[3:], expansion, rtol=1e-12)
    assert not np.allclose(ideal.x[3:], inverse_observe(x0, z), atol=1e-4)
    # the default is EKF SLAM's initialisation, bit for bit
    default = IdealEKFSLAM(x0, P0, Qm, Rm, **kw)
    slam = EKFSLAM(x0, P0, Qm, Rm)
    default.update([7], [z])
    slam.update([7], [z])
    assert np.array_equal(default.x, slam.x) and np.array_equal(default.P, slam.P)
    with pytest.raises(ValueError, match="initialisation"):
        IdealEKFSLAM(x0, P0, Qm, Rm, landmark_init="map", **kw)


def test_fej_is_consistent_where_ekf_slam_is_not():
    # arena loop, sigma_wheel 0.10 (the filters' Q matched), 30 seeds: the Monte-Carlo average
    # of the pose NEES at one instant (the end of the common time grid) against the 95 % band
    # of an average of 30 runs. EKF SLAM is far above it (overconfident), FEJ inside.
    seeds = range(1000, 1030)
    mc = studies.monte_carlo("arena_loop", ("slam", "fej"), seeds, sigma_wheel=0.10,
                             t_end=58.5, workers=2)
    lo, hi = chi2_band(3, len(seeds))
    slam_end, fej_end = mc["slam"].average()[-1], mc["fej"].average()[-1]
    assert slam_end > hi, slam_end
    assert lo < fej_end < hi, fej_end
    # the heading alone, the direction FEJ keeps unobservable: EKF SLAM above its band too
    lo1, hi1 = chi2_band(1, len(seeds))
    assert mc["slam"].average(heading=True)[-1] > hi1


@pytest.mark.parametrize("method", ["slam", "fej", "ideal", "localization"])
def test_public_api_monte_carlo_nees_with_every_method(method):
    st = studies.monte_carlo_nees("arena_loop", method, seeds=(7, 8), step=2.0)
    assert st.nees.shape == (2, st.t.size) and st.t.size > 20
    assert np.all(np.isfinite(st.nees)) and np.all(st.nees >= 0.0)
    assert st.method == method and st.seeds == (7, 8)
    with pytest.raises(ValueError, match="method"):
        studies.monte_carlo_nees("arena_loop", "ukf", seeds=(7,))


def test_public_api_fej_is_used_like_ekf_slam():
    f = FEJEKFSLAM([0.0, 0.0, 0.0], np.eye(3) * 1e-6, Q, R, gate=0.95)
    f.predict([0.2, 0.2], 0.1)
    rep = f.update([3, 4], [[1.0, 0.1], [2.0, -0.3]])
    assert list(rep.new) == [True, True] and np.all(np.isnan(rep.d2))
    f.predict([0.2, 0.2], 0.1)
    rep = f.update([3], [observe(f.pose, f.landmark(3))])
    assert rep.accepted[0] and np.isfinite(rep.d2[0])
    assert f.landmark_ids == [3, 4] and f.x.shape == (7,) and f.P.shape == (7, 7)
    assert f.pose.shape == (3,) and f.pose_cov.shape == (3, 3)
    with pytest.raises(ValueError, match="z"):
        f.update([3], [[np.nan, 0.0]])


def test_fej_given_a_true_map_but_no_truth_ignores_the_map():
    """A true map is used only by a link at the truth: FEJ given one (and no true
    trajectory) runs, and filters exactly as FEJ without it."""
    with_map = FEJEKFSLAM([0.0, 0.0, 0.1], np.eye(3) * 1e-4, Q, R, landmarks=LANDMARKS)
    plain = FEJEKFSLAM([0.0, 0.0, 0.1], np.eye(3) * 1e-4, Q, R)
    ids = np.array(sorted(LANDMARKS))
    for f in (with_map, plain):
        for k in range(3):
            f.predict(np.array([0.2, 0.21]), 0.1)
            pose = f.pose
            f.update(ids, np.array([observe(pose, LANDMARKS[i]) + 0.01 * k for i in ids]))
    assert np.array_equal(with_map.x, plain.x) and np.array_equal(with_map.P, plain.P)
