"""The models against closed forms and finite differences (hypothesis over random inputs)."""

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from slamlib.checks import compare_jacobians, numerical_jacobian
from slamlib.models import (
    KOBUKI_TICKS_PER_REV,
    body_velocity,
    compose_point,
    compose_point_jacobians,
    compose_poses,
    compose_poses_jacobians,
    inverse_observation_jacobians,
    inverse_observe,
    invert_pose,
    motion_jacobians,
    motion_model,
    motion_model_batch,
    observation_jacobians,
    observe,
    polar_to_cartesian,
    polar_to_cartesian_jacobian,
    tick_difference,
    wheel_speeds,
    wheel_speeds_from_ticks,
    wrap_angle,
)

coord = st.floats(-20, 20)
angle = st.floats(-math.pi, math.pi)
# headings and bearings clustered at the +-pi seam as well as spread out
seam_angle = st.one_of(angle, st.floats(math.pi - 1e-3, math.pi),
                       st.floats(-math.pi, -math.pi + 1e-3))
speed = st.floats(-1.0, 1.0)
pose_st = st.tuples(coord, coord, seam_angle).map(np.array)
point_st = st.tuples(coord, coord).map(np.array)


def close(a, b, tol=1e-6):
    return np.allclose(a, b, atol=tol, rtol=1e-5)


# ----------------------------------------------------------------- wrap_angle
@pytest.mark.parametrize("a, w", [(0.0, 0.0), (math.pi, -math.pi), (-math.pi, -math.pi),
                                  (3 * math.pi, -math.pi), (2 * math.pi, 0.0),
                                  (-1e-18, -1e-18), (7.0, 7.0 - 2 * math.pi)])
def test_wrap_angle_seams(a, w):
    assert wrap_angle(a) == pytest.approx(w, abs=1e-12)


@given(st.floats(-1e4, 1e4))
def test_wrap_angle_range_and_equivalence(a):
    w = wrap_angle(a)
    assert -math.pi <= w < math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(a), abs_tol=1e-9)


def test_wrap_angle_tiny_negative_never_returns_pi():
    assert wrap_angle(-1e-17) < math.pi
    arr = wrap_angle(np.array([-1e-17, math.pi, -math.pi]))
    assert np.all(arr < math.pi) and np.all(arr >= -math.pi)


# ----------------------------------------------------------------- wheels
def test_tick_difference_wraps_16_bit_counter():
    assert tick_difference(5, 65530) == 11
    assert tick_difference(65530, 5) == -11
    assert tick_difference(1000, 900) == 100


def test_wheel_speeds_closed_forms():
    assert close(wheel_speeds(10.0, -4.0, radius=0.035), [0.35, -0.14])
    # one wheel revolution in one second: 2 pi r m/s
    u = wheel_speeds_from_ticks(KOBUKI_TICKS_PER_REV, 0.0, 1.0)
    assert close(u, [2 * math.pi * 0.035, 0.0])


def test_body_velocity_z_down_sign():
    # faster left wheel -> clockwise from above -> positive rate in the z-down frame
    v, w = body_velocity([0.1, 0.3], wheel_base=0.2)
    assert v == pytest.approx(0.2) and w == pytest.approx(1.0)


# ----------------------------------------------------------------- motion
def test_motion_model_closed_form_straight_and_spin():
    x = motion_model([1.0, 2.0, math.pi / 2], [0.5, 0.5], 2.0)
    assert close(x, [1.0, 3.0, math.pi / 2])
    b = 0.23
    x = motion_model([0.0, 0.0, 0.0], [-0.1, 0.1], 1.0, wheel_base=b)
    assert close(x, [0.0, 0.0, 0.2 / b])


def test_motion_model_full_circle_returns_heading():
    # spinning in place for one period comes back to the same heading
    b, v = 0.23, 0.1
    period = 2 * math.pi * b / (2 * v)
    x = np.zeros(3)
    n = 1000
    for _ in range(n):
        x = motion_model(x, [-v, v], period / n, wheel_base=b)
    assert abs(wrap_angle(x[2])) < 1e-9


@given(pose_st, st.tuples(speed, speed).map(np.array), st.floats(0.0, 0.5), st.floats(0.1, 1.0))
def test_motion_jacobians_match_finite_differences(x, u, dt, b):
    A, W = motion_jacobians(x, u, dt, b)
    A_fd = numerical_jacobian(lambda s: motion_model(s, u, dt, b), x, angle_outputs=[2])
    W_fd = numerical_jacobian(lambda n: motion_model(x, u + n, dt, b), np.zeros(2),
                              angle_outputs=[2])
    assert compare_jacobians("A", A, A_fd), compare_jacobians("A", A, A_fd).message
    assert compare_jacobians("W", W, W_fd), compare_jacobians("W", W, W_fd).message


