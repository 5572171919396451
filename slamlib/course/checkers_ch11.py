"""Chapter 11's checkers: the exercise (the turn no factor sees) and the frames conversion.

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

__all__ = ["check_pose_cov_to_gtsam", "check_rotation_direction", "jacobian_along"]


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


# --- the lesson's exercise: the rotation the factors cannot see -------------------------

def _residuals(poses, landmarks, lm_points=None) -> np.ndarray:
    """The tiny graph's residuals without the prior: odometry between consecutive poses
    (x_{i+1} seen from x_i) and every pose's range and bearing to every landmark.

    ``lm_points[i][j]``, if given, is the point at which pose i's reading of landmark j is
    linearised (the landmark plus that reading's own offset), as EKF SLAM's moving estimates do.
    """
    out = []
    for a, b in zip(poses[:-1], poses[1:]):
        c, s = np.cos(a[2]), np.sin(a[2])
        d = b[:2] - a[:2]
        out += [c * d[0] + s * d[1], -s * d[0] + c * d[1], b[2] - a[2]]
    for i, p in enumerate(poses):
        c, s = np.cos(p[2]), np.sin(p[2])
        for j, l in enumerate(landmarks):
            q = l if lm_points is None else lm_points[i][j]
            d = q - p[:2]
            out += [np.hypot(*d), np.arctan2(-s * d[0] + c * d[1], c * d[0] + s * d[1])]
    return np.array(out)


def jacobian_along(poses, landmarks, v, offsets=None, eps: float = 1e-6) -> np.ndarray:
    """J v for the tiny graph's Jacobian J (prior left out), by central differences.

    ``offsets[i][j]``: the offset of the point at which pose i's reading of landmark j is
    linearised (None: every factor at the estimate itself, one linearisation point).
    """
    poses, landmarks = np.asarray(poses, float), np.asarray(landmarks, float)
    n = poses.shape[0]
    v = np.asarray(v, float)
    vp, vl = v[:3 * n].reshape(n, 3), v[3 * n:].reshape(-1, 2)

    def r(sign):
        P, L = poses + sign * eps * vp, landmarks + sign * eps * vl
        pts = None if offsets is None else [[L[j] + offsets[i][j] for j in range(len(L))]
                                            for i in range(n)]
        return _residuals(P, L, pts)

    return (r(1.0) - r(-1.0)) / (2 * eps)


def _tiny_cases(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        poses = np.column_stack([rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3),
                                 rng.uniform(-np.pi, np.pi, 3)])
        yield poses, rng.uniform(-4, 4, (2, 2))


def check_rotation_direction(fn, n_points: int = 5, seed: int = 3, verbose: bool = True) -> bool:
    """Check a student's ``fn(poses, landmarks) -> v`` (chapter 11's exercise).

    ``poses`` (n, 3) and ``landmarks`` (m, 2); ``v`` (3n + 2m,) the direction, stacked as
    [x0, y0, theta0, x1, ..., lx0, ly0, ...], in which the whole estimate turns about the
    origin. Any non-zero multiple is accepted, and so is a turn about another point (a turn
    plus a shift). Prints a verdict and, if right, what the direction shows; returns the verdict.
    """
    say = printer(verbose)
    name = name_of(fn)
    for poses, lms in _tiny_cases(n_points, seed):
        n, m = len(poses), len(lms)
        out = attempt(fn, poses.copy(), lms.copy(), say=say)
        if out is None:
            return False
        v = np.asarray(out, dtype=float).ravel()
        if v.shape != (3 * n + 2 * m,):
            say(f"{name}: expected a vector of {3 * n + 2 * m} numbers (3 per pose, 2 per "
                f"landmark), got shape {np.shape(out)}")
            return False
        vp, vl = v[:3 * n].reshape(n, 3), v[3 * n:].reshape(m, 2)
        if np.allclose(vp[:, 2], 0.0):
            say(f"{name}: every heading component is zero: that is a shift, or no rigid "
                "motion at all; a turn of the whole estimate turns every heading too.")
            return False
        scale = vp[0, 2]
        if not np.allclose(vp[:, 2], scale, rtol=1e-6, atol=1e-12):
            say(f"{name}: the heading components differ: a rigid turn changes every heading "
                "by the same angle.")
            return False
        Jv = jacobian_along(poses, lms, v / scale)
        if np.max(np.abs(Jv)) < 1e-6:
            continue
        if np.allclose(vl, 0.0):
            say(f"{name}: the landmarks do not move: the map turns with the robot, or the "
                "readings change.")
            return False
        flipped = np.concatenate([np.column_stack([-vp[:, 0], -vp[:, 1], vp[:, 2]]).ravel(),
                                  -vl.ravel()])
        if np.max(np.abs(jacobian_along(poses, lms, flipped / scale))) < 1e-6:
            say(f"{name}: the positions turn the other way from the headings: turning by a "
                "small angle a moves (x, y) by a * (-y, x).")
            return False
        say(f"{name}: the factors see this direction (largest entry of J v: "
            f"{np.max(np.abs(Jv)):.2e} per radian), so it is not a turn of the whole estimate.")
        return False
    poses, lms = next(_tiny_cases(1, seed))
    v = np.asarray(fn(poses.copy(), lms.copy()), float).ravel()
    v = v / v[2]
    rng = np.random.default_rng(seed + 1)
    offsets = rng.normal(0.0, 0.03, (len(poses), len(lms), 2))
    one = np.linalg.norm(jacobian_along(poses, lms, v))
    own = np.linalg.norm(jacobian_along(poses, lms, v, offsets))
    say(f"{name}: correct at {n_points} random estimates.\n|J v| per radian of turn:\n"
        f"  every factor at one point: {one:.1e} (unobservable);\n"
        f"  each reading at its own landmark copy, 3 cm off: {own:.1e}\n"
        f"  (the turn looks observed)")
    return True
