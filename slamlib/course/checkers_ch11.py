"""Chapter 11's exercise checker: a pose covariance from the course's form into GTSAM's.

The student writes ``fn(pose, P) -> Sigma``: ``pose = [x, y, theta]`` z-down,
``P`` its 3x3 covariance of the additive error in N (the EKF's), ``Sigma`` the
covariance GTSAM wants for the same uncertainty (body-frame perturbation of the
mirrored ``Pose2``). The checker compares with
:func:`slamlib.graph.pose_cov_to_gtsam` at random poses and names the usual
mistakes (no rotation into the body frame, the rotation the wrong way, no mirror).
"""

from __future__ import annotations

import numpy as np

from ..graph import pose_cov_to_gtsam
from .harness import attempt, name_of, printer

__all__ = ["check_pose_cov_to_gtsam"]


def _rot(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _cases(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        pose = np.array([rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-np.pi, np.pi)])
        A = rng.normal(size=(3, 3)) * np.array([0.05, 0.05, 0.02])
        yield pose, A @ A.T + 1e-4 * np.eye(3)


def check_pose_cov_to_gtsam(fn, n_points: int = 6, seed: int = 11, verbose: bool = True) -> bool:
    """Check a student's ``fn(pose, P) -> Sigma`` (chapter 11); prints a verdict, returns it."""
    say = printer(verbose)
    name = name_of(fn)
    M = np.diag([1.0, -1.0, -1.0])
    for pose, P in _cases(n_points, seed):
        out = attempt(fn, pose.copy(), P.copy(), say=say)
        if out is None:
            return False
        got = np.asarray(out, dtype=float)
        if got.shape != (3, 3):
            say(f"{name}: expected a 3x3 matrix, got shape {got.shape}")
            return False
        want = pose_cov_to_gtsam(pose, P)
        if np.allclose(got, want, rtol=1e-9, atol=1e-12):
            continue
        G = _rot(pose[2])
        hints = [
            (M @ P @ M, "you mirrored P but did not rotate it into the robot's frame: "
                        "GTSAM perturbs a Pose2 in its own body frame (T * Exp(xi))"),
            (M @ G @ P @ G.T @ M, "the rotation goes the wrong way: the body-frame error is "
                                  "R(theta)^T times the error in N"),
            (G.T @ P @ G, "the rotation is right but the mirror is missing: GTSAM's y and "
                          "angles point the other way (M = diag(1, -1, -1))"),
            (P, "this is P unchanged: it needs the rotation into the body frame and the mirror"),
        ]
        for wrong, hint in hints:
            if np.allclose(got, wrong, rtol=1e-9, atol=1e-12):
                say(f"{name}: wrong at pose {np.round(pose, 3)}: {hint}.")
                return False
        k = np.unravel_index(np.argmax(np.abs(got - want)), want.shape)
        say(f"{name}: wrong at pose {np.round(pose, 3)}: entry {k} is {got[k]:.3e}, "
            f"expected {want[k]:.3e}.")
        return False
    say(f"{name}: correct at {n_points} random poses.")
    return True
