"""The models of the course: wheels, motion, observation, inverse observation.

All quantities are in the report's world frame N, which is **z-down** (x
forward/north, y right/east, z into the floor): a positive angle turns
clockwise seen from above and a positive bearing lies to the robot's right.
Chapter 00 explains the convention; chapter 01 derives the motion model,
chapter 03 the direct observation and chapter 04 the inverse observation.

Every model ``f`` has a sibling ``f_jacobians`` (or ``..._jacobian``) that
returns its Jacobians under the report's names (A, W, H, J1, J2). Each
Jacobian is checked against finite differences in ``tests/test_models.py``.

Conventions
-----------
- pose ``x = [x, y, theta]`` (m, m, rad), theta wrapped to [-pi, pi)
- control ``u = [V_R, V_L]``: right and left wheel linear speeds (m/s)
- observation ``z = [rho, beta]``: range (m) and bearing (rad) of a landmark,
  measured in the robot frame B from B's origin
- landmark ``m = [x_F, y_F]`` in N
"""

from __future__ import annotations

import math

import numpy as np

from .compiled import compiled
from .validate import as_finite_scalar, as_matrix, as_positive, as_vector

__all__ = [
    "KOBUKI_WHEEL_BASE", "KOBUKI_WHEEL_RADIUS", "KOBUKI_TICKS_PER_REV",
    "wrap_angle", "tick_difference", "wheel_speeds", "wheel_speeds_from_ticks",
    "body_velocity", "body_speeds", "motion_model", "motion_jacobians", "motion_model_batch",
    "observe", "observation_jacobians", "observe_landmarks", "range_bearing",
    "polar_to_cartesian", "polar_to_cartesian_jacobian",
    "compose_point", "compose_point_jacobians",
    "compose_poses", "compose_poses_jacobians", "invert_pose",
    "inverse_observe", "inverse_observation_jacobians", "wrap",
]

#: Kobuki wheel base b (m), distance between the wheels' contact points.
KOBUKI_WHEEL_BASE = 0.23
#: Kobuki wheel radius r (m).
KOBUKI_WHEEL_RADIUS = 0.035
#: Kobuki encoder ticks per wheel revolution (52 ticks/motor rev x 6545/132 gear).
KOBUKI_TICKS_PER_REV = 52 * 6545 / 132

_PI = float(np.pi)
_TWO_PI = 2.0 * float(np.pi)


# --------------------------------------------------------------------------- angles
def wrap_angle(angle):
    """Wrap an angle (or an array of angles) to [-pi, pi).

    Parameters
    ----------
    angle : float or array_like
        Angle(s) in radians (finite).

    Returns
    -------
    float or numpy.ndarray
        The same angle(s) in [-pi, pi); a float for a scalar input.
    """
    a = np.asarray(angle, dtype=float)
    if not np.isfinite(a).all():
        raise ValueError(f"angle: expected finite numbers, got {angle!r}")
    w = wrap(a)
    return float(w) if w.ndim == 0 else w


def wrap(a):
    """:func:`wrap_angle` without the check: ``(a + pi) mod 2 pi - pi``, floats or arrays.

    The one formula of the wrap (the filters, the simulator and the sensors use
    it). ``mod`` takes the sign of the divisor (Python's ``%`` on floats and
    numpy's on arrays alike), and can round up to exactly ``2 pi`` for tiny
    negative inputs: that case is moved down by ``2 pi``.
    """
    w = (a + _PI) % _TWO_PI - _PI
    return w - _TWO_PI * (w >= _PI)


_wrap = compiled(wrap)                       # the same function, for compiled callers


