"""Chapter 06's exercise checkers: the chi-square band of a Monte-Carlo average NEES; how much
of a global rotation a reading sees (section 3, step 4).

The verdicts follow :mod:`slamlib.course.harness`.
"""

from __future__ import annotations

import numpy as np

from .harness import attempt, matching_mistakes, name_of, one_number, printer

__all__ = ["check_average_nees_band", "check_rotation_seen"]


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

    say = printer(verbose)
    name = name_of(fn)
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
        out = attempt(fn, n, d, p, say=say)
        if out is None:
            return False
        try:
            lo, hi = (one_number(v) for v in out)
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


def rotation_direction(x) -> np.ndarray:
    """``N_phi(x) = [-y, x, 1, -y_1, x_1, ...]``: how the state ``[x, y, theta, x_1, y_1, ...]``
    changes per unit rotation of everything (robot and landmarks) about the origin."""
    x = np.asarray(x, dtype=float).reshape(-1)
    if x.size < 3 or (x.size - 3) % 2:
        raise ValueError(f"x: expected [x, y, theta, x_1, y_1, ...] (3 + 2n values), got {x.size}")
    n = np.empty_like(x)
    n[0:2], n[2] = (-x[1], x[0]), 1.0
    n[3::2], n[4::2] = -x[4::2], x[3::2]
    return n


def rotation_seen(pose, landmark_h, landmark_n) -> float:
    """``|H N_phi| / |H|`` for one reading: ``H = [H_pose, H_landmark]`` (chapter 03's
    :func:`slamlib.models.observation_jacobians`) at ``(pose, landmark_h)``, ``N_phi`` (step 2)
    at ``(pose, landmark_n)``; ``|H|`` its Frobenius norm."""
    from ..models import observation_jacobians

    pose, landmark_n = np.asarray(pose, dtype=float), np.asarray(landmark_n, dtype=float)
    Hp, Hl = observation_jacobians(pose, np.asarray(landmark_h, dtype=float))
    H = np.hstack([Hp, Hl])
    n_phi = rotation_direction(np.r_[pose, landmark_n])
    return float(np.linalg.norm(H @ n_phi) / np.linalg.norm(H))


def check_rotation_seen(fn, verbose: bool = True) -> bool:
    """Check a student's ``fn(pose, landmark_h, landmark_n) -> |H N_phi| / |H|`` (chapter 06,
    section 3, step 4): ``H`` at ``(pose, landmark_h)``, ``N_phi`` at ``(pose, landmark_n)``.
    A wrong answer is diagnosed when it matches a known mistake (``N_phi`` taken at ``H``'s own
    point, not divided by ``|H|``, the landmark's part of ``N_phi`` left out)."""
    from ..models import observation_jacobians

    say = printer(verbose)
    name = name_of(fn)
    rng = np.random.default_rng(6)
    cases = []
    for moved in (0.0, 0.0, 0.05, 0.2, 0.5):
        pose = np.r_[rng.uniform(-2, 2, 2), rng.uniform(-np.pi, np.pi)]
        ahead = np.array([np.cos(pose[2] + 0.3), np.sin(pose[2] + 0.3)])
        lm = pose[:2] + rng.uniform(1.0, 3.0) * ahead
        cases.append((pose, lm + moved * rng.normal(size=2), lm))

    def h_of(pose, lh):
        Hp, Hl = observation_jacobians(pose, lh)
        return np.hstack([Hp, Hl])

    mistakes = {
        "N_phi is taken at H's own point: there a rotation is invisible by construction. Take it "
        "at landmark_n, where the chain carried it":
            lambda p, lh, ln: rotation_seen(p, lh, lh),
        "divide by |H| (np.linalg.norm of the 2x5 [H_pose, H_landmark])":
            lambda p, lh, ln: rotation_seen(p, lh, ln) * np.linalg.norm(h_of(p, lh)),
        "N_phi moves the landmark too: it has five entries, [-y, x, 1, -y_1, x_1]":
            lambda p, lh, ln: float(np.linalg.norm(h_of(p, lh)[:, :3] @ [-p[1], p[0], 1.0])
                                    / np.linalg.norm(h_of(p, lh))),
    }
    answers = []
    for pose, lh, ln in cases:
        out = attempt(fn, pose.copy(), lh.copy(), ln.copy(), say=say, what="|H N_phi| / |H|")
        if out is None:
            return False
        try:
            answers.append(one_number(out))
        except (TypeError, ValueError) as exc:
            say(f"{name}: expected one number ({exc}).")
            return False
    want = [rotation_seen(*c) for c in cases]
    wrong = [i for i, (a, w) in enumerate(zip(answers, want))
             if not np.isclose(a, w, rtol=1e-6, atol=1e-9)]
    if not wrong:
        say(f"{name}: correct: 0 when H and N_phi are at the same point, up to {max(want):.2f} "
            "here when the landmark moved between them.")
        return True
    i = wrong[0]
    pose, lh, ln = cases[i]
    say(f"{name}: not right for pose {np.round(pose, 3).tolist()}, "
        f"landmark_h {np.round(lh, 3).tolist()}, "
        f"landmark_n {np.round(ln, 3).tolist()}: got {answers[i]:.6f}, expected {want[i]:.6f}.")
    hints = matching_mistakes(mistakes, answers, cases,
                              lambda a, b: bool(np.isclose(a, b, rtol=1e-6, atol=1e-9)))
    say(f"  Hint: {hints[0]}." if hints else
        "  Hint: H = np.hstack(observation_jacobians(pose, landmark_h)); N_phi from step 2 at "
        "np.r_[pose, landmark_n]; return norm(H @ N_phi) / norm(H).")
    return False
