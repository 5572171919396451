"""Chapter 06's exercise checker: the chi-square band of a Monte-Carlo average NEES.

The verdicts follow :mod:`slamlib.course.harness`.
"""

from __future__ import annotations

import numpy as np

from .harness import attempt, name_of, one_number, printer

__all__ = ["check_average_nees_band"]


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
