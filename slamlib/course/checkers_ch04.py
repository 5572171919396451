"""Chapter 04's exercise checkers: the inverse observation's Jacobians J1, J2, and the
prediction of what a second reading of a new landmark does to the robot's uncertainty.

The verdicts follow :mod:`slamlib.course.harness` and :mod:`slamlib.course.predictions`.
"""

from __future__ import annotations

import numpy as np

from ..checks import compare_jacobians, numerical_jacobian
from ..models import inverse_observe
from .harness import attempt, name_of, printer

__all__ = ["check_inverse_observation_jacobians", "check_second_reading_prediction",
           "SECOND_READING_CHOICES"]


# the nonzero entries of J1 = dg/d[x, y, theta] and J2 = dg/d[rho, beta] of
# g = x_B (+) p(z): what each differentiates and its value, for the hints on a slip
# (here and in :func:`slamlib.course.filter_checkers.check_augment`)
J1_ENTRIES = {(0, 0): ("d x_F / d x", "1"), (1, 1): ("d y_F / d y", "1"),
              (0, 2): ("d x_F / d theta", "-rho sin(theta + beta)"),
              (1, 2): ("d y_F / d theta", "rho cos(theta + beta)")}
J2_ENTRIES = {(0, 0): ("d x_F / d rho", "cos(theta + beta)"),
              (1, 0): ("d y_F / d rho", "sin(theta + beta)"),
              (0, 1): ("d x_F / d beta", "-rho sin(theta + beta)"),
              (1, 1): ("d y_F / d beta", "rho cos(theta + beta)")}


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
                             "(the report stacks them as rows, [d/d rho, d/d ^B theta]^T, "
                             "^B theta = beta).")
            else:
                for r, c, g, e in c2.wrong[:2]:
                    what, formula = J2_ENTRIES[r, c]
                    sign = " (yours has the opposite sign)" if np.isclose(g, -e) else ""
                    hints.append(f"J2[{r},{c}] = {what} = {formula}{sign}.")
                hints.append("J2 = R(theta) times the polar Jacobian "
                             "[[cos b, -rho sin b], [sin b, rho cos b]] (chain rule).")
        for h in hints:
            say("  Hint: " + h)
        return False
    say(f"{name}: correct. J1 and J2 match finite differences at {n_points} random points.")
    return True


# --------------------------------------------------------------------------- predict, then measure
SECOND_READING_CHOICES = ("shrinks a lot", "shrinks a little", "stays the same", "grows")

_WHY_SECOND_READING = (
    "The landmark was computed from the robot: m = g(x_B, z1). Linearised, the second reading "
    "is z2 = H_pose dx_B + H_landmark dm + v2 with dm = J1 dx_B + J2 v1, and H_pose + "
    "H_landmark J1 = 0 (h(x_B, g(x_B, z)) = z for every pose). So z2 = H_landmark J2 v1 + v2 "
    "depends on the two readings' noise only, not on the robot: it says nothing about the "
    "pose, and with the cross-covariances the filter knows it. Without them it believes the "
    "landmark is independent of the robot and 'learns' a pose it was never told. (The "
    "cancellation needs both Jacobians at the same estimate, as here. In a running filter the "
    "pose estimate moves between the landmark's creation and its next reading, the cancellation "
    "fails and the filter gains heading information it does not have: chapter 06, First-"
    "Estimates Jacobians.)")

_R_SECOND = np.diag([0.05 ** 2, np.radians(2.0) ** 2])   # chapter 04's R: 5 cm, 2 degrees


def _random_prior(rng):
    """A random pose and two landmarks with a random correlated covariance (cm, degrees)."""
    x = np.concatenate([rng.uniform(-2, 2, 2), [rng.uniform(-np.pi, np.pi)],
                        rng.uniform(-3, 3, 4)])
    sd = np.concatenate([rng.uniform(0.01, 0.05, 2), [np.radians(rng.uniform(1, 5))],
                         rng.uniform(0.02, 0.1, 4)])
    M = rng.normal(size=(7, 7))
    C = M @ M.T + 3 * np.eye(7)
    C /= np.sqrt(np.outer(np.diag(C), np.diag(C)))
    return x, C * np.outer(sd, sd)


def heading_sigma_ratio(x, P, z, R, drop: bool) -> float:
    """Augment the state with the reading ``z``, optionally drop the new landmark's
    cross-covariances, update with ``z`` again from the same pose: the robot's heading sigma
    after the update over before it (chapter 04, section 5)."""
    from .. import ekf
    from ..models import inverse_observation_jacobians, inverse_observe, observe_landmarks

    n = x.size
    xa, Pa = np.zeros(n + 2), np.zeros((n + 2, n + 2))
    xa[:n], Pa[:n, :n] = x, P
    J1, J2 = inverse_observation_jacobians(x[:3], z)
    ekf.augment(xa, Pa, n, inverse_observe(x[:3], z), J1, J2, R)     # the filter's augment
    if drop:
        Pa[n:, :n] = 0.0
        Pa[:n, n:] = 0.0
    before = Pa[2, 2]
    h, Hp, Hl = observe_landmarks(xa[:3], xa[None, n:])
    idx, H = ekf.stacked_jacobian(np.array([n]), Hp, Hl)
    PHt, S = ekf.innovation_covariance(Pa, idx, H, R)
    ekf.joint_update(xa, Pa, PHt, S, ekf.innovation(h, h).reshape(-1))  # the filter's update
    return float(np.sqrt(Pa[2, 2] / before))


def measure_second_reading(n_runs: int = 100, seed: int = 12):
    """The second reading's effect on the heading sigma over ``n_runs`` seeded random SLAM
    states, with and without the cross-covariances: ``(choice, text)`` for the prediction."""
    rng = np.random.default_rng(seed)
    kept, dropped = [], []
    for _ in range(n_runs):
        x, P = _random_prior(rng)
        z = np.array([rng.uniform(0.5, 4.0), rng.uniform(-0.5, 0.5)])
        kept.append(heading_sigma_ratio(x, P, z, _R_SECOND, drop=False))
        dropped.append(heading_sigma_ratio(x, P, z, _R_SECOND, drop=True))
    kept, dropped = np.array(kept), np.array(dropped)
    worst = np.abs(kept - 1).max()
    choice = ("stays the same" if worst < 1e-6 else "grows" if kept.max() > 1
              else "shrinks a lot" if np.median(kept) < 0.9 else "shrinks a little")
    change = "less than 1e-12" if worst < 1e-12 else f"at most {worst:.1e}"
    return choice, (f"{n_runs} seeded random states: kept, the heading sigma changes by "
                    f"{change} (relative, round-off); dropped, it shrinks in "
                    f"{np.sum(dropped < 1)} of them, by {100 * (1 - np.median(dropped)):.0f} % "
                    f"in the median and by up to {100 * (1 - dropped.min()):.0f} %")


def check_second_reading_prediction(answer, verbose: bool = True) -> bool:
    """The student's prediction (one of :data:`SECOND_READING_CHOICES`) of what a second
    reading of a just-mapped landmark, from the same pose, does to the robot's heading sigma
    when the cross-covariances are kept (chapter 04, section 5). Measured by
    :func:`measure_second_reading`; the accepted answer and the argument are printed only
    once an answer is given."""
    from .predictions import check_prediction

    return check_prediction(answer, measure_second_reading, accept={"stays the same"},
                            why=_WHY_SECOND_READING,
                            name="heading sigma after the second reading",
                            choices=SECOND_READING_CHOICES, verbose=verbose)