def test_motion_jacobians_zero_speed():
    A, W = motion_jacobians([1.0, -2.0, 0.3], [0.0, 0.0], 0.1)
    assert close(A, np.eye(3))
    assert close(W[2], [-0.1 / 0.23, 0.1 / 0.23])


# ----------------------------------------------------------------- observation
def test_motion_model_batch_equals_motion_model_row_by_row():
    rng = np.random.default_rng(11)
    n = 500
    X = np.column_stack([rng.uniform(-5, 5, n), rng.uniform(-5, 5, n),
                         rng.uniform(-math.pi, math.pi, n)])
    X[:50, 2] = rng.choice([math.pi - 1e-4, -math.pi + 1e-4], 50)    # on the seam
    U = rng.uniform(-1.0, 1.0, (n, 2))
    for dt, b in ((0.02, 0.23), (0.7, 0.4)):                  # 0.7 s: turns cross the seam
        got = motion_model_batch(X, U, dt, b)
        want = np.array([motion_model(x, u, dt, b) for x, u in zip(X, U)])
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        assert np.all((got[:, 2] >= -math.pi) & (got[:, 2] < math.pi))
        crossed = np.abs(X[:, 2] + (U[:, 1] - U[:, 0]) / b * dt) > math.pi
        assert np.count_nonzero(crossed) > 10                  # the wrap was exercised
    # one control for all rows
    np.testing.assert_allclose(motion_model_batch(X[:3], [0.2, 0.1], 0.1),
                               [motion_model(x, [0.2, 0.1], 0.1) for x in X[:3]])


@pytest.mark.parametrize("call, name", [
    (lambda: motion_model_batch(np.zeros((4, 2)), np.zeros((4, 2)), 0.1), "X"),
    (lambda: motion_model_batch(np.zeros((4, 3)), np.zeros((3, 2)), 0.1), "U"),
    (lambda: motion_model_batch(np.zeros((4, 3)), np.zeros((4, 2)), -0.1), "dt"),
])
def test_motion_model_batch_bad_input_names_the_argument(call, name):
    with pytest.raises(ValueError, match=rf"^{name}:"):
        call()


def test_observe_closed_form():
    # robot at origin facing +x (north); landmark 1 m to the right (+y): bearing +pi/2
    assert close(observe([0, 0, 0], [0, 1]), [1, math.pi / 2])
    assert close(observe([1, 1, math.pi / 2], [1, 3]), [2, 0])
    # landmark straight behind: bearing on the seam, wrapped to -pi
    assert close(observe([0, 0, 0], [-2, 0]), [2, -math.pi])


@given(pose_st, point_st)
def test_observation_jacobians_match_finite_differences(pose, lm):
    d = np.hypot(*(lm - pose[:2]))
    assume(d > 1e-2)
    Hp, Hl = observation_jacobians(pose, lm)
    Hp_fd = numerical_jacobian(lambda p: observe(p, lm), pose, eps=1e-7 * max(1, d),
                               angle_outputs=[1])
    Hl_fd = numerical_jacobian(lambda m: observe(pose, m), lm, eps=1e-7 * max(1, d),
                               angle_outputs=[1])
    tol = 1e-5 / min(1.0, d) ** 2
    assert compare_jacobians("H_pose", Hp, Hp_fd, atol=tol)
    assert compare_jacobians("H_landmark", Hl, Hl_fd, atol=tol)


@pytest.mark.parametrize("offset", [1e-2, 1e-3])
def test_observation_jacobians_landmark_very_close(offset):
    pose = np.array([0.5, -0.2, 2.0])
    lm = pose[:2] + offset * np.array([0.6, -0.8])
    Hp, Hl = observation_jacobians(pose, lm)
    eps = offset * 1e-4
    Hp_fd = numerical_jacobian(lambda p: observe(p, lm), pose, eps=eps, angle_outputs=[1])
    Hl_fd = numerical_jacobian(lambda m: observe(pose, m), lm, eps=eps, angle_outputs=[1])
    assert np.allclose(Hp, Hp_fd, rtol=1e-5, atol=1e-6)
    assert np.allclose(Hl, Hl_fd, rtol=1e-5, atol=1e-6)


def test_observation_jacobians_behind_robot_on_seam():
    pose = np.array([0.0, 0.0, 0.0])
    lm = np.array([-3.0, 1e-12])  # bearing exactly at the +-pi seam
    Hp, _ = observation_jacobians(pose, lm)
    Hp_fd = numerical_jacobian(lambda p: observe(p, lm), pose, angle_outputs=[1])
    assert np.allclose(Hp, Hp_fd, atol=1e-6)


def test_observation_jacobian_landmark_at_robot_is_an_error():
    with pytest.raises(ValueError, match="landmark"):
        observation_jacobians([1.0, 1.0, 0.0], [1.0, 1.0])


