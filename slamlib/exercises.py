"""Checkers for the chapters' exercises: they tell a student at once whether an answer is right.

Every checker takes the student's function, tries it at several random points
(a fixed seed, so the verdict does not flicker), prints a verdict a student can
act on and returns True or False. It never raises on a student's mistake:

- the function returns None or raises ``NotImplementedError``: "not written yet";
- it raises anything else: the exception is reported;
- it returns the wrong shape or wrong numbers: which entry is wrong, what was
  expected, and a hint when only the sign is flipped.

Chapter 00: :func:`check_pose_from_zup`.
Chapter 01: :func:`check_motion_jacobians`.
Chapter 02: :func:`check_camera_to_range_bearing`.
Chapter 03: :func:`check_observation_jacobians`.
Chapter 04: :func:`check_inverse_observation_jacobians`.
Chapter 05: :func:`check_gate` (wrapped innovation, Mahalanobis distance, chi-square gate).
Chapter 06: :func:`check_average_nees_band` (the chi-square band of a Monte-Carlo average NEES).
Chapter 07: :func:`check_in_field_of_view` (is a point inside the camera's field of view).
Chapter 08: :func:`check_history_index` (where a late frame goes in the filter's history).
Appendix A: :func:`check_numerical_jacobian`.
"""

from __future__ import annotations

import numpy as np

from .checks import compare_jacobians, numerical_jacobian
from .frames import pose_from_zup
from .models import KOBUKI_WHEEL_BASE, inverse_observe, motion_model, wrap_angle

__all__ = ["check_pose_from_zup", "check_motion_jacobians", "check_inverse_observation_jacobians"]


def _random_motion_points(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        x = np.array([rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-np.pi, np.pi)])
        u = rng.uniform(-0.5, 0.5, size=2)
        dt = float(rng.uniform(0.01, 0.5))
        yield x, u, dt


def _call(fn, *args):
    """Run the student's function; return (result, problem message or None)."""
    try:
        out = fn(*args)
    except NotImplementedError:
        return None, "not written yet (it raises NotImplementedError)"
    except Exception as exc:  # noqa: BLE001 - a student's bug is reported, not raised
        return None, f"it raised {type(exc).__name__}: {exc}"
    if out is None:
        return None, "not written yet (it returns None)"
    return out, None


def _printer(verbose: bool):
    """``print`` if verbose, else a function that prints nothing."""
    return print if verbose else (lambda *args, **kwargs: None)


def _not_ready(name: str, problem: str, what: str = "it") -> str:
    """The verdict for a function that is not written yet or raised."""
    todo = f"Write {what}" if problem.startswith("not written") else "Fix it"
    return f"{name}: {problem}. {todo}, then run this cell again."


# --------------------------------------------------------------------------- chapter 01
def check_motion_jacobians(fn, n_points: int = 5, seed: int = 1,
                           wheel_base: float = KOBUKI_WHEEL_BASE, verbose: bool = True) -> bool:
    """Check a student's ``fn(x, u, dt, b) -> (A, W)`` against finite differences (chapter 01).

    ``A = df/dx_{k-1}`` (3x3) and ``W = df/du`` (3x2, columns ``[V_R, V_L]``)
    of :func:`slamlib.models.motion_model` are compared with central
    differences at ``n_points`` random poses, wheel speeds and time steps.

    Returns
    -------
    bool
        True if both Jacobians are right at every point. A verdict is printed.
    """
    say = _printer(verbose)

    name = getattr(fn, "__name__", "your function")
    for i, (x, u, dt) in enumerate(_random_motion_points(n_points, seed)):
        out, problem = _call(fn, x.copy(), u.copy(), dt, wheel_base)
        if problem:
            say(_not_ready(name, problem, "A and W"))
            return False
        if not isinstance(out, (tuple, list)) or len(out) != 2:
            if isinstance(out, (tuple, list)):
                what = f"a {type(out).__name__} of {len(out)}"
            elif isinstance(out, np.ndarray):
                what = f"one numpy array of shape {out.shape}"
            else:
                what = f"a {type(out).__name__}"
            say(f"{name}: expected a pair (A, W), got {what}. Return A, W.")
            return False
        A, W = out
        A_ref = numerical_jacobian(lambda s, u=u, dt=dt: motion_model(s, u, dt, wheel_base), x,
                                   angle_outputs=(2,))
        W_ref = numerical_jacobian(lambda v, x=x, dt=dt: motion_model(x, v, dt, wheel_base), u,
                                   angle_outputs=(2,))
        where = (f"at x = [{x[0]:.3f}, {x[1]:.3f}, {x[2]:.3f}], u = [{u[0]:.3f}, {u[1]:.3f}], "
                 f"dt = {dt:.3f}, b = {wheel_base}")
        bad = [c for c in (compare_jacobians("A", A, A_ref, atol=1e-6, rtol=1e-5),
                           compare_jacobians("W", W, W_ref, atol=1e-6, rtol=1e-5)) if not c.ok]
        if bad:
            say(f"{name}: not right yet (test point {i + 1} of {n_points}, {where}).")
            W_arr = np.asarray(W, dtype=float) if np.shape(W) == (3, 2) else None
            if (W_arr is not None and np.all(np.isfinite(W_arr))
                    and np.allclose(W_arr[:, ::-1], W_ref, atol=1e-6, rtol=1e-5)
                    and not np.allclose(W_arr, W_ref, atol=1e-6, rtol=1e-5)):
                say("  Your W columns are swapped: column 0 is d/dV_R and column 1 is d/dV_L "
                    "(u = [V_R, V_L]). (Here that gives the same numbers as a turn rate of the "
                    "wrong sign: w = (V_L - V_R)/b in the z-down frame.)")
            for c in bad:
                say("  " + c.message)
            say("  Hint: A is the derivative with respect to the previous pose x_{k-1}; "
                "W's columns are d/dV_R and d/dV_L, and w = (V_L - V_R)/b in the z-down frame.")
            return False
    say(f"{name}: correct. A and W match finite differences at {n_points} random points.")
    return True