# --------------------------------------------------------------------------- wheels
def tick_difference(now, before, bits: int = 16):
    """Signed tick increment of a wrapping encoder counter (chapter 01).

    The Kobuki reports each wheel's position as an unsigned ``bits``-bit
    counter that wraps around; the increment between two readings is the
    difference taken modulo ``2**bits`` and mapped to the signed range.

    Parameters
    ----------
    now, before : int or array_like of int
        Counter readings.
    bits : int
        Counter width (16 on the Kobuki).

    Returns
    -------
    int or numpy.ndarray
        ``now - before`` in ``[-2**(bits-1), 2**(bits-1))``.
    """
    span = 1 << bits
    d = (np.asarray(now, dtype=np.int64) - np.asarray(before, dtype=np.int64)) % span
    d = np.where(d >= span // 2, d - span, d)
    return int(d) if d.ndim == 0 else d


def wheel_speeds(omega_R: float, omega_L: float, radius: float = KOBUKI_WHEEL_RADIUS
                 ) -> np.ndarray:
    """Wheel angular rates to wheel linear speeds, ``V = omega * r`` (report III.B).

    Returns
    -------
    numpy.ndarray
        ``u = [V_R, V_L]`` in m/s.
    """
    r = as_positive("radius", radius)
    wr = as_finite_scalar("omega_R", omega_R)
    wl = as_finite_scalar("omega_L", omega_L)
    return np.array([wr * r, wl * r])


def wheel_speeds_from_ticks(dticks_R: float, dticks_L: float, dt: float,
                            ticks_per_rev: float = KOBUKI_TICKS_PER_REV,
                            radius: float = KOBUKI_WHEEL_RADIUS) -> np.ndarray:
    """Encoder tick increments over ``dt`` to mean wheel linear speeds (chapter 01).

    ``V = 2 pi r * dticks / (ticks_per_rev * dt)`` for each wheel.

    Returns
    -------
    numpy.ndarray
        ``u = [V_R, V_L]`` in m/s.
    """
    dt = as_positive("dt", dt)
    n = as_positive("ticks_per_rev", ticks_per_rev)
    r = as_positive("radius", radius)
    k = 2.0 * np.pi * r / (n * dt)
    return np.array([k * as_finite_scalar("dticks_R", dticks_R),
                     k * as_finite_scalar("dticks_L", dticks_L)])


def body_velocity(u, wheel_base: float = KOBUKI_WHEEL_BASE) -> tuple[float, float]:
    """Wheel speeds to body speeds (report III.B, z-down).

    ``V = (V_R + V_L) / 2`` and ``w = (V_L - V_R) / b``: in the z-down frame a
    faster left wheel turns the robot clockwise seen from above, which is a
    positive rotation. (The report writes ``/ h``: a typo for ``/ b``.)

    Returns
    -------
    (float, float)
        Linear speed V (m/s) and angular speed w (rad/s).
    """
    u = as_vector("u", u, 2)
    return body_speeds(float(u[0]), float(u[1]), as_positive("wheel_base", wheel_base))


def body_speeds(V_R, V_L, b):
    """:func:`body_velocity` without the checks, for floats or arrays: ``(V, w)``.

    The one home of ``V = (V_R + V_L)/2`` and ``w = (V_L - V_R)/b`` (z-down):
    the motion model, the simulator and the batch model use it.
    """
    return 0.5 * (V_R + V_L), (V_L - V_R) / b


_body_speeds = compiled(body_speeds)


# --------------------------------------------------------------------------- motion
def _check_motion_args(x, u, dt, wheel_base):
    x = as_vector("x", x, 3)
    u, dt = _check_control(u, dt)
    return x, u, dt, as_positive("wheel_base", wheel_base)


def _check_control(u, dt) -> tuple[np.ndarray, float]:
    """``u`` (2,) finite and ``dt >= 0`` finite, or a ValueError naming them (the one check of a
    prediction's input; an array of two finite floats and a float pass without copies)."""
    if not (type(u) is np.ndarray and u.dtype == np.float64 and u.shape == (2,)
            and math.isfinite(u[0]) and math.isfinite(u[1])):
        u = as_vector("u", u, 2)
    if type(dt) is not float or not math.isfinite(dt):
        dt = as_finite_scalar("dt", dt)
    if dt < 0.0:
        raise ValueError(f"dt: expected a non-negative time step, got {dt}")
    return u, dt


def motion_model(x, u, dt: float, wheel_base: float = KOBUKI_WHEEL_BASE) -> np.ndarray:
    """Differential-drive motion model ``x_k = f(x_{k-1}, u_k)`` (report III.C, chapter 01).

    Euler step with the heading at the start of the step::

        x_k     = x_{k-1} + V cos(theta_{k-1}) dt
        y_k     = y_{k-1} + V sin(theta_{k-1}) dt
        theta_k = theta_{k-1} + w dt

    with ``V = (V_R + V_L)/2`` and ``w = (V_L - V_R)/b`` (z-down).

    Parameters
    ----------
    x : array_like, shape (3,)
        Pose ``[x, y, theta]`` at k-1.
    u : array_like, shape (2,)
        Wheel speeds ``[V_R, V_L]`` (m/s), the noise already added if any.
    dt : float
        Time step (s), >= 0.
    wheel_base : float
        b (m).

    Returns
    -------
    numpy.ndarray, shape (3,)
        Pose at k, heading wrapped to [-pi, pi).
    """
    return _motion_model(*_check_motion_args(x, u, dt, wheel_base))


@compiled
def _motion_model(x, u, dt: float, b: float) -> np.ndarray:
    """:func:`motion_model` on checked arguments (the filters' predict checks them once)."""
    V, w = _body_speeds(float(u[0]), float(u[1]), b)
    th = float(x[2])
    return np.array([x[0] + V * math.cos(th) * dt,          # x + V cos(theta) dt
                     x[1] + V * math.sin(th) * dt,          # y + V sin(theta) dt
                     _wrap(th + w * dt)])                   # theta + w dt, wrapped


def motion_jacobians(x, u, dt: float, wheel_base: float = KOBUKI_WHEEL_BASE
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of :func:`motion_model` (chapter 01).

    ``A = df/dx_{k-1}`` (3x3) and ``W = df/dw`` (3x2), where ``w = [w_R, w_L]``
    is the noise on the measured wheel speeds ``u = [V_R, V_L]`` (covariance Q),
    so that the prediction adds ``W Q W^T``; the columns of W are in the order
    of u. (Because w adds to u, W has the same entries as ``df/du``; the course
    calls it the Jacobian with respect to the noise, as the report does.)::

        A = [[1, 0, -V sin(theta) dt],      W = [[cos(theta) dt/2, cos(theta) dt/2],
             [0, 1,  V cos(theta) dt],           [sin(theta) dt/2, sin(theta) dt/2],
             [0, 0,  1              ]]           [-dt/b,            dt/b          ]]

    (The report writes ``A = df/dx_k``; the derivative is with respect to the
    previous pose ``x_{k-1}``.)

    Returns
    -------
    (A, W) : (numpy.ndarray (3, 3), numpy.ndarray (3, 2))
    """
    return _motion_jacobians(*_check_motion_args(x, u, dt, wheel_base))


@compiled
def _motion_jacobians(x, u, dt: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`motion_jacobians` on checked arguments (the filters' predict checks them once)."""
    V, _ = _body_speeds(float(u[0]), float(u[1]), b)
    c, s = math.cos(float(x[2])), math.sin(float(x[2]))
    A = np.array([[1.0, 0.0, -(V * s * dt)],              # d f / d x_{k-1}
                  [0.0, 1.0, V * c * dt],
                  [0.0, 0.0, 1.0]])
    W = np.array([[0.5 * c * dt, 0.5 * c * dt],           # d f / d [w_R, w_L]
                  [0.5 * s * dt, 0.5 * s * dt],
                  [-(dt / b), dt / b]])
    return A, W


def motion_model_batch(X, U, dt: float, wheel_base: float = KOBUKI_WHEEL_BASE) -> np.ndarray:
    """:func:`motion_model` for many poses at once (chapter 01's Monte-Carlo check).

    The same equation, applied row by row: row ``i`` of the result is
    ``motion_model(X[i], U[i], dt, wheel_base)``, heading wrapped to [-pi, pi).

    Parameters
    ----------
    X : array_like, shape (n, 3)
        Poses ``[x, y, theta]`` at k-1, one per row.
    U : array_like, shape (n, 2) or (2,)
        Wheel speeds ``[V_R, V_L]`` per row (noise already added), or one pair for all.
    dt : float
        Time step (s), >= 0.
    wheel_base : float
        b (m).

    Returns
    -------
    numpy.ndarray, shape (n, 3)
    """
    X = as_matrix("X", X, (None, 3))
    U = np.asarray(U, dtype=float)
    U = as_matrix("U", np.broadcast_to(U, (X.shape[0], 2)) if U.shape == (2,) else U,
                  (X.shape[0], 2))
    dt = as_finite_scalar("dt", dt)
    if dt < 0.0:
        raise ValueError(f"dt: expected a non-negative time step, got {dt}")
    v, w = body_speeds(U[:, 0], U[:, 1], as_positive("wheel_base", wheel_base))
    return np.column_stack([X[:, 0] + v * np.cos(X[:, 2]) * dt,
                            X[:, 1] + v * np.sin(X[:, 2]) * dt,
                            wrap_angle(X[:, 2] + w * dt)])

# --------------------------------------------------------------------------- direct observation
def observe(pose, landmark) -> np.ndarray:
    """Direct observation ``z = h(x_B, x_F)`` (report V.A, chapter 03).

    ``rho = sqrt(dx^2 + dy^2)`` and ``beta = atan2(dy, dx) - theta`` (wrapped),
    with ``dx = x_F - x_B`` and ``dy = y_F - y_B``: :func:`observe_landmarks`
    for one landmark.

    Parameters
    ----------
    pose : array_like, shape (3,)
        Robot pose in N.
    landmark : array_like, shape (2,)
        Landmark position in N.

    Returns
    -------
    numpy.ndarray, shape (2,)
        ``[rho, beta]`` (a landmark on the robot: range 0, bearing ``-theta``).
    """
    pose = as_vector("pose", pose, 3)
    landmark = as_vector("landmark", landmark, 2)
    h = observe_landmarks(pose, landmark[None, :])[0][0]
    if not np.isfinite(h[1]):              # on the robot: range 0, atan2(0, 0) = 0
        h = np.array([0.0, wrap_angle(-pose[2])])
    return h


def observation_jacobians(pose, landmark) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of :func:`observe` (chapter 03): :func:`observe_landmarks` for one landmark.

    With ``q = dx^2 + dy^2`` and ``r = sqrt(q)``::

        H_pose     = [[-dx/r, -dy/r,  0],      H_landmark = [[ dx/r, dy/r],
                      [ dy/q, -dx/q, -1]]                    [-dy/q, dx/q]]

    The report prints ``+dx/q`` in ``H_pose[1, 1]`` and ``+dy/q`` in
    ``H_landmark[1, 0]``: both signs are wrong (appendix A).

    Raises
    ------
    ValueError
        If the landmark coincides with the robot (the bearing is undefined).
    """
    pose = as_vector("pose", pose, 3)
    landmark = as_vector("landmark", landmark, 2)
    _, H_pose, H_landmark = observe_landmarks(pose, landmark[None, :])
    if not np.isfinite(H_landmark).all():
        raise ValueError("landmark: coincides with the robot's position; "
                         "the bearing and its Jacobian are undefined")
    return H_pose[0], H_landmark[0]


@compiled
def range_bearing(dx, dy, theta):
    """``h`` from the offsets of a point (floats or arrays, broadcast; no checks).

    ``rho = sqrt(dx^2 + dy^2)`` and ``beta = atan2(dy, dx) - theta`` (wrapped),
    with ``dx = x_F - x_B``, ``dy = y_F - y_B`` and ``theta`` the heading of
    the frame the point is seen from: the one home of the formula, which the
    filters (:func:`observe_landmarks`), the sensors and the data tools use.
    Compiled by numba: arctan2 is the C library's ``atan2``.

    Returns
    -------
    (rho, beta)
    """
    return np.hypot(dx, dy), _wrap(np.arctan2(dy, dx) - theta)   # _wrap = compiled(wrap)


@compiled
def observe_landmarks(pose, landmarks) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The direct observation of k landmarks and its Jacobians, vectorised (chapter 03).

    The one implementation of ``h`` and ``H``: :func:`observe` and
    :func:`observation_jacobians` are this function for one landmark, and the
    filters' update runs it on every landmark a frame reads. Per landmark, with
    ``dx = x_F - x_B``, ``dy = y_F - y_B``, ``q = dx^2 + dy^2`` and ``r = sqrt(q)``::

        h          = [r, atan2(dy, dx) - theta]          (bearing wrapped)
        H_pose     = [[-dx/r, -dy/r,  0],   H_landmark = [[ dx/r, dy/r],
                      [ dy/q, -dx/q, -1]]                 [-dy/q, dx/q]]

    (The report prints ``+dx/q`` in ``H_pose[1, 1]`` and ``+dy/q`` in
    ``H_landmark[1, 0]``: both signs are wrong, appendix A.) A landmark on top
    of the robot has no bearing: its rows of ``h``, ``H_landmark`` and the
    first two columns of ``H_pose`` come back NaN. No checks: the callers check.
    Compiled by numba (as :func:`range_bearing`), so it takes arrays of floats.

    Parameters
    ----------
    pose : numpy.ndarray of float, shape (3,)
    landmarks : numpy.ndarray of float, shape (k, 2)

    Returns
    -------
    (h, H_pose, H_landmark) : arrays of shapes (k, 2), (k, 2, 3), (k, 2, 2)
    """
    L = np.ascontiguousarray(landmarks).reshape(-1, 2)      # (numba reshapes contiguous arrays)
    dx, dy = L[:, 0] - pose[0], L[:, 1] - pose[1]
    r, beta = range_bearing(dx, dy, pose[2])                # h = [r, beta]
    q = dx * dx + dy * dy
    if not q.all():                                         # a landmark on the robot: no bearing
        on_robot = q == 0.0
        r[on_robot], beta[on_robot], q[on_robot] = np.nan, np.nan, np.nan
    k = L.shape[0]
    h, H_landmark, H_pose = np.empty((k, 2)), np.empty((k, 2, 2)), np.empty((k, 2, 3))
    h[:, 0], h[:, 1] = r, beta
    H_landmark[:, 0, 0], H_landmark[:, 0, 1] = dx / r, dy / r         # d rho / d x_F
    H_landmark[:, 1, 0], H_landmark[:, 1, 1] = -dy / q, dx / q        # d beta / d x_F
    H_pose[:, :, :2] = -H_landmark                          # H_pose = [-H_landmark, [0; -1]]
    H_pose[:, 0, 2], H_pose[:, 1, 2] = 0.0, -1.0
    return h, H_pose, H_landmark


# --------------------------------------------------------------------------- inverse observation
def _check_z(z):
    z = as_vector("z", z, 2)
    if z[0] < 0.0:
        raise ValueError(f"z: expected a non-negative range z[0], got {z[0]}")
    return z


def polar_to_cartesian(z) -> np.ndarray:
    """Polar ``[rho, beta]`` to a point ``[rho cos beta, rho sin beta]`` in B (chapter 04)."""
    z = _check_z(z)
    return np.array([z[0] * np.cos(z[1]), z[0] * np.sin(z[1])])


def polar_to_cartesian_jacobian(z) -> np.ndarray:
    """Jacobian of :func:`polar_to_cartesian`: ``[[cos b, -rho sin b], [sin b, rho cos b]]``."""
    z = _check_z(z)
    c, s = np.cos(z[1]), np.sin(z[1])
    return np.array([[c, -z[0] * s], [s, z[0] * c]])


def compose_point(pose, point) -> np.ndarray:
    """Compounding ``x_B (+) p``: a point in B expressed in N (report V.B, chapter 04).

    ``[x + p_x cos(theta) - p_y sin(theta), y + p_x sin(theta) + p_y cos(theta)]``.
    """
    pose = as_vector("pose", pose, 3)
    p = as_vector("point", point, 2)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.array([pose[0] + c * p[0] - s * p[1], pose[1] + s * p[0] + c * p[1]])


def compose_point_jacobians(pose, point) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of :func:`compose_point` (chapter 04).

    ``J1 = d/d pose = [[1, 0, -p_x sin - p_y cos], [0, 1, p_x cos - p_y sin]]`` and
    ``J2 = d/d point = R(theta)``. (The report's J1 has ``^N x`` for ``^B x`` in
    ``J1[1, 2]``: a typo, appendix A.)
    """
    pose = as_vector("pose", pose, 3)
    p = as_vector("point", point, 2)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    J1 = np.array([[1.0, 0.0, -p[0] * s - p[1] * c],
                   [0.0, 1.0, p[0] * c - p[1] * s]])
    J2 = np.array([[c, -s], [s, c]])
    return J1, J2


def inverse_observe(pose, z) -> np.ndarray:
    """Inverse observation ``x_F = g(x_B, z) = x_B (+) polar_to_cartesian(z)`` (report V.B, ch. 04).

    Equals ``[x + rho cos(theta + beta), y + rho sin(theta + beta)]``.

    Parameters
    ----------
    pose : array_like, shape (3,)
        Robot pose in N.
    z : array_like, shape (2,)
        ``[rho, beta]``, rho >= 0.

    Returns
    -------
    numpy.ndarray, shape (2,)
        The landmark in N.
    """
    return compose_point(pose, polar_to_cartesian(z))


def inverse_observation_jacobians(pose, z) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of :func:`inverse_observe` by the chain rule (chapter 04).

    ``J1 = dg/d pose`` (2x3) is the compounding's J1 at ``p = polar_to_cartesian(z)``;
    ``J2 = dg/dz`` (2x2) is the compounding's ``R(theta)`` times the polar
    Jacobian, which simplifies to
    ``[[cos(theta+beta), -rho sin(theta+beta)], [sin(theta+beta), rho cos(theta+beta)]]``.
    Its columns are d/d rho and d/d beta (the report stacks them transposed).
    """
    p = polar_to_cartesian(z)
    J1, Jp = compose_point_jacobians(pose, p)
    return J1, Jp @ polar_to_cartesian_jacobian(z)


# --------------------------------------------------------------------------- poses
def compose_poses(a, b) -> np.ndarray:
    """Pose compounding ``a (+) b``: pose b, given in frame a, expressed in a's parent frame."""
    a = as_vector("a", a, 3)
    b = as_vector("b", b, 3)
    c, s = np.cos(a[2]), np.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1],
                     wrap_angle(a[2] + b[2])])


def compose_poses_jacobians(a, b) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians ``J1 = d(a(+)b)/da``, ``J2 = d(a(+)b)/db`` (3x3) of :func:`compose_poses`."""
    a = as_vector("a", a, 3)
    b = as_vector("b", b, 3)
    c, s = np.cos(a[2]), np.sin(a[2])
    J1 = np.array([[1.0, 0.0, -s * b[0] - c * b[1]],
                   [0.0, 1.0, c * b[0] - s * b[1]],
                   [0.0, 0.0, 1.0]])
    J2 = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return J1, J2


def invert_pose(a) -> np.ndarray:
    """Pose inversion ``(-)a``, so that ``compose_poses(invert_pose(a), a) == 0``."""
    a = as_vector("a", a, 3)
    c, s = np.cos(a[2]), np.sin(a[2])
    return np.array([-c * a[0] - s * a[1], s * a[0] - c * a[1], wrap_angle(-a[2])])
