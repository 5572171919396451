"""Chapter 03's exercise checkers: the direct observation's Jacobians H_pose, H_landmark,
and the prediction of the NEES of a filter whose R is too large.

The verdicts follow :mod:`slamlib.course.harness` and :mod:`slamlib.course.predictions`.
"""

from __future__ import annotations

import numpy as np

from ..checks import compare_jacobians, numerical_jacobian
from .harness import attempt, name_of, printer

__all__ = ["check_observation_jacobians", "check_nees_prediction"]


# every entry of the two Jacobians: what it differentiates, and its value (dx = x_F - x,
# dy = y_F - y, q = dx^2 + dy^2), for the hint on an entry no other hint explains
_ENTRIES = {
    "H_pose": (
        (("d range / d x", "-dx/sqrt(q): moving towards the marker shortens the range"),
         ("d range / d y", "-dy/sqrt(q)"),
         ("d range / d theta", "0: turning in place does not change the distance")),
        (("d bearing / d x", "dy/q"),
         ("d bearing / d y", "-dx/q"),
         ("d bearing / d theta", "-1")),
    ),
    "H_landmark": (
        (("d range / d x_F", "dx/sqrt(q)"), ("d range / d y_F", "dy/sqrt(q)")),
        (("d bearing / d x_F", "-dy/q"), ("d bearing / d y_F", "dx/q")),
    ),
}


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
    from ..models import observe

    say = printer(verbose)

    name = name_of(fn)
    pts = _random_observation_points(max(int(n_points), 2), seed)
    for i, (pose, lm) in enumerate(pts):
        out = attempt(fn, pose.copy(), lm.copy(), say=say, what="H_pose and H_landmark")
        if out is None:
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
        for r, k in [key for key in wrong_p if key[0] == 0] + [key for key in wrong_l
                                                                if key[0] == 0]:
            g, e = wrong_p.get((r, k)) or wrong_l[(r, k)]
            if e != 0.0 and np.isclose(abs(g) * np.sqrt(q), abs(e), rtol=1e-4):
                hints.append("the range row is [dx/sqrt(q), dy/sqrt(q)] for the landmark "
                             "(d sqrt(q) / d x_F = dx / sqrt(q)): yours divides by q.")
                break
        if not hints:
            named = [("H_pose", key, flipped(wrong_p, key)) for key in wrong_p]
            named += [("H_landmark", key, flipped(wrong_l, key)) for key in wrong_l]
            for which, (r, k), sign in named[:2]:
                what, formula = _ENTRIES[which][r][k]
                hints.append(f"{which}[{r},{k}] = {what} = {formula}"
                             + (" (yours has the opposite sign)." if sign else "."))
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


# --------------------------------------------------------------------------- predict, then measure
_WHY_R_TOO_LARGE = (
    "A covariance four times too large on the readings makes P too large, so the NEES "
    "e^T P^-1 e falls below 3. But not by four: P is not made of R alone. Between frames the "
    "odometry's Q adds the same uncertainty as before, and the estimate's error hardly changes "
    "(the ATE is the same to 0.2 mm), so the NEES lands between 3/4 (if P were all R) and 3 "
    "(if it were all Q). Part of the measured drop is the gate: with R this large it rejects "
    "almost no reading, and the censoring that added about 0.24 to the NEES with the right R "
    "(section 5) is gone.")


def check_nees_prediction(answer, verbose: bool = True) -> bool:
    """The student's prediction of the mean pose NEES of the map-based EKF told that the
    camera is twice as noisy as it is (R four times too large), chapter 03, section 7.

    Measured on the stored 100-seed study ``arena_localization`` (its ``assumed/2`` part,
    gate 0.95); a justified prediction is 0.75 to 2.9 (between 3/4 and 3, the argument's
    bounds, 3 itself excluded: R is part of P). The range and the argument are printed
    only once an answer is given (:func:`slamlib.course.predictions.check_prediction`).
    """
    from . import evidence
    from .predictions import check_prediction

    def measure():
        study = evidence.load_study("arena_localization")

        def per_run(part):
            return evidence.column(study, part, "nees_sum") / evidence.column(study, part, "n")

        right, twice = per_run("clean/0.95"), per_run("assumed/2")
        half = 1.96 * twice.std(ddof=1) / np.sqrt(twice.size)
        rej = (evidence.column(study, "assumed/2", "rejected").sum()
               / evidence.column(study, "assumed/2", "gated").sum())
        return twice.mean(), (f"mean pose NEES over {twice.size} stored seeded runs, gate 0.95, "
                              f"interval +- {half:.2f}, {rej:.1%} of the readings rejected; "
                              f"with the right R {right.mean():.2f}")

    return check_prediction(answer, measure, accept=(0.75, 2.9), why=_WHY_R_TOO_LARGE,
                            name="average NEES with R too large", verbose=verbose)