# --------------------------------------------------------------------------- chapter 00
def check_pose_from_zup(fn, n_points: int = 8, seed: int = 0, verbose: bool = True) -> bool:
    """Check a student's ``fn(pose_zup) -> pose_zdown`` for one pose ``[x, y, yaw]`` (chapter 00).

    Compared with :func:`slamlib.frames.pose_from_zup` at random poses, including
    headings on the +-pi seam; the heading must come back wrapped to [-pi, pi).
    """
    say = _printer(verbose)

    name = getattr(fn, "__name__", "your function")
    rng = np.random.default_rng(seed)
    poses = [np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-np.pi, np.pi)])
             for _ in range(n_points - 2)]
    poses += [np.array([1.0, 2.0, -np.pi]), np.array([-1.5, 0.5, np.pi - 1e-9])]
    for p in poses:
        out, problem = _call(fn, p.copy())
        if problem:
            say(_not_ready(name, problem, "it"))
            return False
        got = np.asarray(out, dtype=float)
        want = pose_from_zup(p)
        if got.shape != (3,):
            say(f"{name}: expected a pose of shape (3,), got shape {got.shape}")
            return False
        for k, label in enumerate(("x", "y", "heading")):
            diff = wrap_angle(got[k] - want[k]) if k == 2 else got[k] - want[k]
            if abs(diff) > 1e-9:
                hint = " (sign flipped)" if np.isclose(got[k], -want[k]) and want[k] else ""
                say(f"{name}: {label} is wrong for the z-up pose [{p[0]:.3f}, {p[1]:.3f}, "
                    f"{p[2]:.3f}]: got {got[k]:.4f}, expected {want[k]:.4f}{hint}.")
                return False
        if not -np.pi <= got[2] < np.pi:
            say(f"{name}: the heading {got[2]:.4f} is right but not wrapped to [-pi, pi).")
            return False
    say(f"{name}: correct at {len(poses)} poses, the +-pi seam included.")
    return True


# --------------------------------------------------------------------------- chapter 04
def _random_inverse_observation_points(n: int, seed: int):
    """Generic poses and readings: no heading on a multiple of pi/4, no bearing near 0."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        pose = np.array([rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-np.pi, np.pi)])
        z = np.array([rng.uniform(0.3, 5.0), rng.uniform(-1.3, 1.3)])
        yield pose, z


def _looks_like_report_J1_typo(c1, pose, z) -> bool:
    """J1 wrong in [1,2] only, with the report's ``^N x cos(theta) - ^B y sin(theta)``."""
    if [(r, c) for r, c, *_ in c1.wrong] != [(1, 2)]:
        return False
    got = c1.wrong[0][2]
    typo = pose[0] * np.cos(pose[2]) - z[0] * np.sin(z[1]) * np.sin(pose[2])
    return bool(np.isclose(got, typo, rtol=1e-5, atol=1e-7))


def check_inverse_observation_jacobians(fn, n_points: int = 6, seed: int = 4,
                                        verbose: bool = True) -> bool:
    """Check a student's ``fn(pose, z) -> (J1, J2)`` against finite differences (chapter 04).

    ``J1 = dg/d pose`` (2x3, columns x, y, theta) and ``J2 = dg/dz`` (2x2,
    columns rho, beta) of :func:`slamlib.models.inverse_observe` are compared
    with central differences at ``n_points`` seeded random poses and readings
    (generic points: a special point such as a heading of pi/2 can hide an error).
    A J2 that is the transpose of the right one (the report's layout) gets its
    own hint.

    Returns
    -------
    bool
        True if both Jacobians are right at every point. A verdict is printed.
    """
    say = _printer(verbose)

    name = getattr(fn, "__name__", "your function")
    for i, (pose, z) in enumerate(_random_inverse_observation_points(n_points, seed)):
        out, problem = _call(fn, pose.copy(), z.copy())
        if problem:
            say(_not_ready(name, problem, "J1 and J2"))
            return False
        try:
            J1, J2 = out
        except (TypeError, ValueError):
            say(f"{name}: expected a pair (J1, J2), got {type(out).__name__}")
            return False
        J1_ref = numerical_jacobian(lambda p, z=z: inverse_observe(p, z), pose)
        J2_ref = numerical_jacobian(lambda q, pose=pose: inverse_observe(pose, q), z)
        where = (f"at pose = [{pose[0]:.3f}, {pose[1]:.3f}, {pose[2]:.3f}], "
                 f"z = [{z[0]:.3f}, {z[1]:.3f}]")
        c1 = compare_jacobians("J1", J1, J1_ref)
        c2 = compare_jacobians("J2", J2, J2_ref)
        if c1.ok and c2.ok:
            continue
        say(f"{name}: not right yet (test point {i + 1} of {n_points}, {where}).")
        hints = []
        if not c1.ok:
            say("  " + c1.message)
            if np.shape(J1) == (3, 2):
                hints.append("J1 has 2 rows (x_F, y_F) and 3 columns (x, y, theta): "
                             "it looks transposed.")
            elif _looks_like_report_J1_typo(c1, pose, z):
                hints.append("J1[1,2] = d y_F / d theta = ^B x cos(theta) - ^B y sin(theta), "
                             "where (^B x, ^B y) is the landmark in the robot frame, not the "
                             "robot's position in N (the report prints ^N x here).")
            elif any(c == 2 for _, c, *_ in c1.wrong):
                hints.append("the theta column of J1 is d(x_F, y_F)/d theta = "
                             "[-rho sin(theta + beta), rho cos(theta + beta)]: turning the robot "
                             "swings the landmark on a circle of radius rho around it.")
            else:
                hints.append("J1 is the derivative of x_B (+) p with respect to the pose "
                             "[x, y, theta], with p = [rho cos(beta), rho sin(beta)] fixed.")
        if not c2.ok:
            say("  " + c2.message)
            J2_arr = np.asarray(J2, dtype=float) if np.shape(J2) == (2, 2) else None
            if J2_arr is not None and compare_jacobians("J2^T", J2_arr.T, J2_ref).ok:
                hints.append("your J2 is transposed: its COLUMNS must be d/d rho and d/d beta "
                             "(the report stacks them as rows, [d/d rho, d/d theta]^T).")
            else:
                hints.append("J2 = R(theta) times the polar Jacobian "
                             "[[cos b, -rho sin b], [sin b, rho cos b]] (chain rule).")
        for h in hints:
            say("  Hint: " + h)
        return False
    say(f"{name}: correct. J1 and J2 match finite differences at {n_points} random points.")
    return True


# ============================================================================ chapter 02 (vision)
# Added by the vision chapter (02 · Seeing ArUco markers).
__all__ += ["check_camera_to_range_bearing"]


def _random_mount(rng) -> np.ndarray:
    """A camera mount ``^B T_C``: the forward-looking axes, turned a little, moved a little."""
    from .vision import R_BASE_CAM

    yaw, pitch, roll = rng.uniform(-0.5, 0.5), rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2)
    cz, sz, cy, sy, cx, sx = (np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch),
                              np.cos(roll), np.sin(roll))
    Rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    Ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    T = np.eye(4)
    T[:3, :3] = Rz @ Ry @ Rx @ R_BASE_CAM
    T[:3, 3] = [rng.uniform(0.0, 0.3), rng.uniform(-0.15, 0.15), rng.uniform(-0.2, 0.2)]
    return T


