"""Chapter 00's exercise checker: a pose from a z-up (ROS REP-103) frame into N (z down).

The verdicts follow :mod:`slamlib.course.harness`.
"""

from __future__ import annotations

import numpy as np

from ..frames import pose_from_zup
from ..models import wrap_angle
from .harness import attempt, name_of, printer, shape_problem

__all__ = ["check_pose_from_zup"]


def check_pose_from_zup(fn, n_points: int = 8, seed: int = 0, verbose: bool = True) -> bool:
    """Check a student's ``fn(pose_zup) -> pose_zdown`` for one pose ``[x, y, yaw]`` (chapter 00).

    Compared with :func:`slamlib.frames.pose_from_zup` at random poses, including
    headings on the +-pi seam; the heading must come back wrapped to [-pi, pi).
    """
    say = printer(verbose)

    name = name_of(fn)
    rng = np.random.default_rng(seed)
    poses = [np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-np.pi, np.pi)])
             for _ in range(n_points - 2)]
    poses += [np.array([1.0, 2.0, -np.pi]), np.array([-1.5, 0.5, np.pi - 1e-9])]
    for p in poses:
        out = attempt(fn, p.copy(), say=say)
        if out is None:
            return False
        wrong_shape = shape_problem(name, out, (3,))
        if wrong_shape:
            say(wrong_shape)
            return False
        got = np.asarray(out, dtype=float)
        want = pose_from_zup(p)
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