def test_landmark_jacobian_is_minus_pose_jacobian_position_block():
    Hp, Hl = observation_jacobians([0.3, 0.4, 1.0], [2.0, -1.0])
    assert close(Hl, -Hp[:, :2])


# ----------------------------------------------------------------- inverse observation
@given(pose_st, st.floats(0.0, 10.0), seam_angle)
def test_inverse_observe_inverts_observe(pose, rho, beta):
    assume(rho > 1e-6)
    lm = inverse_observe(pose, [rho, beta])
    z = observe(pose, lm)
    assert z[0] == pytest.approx(rho, abs=1e-9)
    assert abs(wrap_angle(z[1] - beta)) < 1e-7


@given(pose_st, st.floats(0.0, 10.0), seam_angle)
def test_inverse_observation_jacobians_match_finite_differences(pose, rho, beta):
    z = np.array([rho, beta])
    J1, J2 = inverse_observation_jacobians(pose, z)
    J1_fd = numerical_jacobian(lambda p: inverse_observe(p, z), pose)
    # the range must stay >= 0 under the difference: use a one-sided-safe point
    zz = np.array([max(rho, 1e-5), beta])
    J2_fd = numerical_jacobian(lambda q: inverse_observe(pose, q), zz, eps=1e-6)
    _, J2b = inverse_observation_jacobians(pose, zz)
    assert compare_jacobians("J1", J1, J1_fd, atol=1e-5)
    assert compare_jacobians("J2", J2b, J2_fd, atol=1e-5)
    # closed form of J2
    c, s = math.cos(pose[2] + beta), math.sin(pose[2] + beta)
    assert close(J2, [[c, -rho * s], [s, rho * c]], tol=1e-9)


@given(pose_st, point_st)
def test_compose_point_jacobians_match_finite_differences(pose, p):
    J1, J2 = compose_point_jacobians(pose, p)
    assert np.allclose(J1, numerical_jacobian(lambda a: compose_point(a, p), pose), atol=1e-5)
    assert np.allclose(J2, numerical_jacobian(lambda q: compose_point(pose, q), p), atol=1e-5)


@given(st.floats(0.0, 10.0), angle)
def test_polar_to_cartesian_jacobian(rho, beta):
    z = np.array([max(rho, 1e-5), beta])
    J = polar_to_cartesian_jacobian(z)
    assert np.allclose(J, numerical_jacobian(polar_to_cartesian, z), atol=1e-5)


@given(pose_st, pose_st)
def test_compose_poses_jacobians_and_inverse(a, b):
    J1, J2 = compose_poses_jacobians(a, b)
    assert np.allclose(J1, numerical_jacobian(lambda q: compose_poses(q, b), a,
                                              angle_outputs=[2]), atol=1e-5)
    assert np.allclose(J2, numerical_jacobian(lambda q: compose_poses(a, q), b,
                                              angle_outputs=[2]), atol=1e-5)
    e = compose_poses(invert_pose(a), a)
    assert np.allclose(e[:2], 0.0, atol=1e-9) and abs(wrap_angle(e[2])) < 1e-9


def test_inverse_observation_chain_equals_composition():
    pose, z = np.array([1.0, 2.0, 0.7]), np.array([2.5, -0.4])
    assert close(inverse_observe(pose, z), compose_point(pose, polar_to_cartesian(z)), 1e-12)


# ----------------------------------------------------------------- bad input
@pytest.mark.parametrize("call, name", [
    (lambda: motion_model([0, 0], [0, 0], 0.1), "x"),
    (lambda: motion_model([0, 0, np.nan], [0, 0], 0.1), "x"),
    (lambda: motion_model([0, 0, 0], [0, np.inf], 0.1), "u"),
    (lambda: motion_model([0, 0, 0], [0, 0], -0.1), "dt"),
    (lambda: motion_jacobians([0, 0, 0], [0, 0], 0.1, wheel_base=0.0), "wheel_base"),
    (lambda: observe([0, 0, 0], [1, 2, 3]), "landmark"),
    (lambda: observe([[0, 0, 0]], [1, 2]), "pose"),
    (lambda: observation_jacobians([0, 0, 0], [np.nan, 1]), "landmark"),
    (lambda: inverse_observe([0, 0, 0], [-1.0, 0.0]), "z"),
    (lambda: inverse_observe([0, 0, 0], [1.0]), "z"),
    (lambda: inverse_observation_jacobians([0, 0, np.inf], [1.0, 0.0]), "pose"),
    (lambda: wheel_speeds_from_ticks(10, 10, 0.0), "dt"),
    (lambda: wrap_angle(np.nan), "angle"),
    (lambda: motion_model("abc", [0, 0], 0.1), "x"),
])
def test_bad_input_names_the_argument(call, name):
    with pytest.raises(ValueError, match=rf"^{name}:"):
        call()