def check_camera_to_range_bearing(fn, n_points: int = 8, seed: int = 2,
                                  verbose: bool = True) -> bool:
    """Check a student's ``fn(p_cam, T_base_cam) -> [rho, bearing]`` (chapter 02).

    ``p_cam`` is a marker centre (3,) in the camera's optical frame and
    ``T_base_cam`` the 4x4 ``^B T_C``; the answer is the range projected on the
    floor and the bearing (rad), both from the robot's origin, as
    :func:`slamlib.vision.camera_to_range_bearing` computes them. The first
    point uses the course's camera, the others other mounts (turned and moved),
    so an answer that ignores ``T_base_cam`` fails. Common mistakes are named:
    measuring from the camera, ``^C T_B`` used for ``^B T_C``, the rotation
    transposed or forgotten, a 3-D range, the bearing in degrees, atan2's
    arguments swapped, a flipped bearing, the optical axes taken as the robot's.
    """
    from .vision import camera_to_range_bearing, default_camera

    say = _printer(verbose)

    name = getattr(fn, "__name__", "your function")
    rng = np.random.default_rng(seed)
    cases = []
    for k in range(n_points):
        T = default_camera().T_base_cam if k == 0 else _random_mount(rng)
        p = np.array([rng.uniform(-1.0, 1.0), rng.uniform(-0.1, 0.1), rng.uniform(0.5, 4.0)])
        cases.append((p, T))

    def rb(q):
        return np.array([np.hypot(q[0], q[1]), np.arctan2(q[1], q[0])])

    def same(a, b):
        return abs(a[0] - b[0]) < 1e-6 and abs(wrap_angle(a[1] - b[1])) < 1e-6

    for p, T in cases:
        out, problem = _call(fn, p.copy(), T.copy())
        if problem:
            say(_not_ready(name, problem, "it"))
            return False
        try:
            got = np.asarray(out, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            say(f"{name}: expected [rho, bearing], got {out!r}")
            return False
        if got.shape != (2,):
            say(f"{name}: expected [rho, bearing] of shape (2,), got shape {got.shape}")
            return False
        want = camera_to_range_bearing(p, T)
        if np.all(np.isfinite(got)) and same(got, want):
            continue
        R, t = T[:3, :3], T[:3, 3]
        pb = R @ p + t
        # whole answers that a known mistake produces
        wrong_answers = [
            (rb(R @ p), "the range and bearing are measured from the camera: add the mount "
                        "offset t = T_base_cam[:3, 3] to get the point from B's origin"),
            (rb(R.T @ (p - t)), "you used ^C T_B (the inverse) instead of ^B T_C: T_base_cam "
                                "already carries camera points into B, ^B p = R ^C p + t"),
            (rb(R.T @ p + t), "the rotation is transposed: ^B p = R ^C p + t with "
                              "R = T_base_cam[:3, :3] (its columns are C's axes in B)"),
            (rb(p + t), "the rotation is forgotten: the camera's axes are not the robot's "
                        "(x_B = z_C, y_B = x_C, z_B = y_C for the course's camera), "
                        "^B p = R ^C p + t"),
            (rb(p), "the point is used as it is: carry it into B first, ^B p = R ^C p + t"),
        ]
        T0 = default_camera().T_base_cam
        if not np.allclose(T, T0):
            wrong_answers.append((rb(T0[:3, :3] @ p + T0[:3, 3]),
                                  "the answer ignores T_base_cam (it is right for the course's "
                                  "camera only): use the matrix you are given"))
        hints = [h for z, h in wrong_answers if np.all(np.isfinite(got)) and same(got, z)]
        if not hints:
            if np.isclose(got[0], np.linalg.norm(pb)):
                hints.append("the range includes the height: project on the floor, "
                             "hypot(x_B, y_B)")
            if np.isclose(got[0], np.hypot(pb[0], pb[2])) or np.isclose(got[0],
                                                                      np.hypot(p[0], p[1])):
                hints.append("the axes are mixed up: use the rotation T_base_cam[:3, :3]")
            if np.isclose(got[1], np.degrees(want[1])):
                hints.append("the bearing is in degrees: the filters work in radians")
            elif np.isclose(got[1], np.arctan2(pb[0], pb[1])):
                hints.append("atan2's arguments are swapped: the bearing is atan2(y_B, x_B)")
            elif np.isclose(got[1], -want[1]):
                hints.append("the bearing's sign is flipped: in the z-down frame a point to "
                             "the right has a positive bearing, atan2(y_B, x_B)")
        hint = (" Hint: " + "; ".join(hints) + ".") if hints else ""
        mount = ("the course's camera" if np.allclose(T, T0)
                 else f"a camera mounted at t = [{t[0]:.3f}, {t[1]:.3f}, {t[2]:.3f}], turned")
        say(f"{name}: wrong for p_cam = [{p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}] and {mount}: "
            f"got [{got[0]:.4f}, {got[1]:.4f}], expected [{want[0]:.4f}, {want[1]:.4f}].{hint}")
        return False
    say(f"{name}: correct at {len(cases)} points, with the course's camera and "
        f"{len(cases) - 1} other mounts.")
    return True


# --------------------------------------------------------------------------- appendix A
__all__ += ["check_numerical_jacobian"]


def check_numerical_jacobian(fn, verbose: bool = True, eps: float = 1e-3,
                             tol: float = 5e-7) -> bool:
    """Check a student's ``fn(f, x, eps=1e-6) -> J`` (a finite-difference Jacobian, appendix A).

    It is called with ``eps=1e-3`` on functions whose Jacobians are known in
    closed form: a linear map (3 -> 2), a nonlinear one (3 -> 3) and the
    range-bearing of a point. The answer must have shape (outputs, inputs) and
    be within ``tol`` = 5e-7 of the exact Jacobian: a central difference is
    (error of order eps^2, about 1e-7 here), a one-sided one is not (order eps,
    about 1e-3). Named mistakes: a one-sided difference, dividing by eps
    instead of 2 eps, the transpose, an ``eps`` argument that is not accepted.
    """
    say = _printer(verbose)

    name = getattr(fn, "__name__", "your function")
    M = np.array([[1.0, -2.0, 0.5], [0.0, 3.0, -1.0]])
    cases = [
        ("a linear map", lambda x: M @ x, np.array([0.3, -1.2, 2.0]), lambda x: M),
        ("a nonlinear map", lambda x: np.array([x[0] * x[1], np.sin(x[2]), x[0] ** 2 * x[2]]),
         np.array([0.7, -0.4, 1.1]),
         lambda x: np.array([[x[1], x[0], 0.0], [0.0, 0.0, np.cos(x[2])],
                             [2 * x[0] * x[2], 0.0, x[0] ** 2]])),
        ("range and bearing of a point",
         lambda p: np.array([np.hypot(*p), np.arctan2(p[1], p[0])]),
         np.array([1.5, -0.8]),
         lambda p: np.array([[p[0], p[1]] / np.hypot(*p),
                             [-p[1] / (p @ p), p[0] / (p @ p)]])),
    ]

    def one_sided(f, x, sign):
        cols = [sign * (f(x + sign * eps * e) - f(x)) / eps for e in np.eye(x.size)]
        return np.stack(cols, axis=1)

    for label, f, x, exact in cases:
        out, problem = _call(lambda f_, x_: fn(f_, x_, eps=eps), f, x.copy())
        if problem:
            if problem.startswith("it raised TypeError") and "eps" in problem:
                say(f"{name}: {problem}. The checker calls {name}(f, x, eps={eps:g}): "
                    f"define it as def {name}(f, x, eps=1e-6) and use eps as the step.")
            else:
                say(_not_ready(name, problem, "it"))
            return False
        try:
            J = np.asarray(out, dtype=float)
        except (TypeError, ValueError):
            say(f"{name}: expected a numeric (m, n) array, got {type(out).__name__}.")
            return False
        Je = exact(x)
        if J.shape != Je.shape:
            transposed = J.shape == Je.T.shape
            hint = " (transposed: rows are outputs, columns inputs)" if transposed else ""
            say(f"{name}: for {label} expected shape {Je.shape}, got {J.shape}{hint}.")
            return False
        err = float(np.max(np.abs(J - Je))) if np.all(np.isfinite(J)) else float("inf")
        if err > tol:
            c = compare_jacobians("J", J, Je, atol=tol, rtol=0.0)
            say(f"{name}: wrong for {label} with eps = {eps:g} (largest error {err:.2e}, "
                f"allowed {tol:.0e}). {c.message}.")
            if np.allclose(J, 2.0 * Je, rtol=1e-4, atol=tol):
                say("  Hint: your J is twice the Jacobian: you divide by eps, but the central "
                    "difference f(x + eps) - f(x - eps) spans 2 eps. Divide by 2 eps.")
            elif any(np.allclose(J, one_sided(f, x, sg), rtol=1e-6, atol=1e-9) for sg in (1, -1)):
                say("  Hint: this is a one-sided difference (f(x + eps) - f(x)) / eps, whose "
                    "error is of order eps. Use the central difference "
                    "(f(x + eps) - f(x - eps)) / (2 eps): its error is of order eps^2.")
            elif err < 1e-2:
                say("  Hint: the error is small but too large for a central difference at this "
                    "eps: is it (f(x + eps e_j) - f(x - eps e_j)) / (2 eps), with the eps the "
                    "checker passes?")
            return False
    say(f"{name}: correct on {len(cases)} functions with known Jacobians (eps = {eps:g}, "
        f"error below {tol:.0e}).")
    return True


# --------------------------------------------------------------------------- chapter 03
# Added by the chapter on the direct observation and the map-based EKF.
__all__ += ["check_observation_jacobians"]


def _random_observation_points(n: int, seed: int):
    """Generic poses and landmarks, then one landmark almost behind the robot (bearing near pi).

    A generic point has ``|dx|`` and ``|dy|`` of at least 0.3 m: at ``dx = 0`` the
    report's sign error in ``H_pose[1,1] = -dx/q`` would vanish and go unseen.
    """
    rng = np.random.default_rng(seed)
    pts = []
    while len(pts) < n - 1:
        pose = np.array([rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-np.pi, np.pi)])
        d = rng.uniform(-4, 4, size=2)
        if np.min(np.abs(d)) >= 0.3:
            pts.append((pose, pose[:2] + d))
    # bearing pi - 1e-7: a central difference of step 1e-6 crosses the seam unless it wraps
    pose = np.array([rng.uniform(-2, 2), rng.uniform(-2, 2), 0.9])
    a = pose[2] + np.pi - 1e-7
    pts.append((pose, pose[:2] + 2.3 * np.array([np.cos(a), np.sin(a)])))
    return pts


