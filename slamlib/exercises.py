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
"""

from __future__ import annotations

import numpy as np

from .checks import compare_jacobians, numerical_jacobian
from .frames import pose_from_zup
from .models import KOBUKI_WHEEL_BASE, motion_model, wrap_angle

__all__ = ["check_pose_from_zup", "check_motion_jacobians"]


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
    def say(msg: str) -> None:
        if verbose:
            print(msg)

    name = getattr(fn, "__name__", "your function")
    for i, (x, u, dt) in enumerate(_random_motion_points(n_points, seed)):
        out, problem = _call(fn, x.copy(), u.copy(), dt, wheel_base)
        if problem:
            todo = ("Write A and W" if problem.startswith("not written") else "Fix it")
            say(f"{name}: {problem}. {todo}, then run this cell again.")
            return False
        try:
            A, W = out
        except (TypeError, ValueError):
            say(f"{name}: expected a pair (A, W), got {type(out).__name__}")
            return False
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
    def say(msg: str) -> None:
        if verbose:
            print(msg)

    name = getattr(fn, "__name__", "your function")
    rng = np.random.default_rng(seed)
    poses = [np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-np.pi, np.pi)])
             for _ in range(n_points - 2)]
    poses += [np.array([1.0, 2.0, -np.pi]), np.array([-1.5, 0.5, np.pi - 1e-9])]
    for p in poses:
        out, problem = _call(fn, p.copy())
        if problem:
            todo = "Write it" if problem.startswith("not written") else "Fix it"
            say(f"{name}: {problem}. {todo}, then run this cell again.")
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
