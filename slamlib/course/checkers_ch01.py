"""Chapter 01's exercise checker: the motion model's Jacobians A and W.

The verdicts follow :mod:`slamlib.course.harness`.
"""

from __future__ import annotations

import numpy as np

from ..checks import compare_jacobians, numerical_jacobian
from ..models import KOBUKI_WHEEL_BASE, motion_model
from .harness import attempt, name_of, printer

__all__ = ["check_motion_jacobians"]


def _random_motion_points(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        x = np.array([rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-np.pi, np.pi)])
        u = rng.uniform(-0.5, 0.5, size=2)
        dt = float(rng.uniform(0.01, 0.5))
        yield x, u, dt


def check_motion_jacobians(fn, n_points: int = 5, seed: int = 1,
                           wheel_base: float = KOBUKI_WHEEL_BASE, verbose: bool = True) -> bool:
    """Check a student's ``fn(x, u, dt, b) -> (A, W)`` against finite differences (chapter 01).

    ``A = df/dx_{k-1}`` (3x3) and ``W = df/dw`` (3x2; w is the noise on ``[V_R, V_L]``,
    so W has the entries of df/du) of :func:`slamlib.models.motion_model` are compared with central
    differences at ``n_points`` random poses, wheel speeds and time steps.

    Returns
    -------
    bool
        True if both Jacobians are right at every point. A verdict is printed.
    """
    say = printer(verbose)

    name = name_of(fn)
    for i, (x, u, dt) in enumerate(_random_motion_points(n_points, seed)):
        out = attempt(fn, x.copy(), u.copy(), dt, wheel_base, say=say, what="A and W")
        if out is None:
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
                say("  Your W columns are swapped: column 0 is d/dw_R and column 1 is d/dw_L, "
                    "the noise on V_R and on V_L (u = [V_R, V_L]). (Here that gives the same "
                    "numbers as a turn rate of the wrong sign: omega = (V_L - V_R)/b in the "
                    "z-down frame.)")
            for c in bad:
                say("  " + c.message)
            say("  Hint: A is the derivative with respect to the previous pose x_{k-1}; "
                "W's columns are d/dw_R and d/dw_L (w the noise on [V_R, V_L]), and the turn "
                "rate is omega = (V_L - V_R)/b in the z-down frame.")
            return False
    say(f"{name}: correct. A and W match finite differences at {n_points} random points.")
    return True