def check_observation_jacobians(fn, n_points: int = 6, seed: int = 3,
                                verbose: bool = True) -> bool:
    """Check a student's ``fn(pose, landmark) -> (H_pose, H_landmark)`` (chapter 03).

    ``H_pose = dh/d pose`` (2x3, columns x, y, theta) and ``H_landmark =
    dh/d landmark`` (2x2, columns x_F, y_F) of :func:`slamlib.models.observe`
    (``h = [range, bearing]``) are compared with central differences (bearing
    differences wrapped) at ``n_points - 1`` seeded generic points and one
    point whose bearing is within 1e-7 rad of pi. A wrong entry is named, with
    "sign flipped" when only its sign is wrong and a hint for the report's
    errors (``H_pose[1,1]``, ``H_landmark[1,0]``, ``dy/sqrt(q)`` for ``dy/q``).

    Returns
    -------
    bool
        True if both Jacobians are right at every point. A verdict is printed.
    """
    from .models import observe

    say = _printer(verbose)

    name = getattr(fn, "__name__", "your function")
    pts = _random_observation_points(max(int(n_points), 2), seed)
    for i, (pose, lm) in enumerate(pts):
        out, problem = _call(fn, pose.copy(), lm.copy())
        if problem:
            say(_not_ready(name, problem, "H_pose and H_landmark"))
            return False
        try:
            Hp, Hl = out
        except (TypeError, ValueError):
            say(f"{name}: expected a pair (H_pose, H_landmark), got {type(out).__name__}")
            return False
        Hp_ref = numerical_jacobian(lambda p, lm=lm: observe(p, lm), pose, angle_outputs=(1,))
        Hl_ref = numerical_jacobian(lambda m, pose=pose: observe(pose, m), lm, angle_outputs=(1,))
        cp = compare_jacobians("H_pose", Hp, Hp_ref)
        cl = compare_jacobians("H_landmark", Hl, Hl_ref)
        if cp.ok and cl.ok:
            continue
        dx, dy = lm - pose[:2]
        q = dx * dx + dy * dy
        beta = float(observe(pose, lm)[1])
        seam = " (bearing near +-pi)" if i == len(pts) - 1 else ""
        say(f"{name}: not right yet (test point {i + 1} of {len(pts)}: pose = [{pose[0]:.3f}, "
            f"{pose[1]:.3f}, {pose[2]:.3f}], landmark = [{lm[0]:.3f}, {lm[1]:.3f}], "
            f"bearing {beta:+.4f} rad{seam}).")
        hints = []
        for c, got, shape in ((cp, Hp, (2, 3)), (cl, Hl, (2, 2))):
            if c.ok:
                continue
            say("  " + c.message)
            if shape[0] != shape[1] and np.shape(got) == shape[::-1]:
                hints.append(f"{c.name} has 2 rows (range, bearing) and {shape[1]} columns: "
                             "yours looks transposed.")
        wrong_p = {(r, k): (g, e) for r, k, g, e in cp.wrong}
        wrong_l = {(r, k): (g, e) for r, k, g, e in cl.wrong}
        if seam:
            hints.append("this point's bearing is within 1e-7 of pi: if you differentiate "
                         "numerically, wrap the bearing difference to [-pi, pi).")
        def flipped(wrong, key):
            return key in wrong and bool(np.isclose(wrong[key][0], -wrong[key][1]))

        for c, wrong in ((cp, wrong_p), (cl, wrong_l)):
            if len(wrong) > 1 and all(flipped(wrong, key) for key in wrong):
                hints.append(f"several entries of {c.name} have the wrong sign: the difference "
                             "is landmark minus robot, dx = x_F - x, dy = y_F - y.")
        Hl_t = np.asarray(Hl, dtype=float) if np.shape(Hl) == (2, 2) else None
        l_transposed = (not cl.ok and Hl_t is not None and np.all(np.isfinite(Hl_t))
                        and compare_jacobians("H_landmark^T", Hl_t.T, Hl_ref).ok)
        if l_transposed:
            hints.append("your H_landmark is transposed: its ROWS are range and bearing, its "
                         "columns d/d x_F and d/d y_F (H_landmark[1,0] = d bearing / d x_F).")
            wrong_l = {}
        if (1, 2) in wrong_p:
            hints.append("H_pose[1,2] = d bearing / d theta = -1: the bearing is "
                         "atan2(dy, dx) - theta, so turning the robot by +d theta moves the "
                         "marker's bearing by -d theta.")
        if flipped(wrong_p, (1, 1)) and len(wrong_p) <= 2:
            hints.append("H_pose[1,1] = d bearing / d y = -dx/q with dx = x_F - x, q = dx^2 + dy^2 "
                         "(the report prints +dx/q).")
        if flipped(wrong_l, (1, 0)) and len(wrong_l) == 1:
            hints.append("H_landmark[1,0] = d bearing / d x_F = -dy/q (the report prints +dy/q).")
        for r, k in [key for key in wrong_p if key[0] == 1] + [key for key in wrong_l
                                                                if key[0] == 1]:
            g, e = wrong_p.get((r, k)) or wrong_l[(r, k)]
            if e != 0.0 and np.isclose(abs(g), abs(e) * np.sqrt(q), rtol=1e-4):
                hints.append("the bearing row divides by q = dx^2 + dy^2, not by sqrt(q) "
                             "(the report's second H has dy/sqrt(q)).")
                break
        if not hints:
            hints.append("with dx = x_F - x, dy = y_F - y: range = sqrt(q), bearing = "
                         "atan2(dy, dx) - theta; H_landmark is minus the first two columns "
                         "of H_pose.")
        for h in dict.fromkeys(hints):
            say("  Hint: " + h)
        return False
    say(f"{name}: correct. H_pose and H_landmark match finite differences at {len(pts)} "
        "points, one with a bearing near pi.")
    return True


