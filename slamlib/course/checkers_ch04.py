"""Chapter 04's exercise checker: the inverse observation's Jacobians J1, J2.

The verdicts follow :mod:`slamlib.course.harness`.
"""

from __future__ import annotations

import numpy as np

from ..checks import compare_jacobians, numerical_jacobian
from ..models import inverse_observe
from .harness import attempt, name_of, printer

__all__ = ["check_inverse_observation_jacobians"]


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
    say = printer(verbose)

    name = name_of(fn)
    for i, (pose, z) in enumerate(_random_inverse_observation_points(n_points, seed)):
        out = attempt(fn, pose.copy(), z.copy(), say=say, what="J1 and J2")
        if out is None:
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