# --------------------------------------------------------------------------- chapter 05
__all__ += ["check_gate"]


def _wrap_independent(a):
    """(a + pi) mod 2 pi - pi, written out here so the checker does not trust wrap_angle."""
    return (np.asarray(a, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def _random_gate_cases(n: int, seed: int):
    """Readings, predictions, innovation covariances and gate probabilities.

    Half the innovations fall inside the gate and half outside; every third
    one straddles the +-pi seam (prediction just below pi, reading just above
    -pi, or the other way round).
    """
    from scipy.stats import chi2

    rng = np.random.default_rng(seed)
    probs = (0.95, 0.99, 0.9, 0.5, 0.999)
    for i in range(n):
        prob = probs[i % len(probs)]
        thr = float(chi2.ppf(prob, 2))
        sr, sb = rng.uniform(0.02, 0.2), np.radians(rng.uniform(0.5, 6.0))
        c = rng.uniform(-0.6, 0.6)
        S = np.array([[sr * sr, c * sr * sb], [c * sr * sb, sb * sb]])
        d2 = thr * (rng.uniform(0.02, 0.95) if i % 2 == 0 else rng.uniform(1.05, 3.0))
        u = rng.normal(size=2)
        y = np.linalg.cholesky(S) @ (u / np.linalg.norm(u)) * np.sqrt(d2)
        h_r = abs(y[0]) + rng.uniform(0.3, 3.0)
        if i % 3 == 0:   # across the seam: h + y leaves [-pi, pi) and comes back on the other side
            h_b = np.pi - y[1] / 2 if y[1] > 0 else -np.pi - y[1] / 2
        else:
            h_b = rng.uniform(-np.pi + abs(y[1]), np.pi - abs(y[1]))
        z_pred = np.array([h_r, h_b])
        z = np.array([h_r + y[0], _wrap_independent(h_b + y[1])])
        yield z, z_pred, S, prob


def _scalar(v):
    a = np.asarray(v, dtype=float)
    if a.size != 1:
        raise ValueError(f"expected one number, got shape {a.shape}")
    return float(a.reshape(-1)[0])


def check_gate(fn, n_points: int = 20, seed: int = 5, verbose: bool = True) -> bool:
    """Check a student's ``fn(z, z_pred, S, prob) -> (d2, accept)`` (chapter 05).

    ``z`` is a reading ``[range, bearing]``, ``z_pred`` the predicted one
    ``h(x)``, ``S`` the 2x2 innovation covariance, ``prob`` the gate
    probability. Expected: the innovation ``y = z - z_pred`` with its bearing
    wrapped to [-pi, pi), ``d2 = y^T S^-1 y`` and ``accept = d2 < chi2.ppf(prob, 2)``.

    The reference is computed here independently (its own wrap, ``solve``,
    scipy's chi-square quantile) at ``n_points`` seeded cases, a third of them
    across the +-pi seam, half inside the gate and half outside. A wrong answer
    is diagnosed when it matches a known mistake: bearing not wrapped, ``S``
    used instead of ``S^-1``, ``D`` returned instead of ``D^2``, the report's
    eq. (6) (``h`` subtracted twice), the off-diagonal of ``S`` ignored, or a
    wrong threshold (1 degree of freedom, the probability itself, ``1 - p``,
    a fixed 5.99, the comparison reversed), or the pair returned as
    ``(accept, d2)``.
    """
    from scipy.stats import chi2

    say = _printer(verbose)

    name = getattr(fn, "__name__", "your function")
    cases = list(_random_gate_cases(n_points, seed))
    got = []
    for z, z_pred, S, prob in cases:
        out, problem = _call(fn, z.copy(), z_pred.copy(), S.copy(), prob)
        if problem:
            say(_not_ready(name, problem, "it"))
            return False
        if (isinstance(out, (tuple, list)) and len(out) == 2
                and isinstance(out[0], (bool, np.bool_))
                and not isinstance(out[1], (bool, np.bool_))):
            say(f"{name}: it returns (accept, d2), a True/False first: return the pair in the "
                f"order (d2, accept).")
            return False
        try:
            d2, accept = out
            d2 = _scalar(d2)
            acc = np.asarray(accept)
            if acc.size != 1:
                raise ValueError(f"accept: expected one True/False, got shape {acc.shape}")
            got.append((d2, bool(acc.reshape(-1)[0])))
        except (TypeError, ValueError) as exc:
            say(f"{name}: expected a pair (d2, accept) with d2 a number and accept True/False "
                f"({exc}).")
            return False

    def where(z, z_pred, prob):
        return (f"z = [{z[0]:.3f}, {z[1]:.4f}], z_pred = [{z_pred[0]:.3f}, {z_pred[1]:.4f}], "
                f"prob = {prob}")

    # ---- the distance
    def variants(z, z_pred, S):
        y = np.array([z[0] - z_pred[0], _wrap_independent(z[1] - z_pred[1])])
        y_raw = np.asarray(z, float) - np.asarray(z_pred, float)
        d2 = float(y @ np.linalg.solve(S, y))
        return d2, {
            "the bearing of the innovation is not wrapped: across the +-pi seam a 0.02 rad "
            "difference becomes almost 2 pi. Wrap y[1] to [-pi, pi)":
                float(y_raw @ np.linalg.solve(S, y_raw)),
            "it uses S where S^-1 belongs (y^T S y). Use np.linalg.solve(S, y)":
                float(y @ S @ y),
            "it returns D, the distance, not D^2 = y^T S^-1 y (no square root)":
                float(np.sqrt(d2)),
            "it is the report's eq. (6): (y - h)^T S^-1 (y - h) subtracts the prediction twice. "
            "The innovation y = z - h is already the difference":
                float((y - z_pred) @ np.linalg.solve(S, y - z_pred)),
            "it ignores the off-diagonal (range-bearing correlation) of S. Use the full S^-1":
                float(y @ (y / np.diag(S))),
        }

    for (z, z_pred, S, prob), (d2, _) in zip(cases, got):
        ref, wrong = variants(z, z_pred, S)
        if not np.isclose(d2, ref, rtol=1e-6, atol=1e-9):
            say(f"{name}: d2 is wrong at {where(z, z_pred, prob)}: got {d2:.6g}, "
                f"expected {ref:.6g}.")
            for why, value in wrong.items():
                if np.isclose(d2, value, rtol=1e-6, atol=1e-9):
                    say(f"  Hint: {why}.")
                    break
            else:
                say("  Hint: y = z - z_pred with y[1] wrapped to [-pi, pi), then d2 = y^T S^-1 y.")
            return False

    # ---- the decision
    thresholds = [float(chi2.ppf(p, 2)) for *_, p in cases]
    wrong_rules = {
        "it accepts when d2 is ABOVE the threshold: the comparison is reversed":
            lambda d2, p, t: d2 > t,
        "your threshold looks like chi2.ppf(prob, 1); use chi2.ppf(prob, 2): the "
        "innovation has 2 degrees of freedom (range and bearing)":
            lambda d2, p, t: d2 < chi2.ppf(p, 1),
        "it compares d2 with the probability itself; compare it with the chi-square "
        "quantile chi2.ppf(prob, 2)":
            lambda d2, p, t: d2 < p,
        "your threshold looks like chi2.ppf(1 - prob, 2); use chi2.ppf(prob, 2): prob is "
        "the probability inside the gate":
            lambda d2, p, t: d2 < chi2.ppf(1.0 - p, 2),
        "it compares d2 with sqrt(threshold); compare D^2 with the chi-square quantile "
        "chi2.ppf(prob, 2) itself":
            lambda d2, p, t: d2 < np.sqrt(t),
        "your threshold looks fixed at 5.99, which is right only for prob = 0.95; use "
        "chi2.ppf(prob, 2)":
            lambda d2, p, t: d2 < 5.991,
    }
    for (z, z_pred, _S, prob), (d2, acc), thr in zip(cases, got, thresholds):
        if acc != (d2 < thr):
            say(f"{name}: wrong decision at {where(z, z_pred, prob)}: d2 = {d2:.4f}, the gate's "
                f"threshold is chi2.ppf({prob}, 2) = -2 ln(1 - {prob}) = {thr:.4f}, so the "
                f"reading should be {'accepted' if d2 < thr else 'rejected'}, got "
                f"accept = {acc}.")
            fits = [why for why, rule in wrong_rules.items()
                    if all(bool(rule(d, c[3], t)) == a
                           for c, (d, a), t in zip(cases, got, thresholds))]
            for why in fits:
                say(f"  Hint: {why}.")
            if not fits:
                say("  Hint: accept = d2 < chi2.ppf(prob, 2), which for 2 degrees of freedom "
                    "is -2 ln(1 - prob).")
            return False
    n_seam = len(range(0, n_points, 3))
    say(f"{name}: correct. d2 and the decision match at {n_points} readings "
        f"({n_seam} across the +-pi seam, gate probabilities 0.5 to 0.999).")
    return True


# --------------------------------------------------------------------------- chapter 06
__all__ += ["check_average_nees_band"]


def check_average_nees_band(fn, verbose: bool = True) -> bool:
    """Check a student's ``fn(n_runs, dof, prob) -> (lo, hi)`` (chapter 06).

    Expected: the two-sided ``prob`` band of the average of ``n_runs``
    independent chi-square(``dof``) values, ``(chi2.ppf((1 - prob)/2, n_runs*dof) / n_runs,
    chi2.ppf((1 + prob)/2, n_runs*dof) / n_runs)``: the sum of the runs' NEES is
    chi-square with ``n_runs*dof`` degrees of freedom. The reference is computed
    here with scipy; a wrong answer is diagnosed when it matches a known mistake
    (the band of one sample, the sum not divided by N, the degrees of freedom
    not multiplied by N, a one-sided quantile, the normal approximation).
    """
    from scipy.stats import chi2, norm

    say = _printer(verbose)
    name = getattr(fn, "__name__", "your function")
    cases = [(20, 3, 0.95), (50, 3, 0.95), (20, 1, 0.95), (10, 2, 0.99), (1, 3, 0.95),
             (100, 1, 0.9), (5, 3, 0.5)]

    def ref(n, d, p):
        return (chi2.ppf((1 - p) / 2, n * d) / n, chi2.ppf((1 + p) / 2, n * d) / n)

    mistakes = {
        "it is the band of ONE sample (chi2.ppf(., dof)): the average of N runs varies less; "
        "its sum is chi-square with N*dof degrees of freedom":
            lambda n, d, p: (chi2.ppf((1 - p) / 2, d), chi2.ppf((1 + p) / 2, d)),
        "it is the band of the SUM of the N values: divide the quantiles by n_runs":
            lambda n, d, p: (chi2.ppf((1 - p) / 2, n * d), chi2.ppf((1 + p) / 2, n * d)),
        "the degrees of freedom are dof, not n_runs*dof: the sum of N chi-square(dof) "
        "values has N*dof":
            lambda n, d, p: (chi2.ppf((1 - p) / 2, d) / n, chi2.ppf((1 + p) / 2, d) / n),
        "the quantiles are one-sided (1 - prob and prob): a two-sided band of probability "
        "prob leaves (1 - prob)/2 on each side":
            lambda n, d, p: (chi2.ppf(1 - p, n * d) / n, chi2.ppf(p, n * d) / n),
        "it is the normal approximation dof +- z sqrt(2 dof / N): close for large N, "
        "not for small N. Use the chi-square quantiles":
            lambda n, d, p: (d - norm.ppf((1 + p) / 2) * np.sqrt(2 * d / n),
                             d + norm.ppf((1 + p) / 2) * np.sqrt(2 * d / n)),
    }
    for n, d, p in cases:
        out, problem = _call(fn, n, d, p)
        if problem:
            say(_not_ready(name, problem, "it"))
            return False
        try:
            lo, hi = (_scalar(v) for v in out)
        except (TypeError, ValueError) as exc:
            say(f"{name}: expected a pair (lo, hi) of numbers ({exc}).")
            return False
        want = ref(n, d, p)
        if not np.allclose([lo, hi], want, rtol=1e-6, atol=1e-9):
            say(f"{name}: not right for n_runs = {n}, dof = {d}, prob = {p}: got "
                f"({lo:.4f}, {hi:.4f}), expected ({want[0]:.4f}, {want[1]:.4f}).")
            for why, wrong in mistakes.items():
                if np.allclose([lo, hi], wrong(n, d, p), rtol=1e-6, atol=1e-9):
                    say(f"  Hint: {why}.")
                    break
            else:
                if lo > hi:
                    say("  Hint: lo and hi are swapped.")
                else:
                    say("  Hint: (chi2.ppf((1 - prob)/2, n_runs*dof) / n_runs, "
                        "chi2.ppf((1 + prob)/2, n_runs*dof) / n_runs).")
            return False
    say(f"{name}: correct. The band matches at {len(cases)} cases (1 to 100 runs, "
        f"1 to 3 degrees of freedom, probabilities 0.5 to 0.99).")
    return True


# --------------------------------------------------------------------------- chapter 08
__all__ += ["check_history_index"]


def _history_cases(seed: int):
    """Event logs (non-decreasing times, some repeated) and capture times to place in them."""
    rng = np.random.default_rng(seed)
    cases = [([], 0.3), ([0.5], 0.5), ([0.5], 0.4), ([0.5], 0.6)]
    for _ in range(12):
        n = int(rng.integers(3, 25))
        times = np.round(np.cumsum(rng.choice([0.0, 0.02, 0.02, 0.04], size=n)) + 10.0, 6)
        pick = rng.integers(0, 4)
        if pick == 0:
            tc = float(rng.choice(times))                       # exactly an event's time
        elif pick == 1:
            tc = float(rng.uniform(times[0], times[-1] + 1e-9))  # somewhere inside
        elif pick == 2:
            tc = float(times[0] - rng.uniform(0.01, 1.0))       # before the whole log
        else:
            tc = float(times[-1] + rng.uniform(0.0, 0.1))       # at or after the newest event
        cases.append((list(times), tc))
    times = [1.0, 1.02, 1.04, 1.04, 1.04, 1.06]                  # a tie at the capture time
    cases += [(times, 1.04), (np.array(times), 1.04), (times, 1.0), (times, 1.06)]
    return cases


def check_history_index(fn, seed: int = 8, verbose: bool = True) -> bool:
    """Check a student's ``fn(times, t_capture) -> int`` (chapter 08).

    ``times`` are the times of the events in the filter's history (non-decreasing,
    possibly repeated); the answer is where a frame captured at ``t_capture``
    goes: after every event at a time ``<= t_capture``, i.e. the number of such
    events (a prediction at the very instant of the capture comes first, as in
    :meth:`slamlib.runs.Run.events`). The reference is that count, computed here
    by a plain loop. Wrong answers that match ``<`` instead of ``<=``
    (``bisect_left``), an index one too small (the last event's index instead
    of the place after it) or a count from the newest end are named.
    """
    say = _printer(verbose)

    name = getattr(fn, "__name__", "your function")
    cases = _history_cases(seed)
    got = []
    for times, tc in cases:
        out, problem = _call(fn, list(times) if isinstance(times, list) else times.copy(), tc)
        if problem:
            say(_not_ready(name, problem, "it"))
            return False
        a = np.asarray(out)
        if (a.size != 1 or not np.issubdtype(a.dtype, np.number)
                or not float(a.reshape(-1)[0]).is_integer()):
            say(f"{name}: expected one integer (an index), got {out!r}.")
            return False
        got.append(int(a.reshape(-1)[0]))
    want = [sum(1 for t in times if t <= tc) for times, tc in cases]
    wrong = [i for i in range(len(cases)) if got[i] != want[i]]
    if wrong:
        times, tc = cases[wrong[0]]
        shown = ", ".join(f"{t:g}" for t in times[:8]) + (", ..." if len(times) > 8 else "")
        say(f"{name}: wrong place for t_capture = {tc:g} in times = [{shown}] "
            f"({len(times)} events): got {got[wrong[0]]}, expected {want[wrong[0]]}.")
        rules = {
            "an event at exactly the capture time (the prediction that reached it) happened "
            "BEFORE the frame: count times <= t_capture, not < (bisect_right, not bisect_left)":
                lambda times, tc: sum(1 for t in times if t < tc),
            "that is the index of the last event before the frame; the frame goes AFTER it, "
            "so the answer is one more (the number of such events)":
                lambda times, tc: sum(1 for t in times if t <= tc) - 1,
            "that counts the events AFTER the capture time (the ones to re-apply); the index "
            "is the number of events at or before it":
                lambda times, tc: sum(1 for t in times if t > tc),
        }
        fits = [why for why, rule in rules.items()
                if all(rule(times, tc) == g for (times, tc), g in zip(cases, got))]
        for why in fits or ["the answer is the number of events with a time <= t_capture "
                            "(0 if the frame is older than all of them, len(times) if newer)"]:
            say(f"  Hint: {why}.")
        return False
    say(f"{name}: correct. Right place at {len(cases)} capture times, with ties, an empty "
        "history and frames older or newer than every event.")
    return True


# --------------------------------------------------------------------------- chapter 07
__all__ += ["check_in_field_of_view"]


def _random_view_cases(n: int, seed: int):
    """Poses (a third of them facing close to +-pi, where the bearing must be wrapped),
    points around them, half angles and ranges."""
    rng = np.random.default_rng(seed)
    for i in range(n):
        heading = (np.pi - rng.uniform(0.0, 0.4)) * rng.choice([-1.0, 1.0]) if i % 3 == 0 \
            else rng.uniform(-np.pi, np.pi)
        pose = np.array([rng.uniform(-3, 3), rng.uniform(-3, 3), heading])
        half, max_range = float(rng.uniform(0.3, 1.2)), float(rng.uniform(1.0, 3.0))
        pts = pose[:2] + rng.uniform(-1.3 * max_range, 1.3 * max_range, (40, 2))
        yield pose, pts, half, max_range


def check_in_field_of_view(fn, n_cases: int = 12, seed: int = 7, verbose: bool = True) -> bool:
    """Check a student's ``fn(pose, points, half_angle, max_range) -> bool array`` (chapter 07).

    ``points`` is (n, 2); a point is in view when its distance from the robot
    is at most ``max_range`` and its bearing ``wrap(atan2(dy, dx) - theta)`` is
    at most ``half_angle`` in size. Compared with
    :func:`slamlib.explore.in_field_of_view` for ``n_cases`` random poses of 40
    points each; hints for a bearing that is not wrapped, ``+ theta`` instead of
    ``- theta``, ``atan2(dx, dy)``, the whole field of view used as the half
    angle, and the squared distance compared with the range.
    """
    from .explore import in_field_of_view

    say = _printer(verbose)
    name = getattr(fn, "__name__", "your function")
    cases = list(_random_view_cases(n_cases, seed))
    got_all = []
    for pose, pts, half, rmax in cases:
        out, problem = _call(fn, pose.copy(), pts.copy(), half, rmax)
        if problem:
            say(_not_ready(name, problem, "the test"))
            return False
        got = np.asarray(out).reshape(-1) if np.ndim(out) else np.asarray(out)
        if got.shape != (pts.shape[0],):
            say(f"{name}: expected one True/False per point, shape ({pts.shape[0]},), "
                f"got shape {np.shape(out)}.")
            return False
        if got.dtype != bool and not np.isin(got, (0, 1)).all():
            say(f"{name}: expected True/False per point, got values such as {got[:3]}.")
            return False
        got_all.append(got.astype(bool))

    def variant(bearing_of, half_of=lambda h: h, dist_of=np.hypot):
        out = []
        for pose, pts, half, rmax in cases:
            dx, dy = pts[:, 0] - pose[0], pts[:, 1] - pose[1]
            out.append((dist_of(dx, dy) <= rmax)
                       & (np.abs(bearing_of(dx, dy, pose[2])) <= half_of(half)))
        return out

    want = [in_field_of_view(pose, pts, half, rmax) for pose, pts, half, rmax in cases]
    for k, ((pose, pts, half, rmax), g, w) in enumerate(zip(cases, got_all, want)):
        bad = np.flatnonzero(g != w)
        if bad.size == 0:
            continue
        i = bad[0]
        dx, dy = pts[i, 0] - pose[0], pts[i, 1] - pose[1]
        b = wrap_angle(np.arctan2(dy, dx) - pose[2])
        say(f"{name}: not right yet (case {k + 1} of {n_cases}: pose [{pose[0]:.2f}, "
            f"{pose[1]:.2f}, {pose[2]:.3f}], half_angle {half:.3f}, max_range {rmax:.2f}). "
            f"The point [{pts[i, 0]:.2f}, {pts[i, 1]:.2f}] at distance {np.hypot(dx, dy):.2f} m "
            f"and bearing {b:+.3f} rad is {'inside' if w[i] else 'outside'}; you said "
            f"{'inside' if g[i] else 'outside'} ({bad.size} of {len(g)} points wrong here).")
        hints = {
            "the bearing atan2(dy, dx) - theta must be wrapped to [-pi, pi): facing near +-pi, "
            "a point straight ahead can come out as almost 2 pi":
                variant(lambda dx, dy, th: np.arctan2(dy, dx) - th),
            "the bearing is atan2(dy, dx) - theta (the direction to the point minus the "
            "heading), not + theta":
                variant(lambda dx, dy, th: wrap_angle(np.arctan2(dy, dx) + th)),
            "wrap the bearing to [-pi, pi) (a point a little to the left has a small "
            "negative bearing), not to [0, 2 pi) with a plain modulo":
                variant(lambda dx, dy, th: np.mod(np.arctan2(dy, dx) - th, 2 * np.pi)),
            "numpy's arctan2 takes (dy, dx): y first":
                variant(lambda dx, dy, th: wrap_angle(np.arctan2(dx, dy) - th)),
            "half_angle is HALF the field of view: compare |bearing| with half_angle itself":
                variant(lambda dx, dy, th: wrap_angle(np.arctan2(dy, dx) - th),
                        half_of=lambda h: 2 * h),
            "half_angle is already half the field of view: do not halve it again":
                variant(lambda dx, dy, th: wrap_angle(np.arctan2(dy, dx) - th),
                        half_of=lambda h: h / 2),
            "compare the distance sqrt(dx^2 + dy^2) with max_range, not its square":
                variant(lambda dx, dy, th: wrap_angle(np.arctan2(dy, dx) - th),
                        dist_of=lambda dx, dy: dx * dx + dy * dy),
        }
        fits = [why for why, v in hints.items()
                if all(np.array_equal(a, b) for a, b in zip(v, got_all))]
        for why in fits or ["a point is in view when distance <= max_range AND "
                            "|wrap(atan2(dy, dx) - theta)| <= half_angle"]:
            say(f"  Hint: {why}.")
        return False
    say(f"{name}: correct. Right for {sum(len(g) for g in got_all)} points around "
        f"{n_cases} poses, including headings near +-pi.")
    return True
