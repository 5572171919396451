"""Chapter 05's exercise checker: the wrapped innovation, its Mahalanobis distance and
the chi-square gate.

The verdicts follow :mod:`slamlib.course.harness`.
"""

from __future__ import annotations

import numpy as np

from .harness import attempt, name_of, one_number, printer

__all__ = ["check_gate"]


def _wrap_independent(a):
    """(a + pi) mod 2 pi - pi, written out here so the checker does not trust wrap_angle."""
    return (np.asarray(a, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def _random_gate_cases(n: int, seed: int):
    """Readings, predictions, innovation covariances and gate probabilities.

    Half the innovations fall inside the gate and half outside; every third
    one straddles the +-pi seam (prediction just below pi, reading just above
    -pi, or the other way round).
    """
    from scipy.stats import chi2

    rng = np.random.default_rng(seed)
    probs = (0.95, 0.99, 0.9, 0.5, 0.999)
    for i in range(n):
        prob = probs[i % len(probs)]
        thr = float(chi2.ppf(prob, 2))
        sr, sb = rng.uniform(0.02, 0.2), np.radians(rng.uniform(0.5, 6.0))
        c = rng.uniform(-0.6, 0.6)
        S = np.array([[sr * sr, c * sr * sb], [c * sr * sb, sb * sb]])
        d2 = thr * (rng.uniform(0.02, 0.95) if i % 2 == 0 else rng.uniform(1.05, 3.0))
        u = rng.normal(size=2)
        y = np.linalg.cholesky(S) @ (u / np.linalg.norm(u)) * np.sqrt(d2)
        h_r = abs(y[0]) + rng.uniform(0.3, 3.0)
        if i % 3 == 0:   # across the seam: h + y leaves [-pi, pi) and comes back on the other side
            h_b = np.pi - y[1] / 2 if y[1] > 0 else -np.pi - y[1] / 2
        else:
            h_b = rng.uniform(-np.pi + abs(y[1]), np.pi - abs(y[1]))
        z_pred = np.array([h_r, h_b])
        z = np.array([h_r + y[0], _wrap_independent(h_b + y[1])])
        yield z, z_pred, S, prob


def check_gate(fn, n_points: int = 20, seed: int = 5, verbose: bool = True) -> bool:
    """Check a student's ``fn(z, z_pred, S, prob) -> (d2, accept)`` (chapter 05).

    ``z`` is a reading ``[range, bearing]``, ``z_pred`` the predicted one
    ``h(x)``, ``S`` the 2x2 innovation covariance, ``prob`` the gate
    probability. Expected: the innovation ``y = z - z_pred`` with its bearing
    wrapped to [-pi, pi), ``d2 = y^T S^-1 y`` and ``accept = d2 < chi2.ppf(prob, 2)``.

    The reference is computed here independently (its own wrap, ``solve``,
    scipy's chi-square quantile) at ``n_points`` seeded cases, a third of them
    across the +-pi seam, half inside the gate and half outside. A wrong answer
    is diagnosed when it matches a known mistake: bearing not wrapped, ``S``
    used instead of ``S^-1``, ``D`` returned instead of ``D^2``, the report's
    eq. (6) (``h`` subtracted twice), the off-diagonal of ``S`` ignored, or a
    wrong threshold (1 degree of freedom, the probability itself, ``1 - p``,
    a fixed 5.99, the comparison reversed), or the pair returned as
    ``(accept, d2)``.
    """
    from scipy.stats import chi2

    say = printer(verbose)

    name = name_of(fn)
    cases = list(_random_gate_cases(n_points, seed))
    got = []
    for z, z_pred, S, prob in cases:
        out = attempt(fn, z.copy(), z_pred.copy(), S.copy(), prob, say=say)
        if out is None:
            return False
        if (isinstance(out, (tuple, list)) and len(out) == 2
                and isinstance(out[0], (bool, np.bool_))
                and not isinstance(out[1], (bool, np.bool_))):
            say(f"{name}: it returns (accept, d2), a True/False first: return the pair in the "
                f"order (d2, accept).")
            return False
        try:
            d2, accept = out
            d2 = one_number(d2)
            acc = np.asarray(accept)
            if acc.size != 1:
                raise ValueError(f"accept: expected one True/False, got shape {acc.shape}")
            got.append((d2, bool(acc.reshape(-1)[0])))
        except (TypeError, ValueError) as exc:
            say(f"{name}: expected a pair (d2, accept) with d2 a number and accept True/False "
                f"({exc}).")
            return False

    def where(z, z_pred, prob):
        return (f"z = [{z[0]:.3f}, {z[1]:.4f}], z_pred = [{z_pred[0]:.3f}, {z_pred[1]:.4f}], "
                f"prob = {prob}")

    # ---- the distance
    def variants(z, z_pred, S):
        y = np.array([z[0] - z_pred[0], _wrap_independent(z[1] - z_pred[1])])
        y_raw = np.asarray(z, float) - np.asarray(z_pred, float)
        d2 = float(y @ np.linalg.solve(S, y))
        return d2, {
            "the bearing of the innovation is not wrapped: across the +-pi seam a 0.02 rad "
            "difference becomes almost 2 pi. Wrap y[1] to [-pi, pi)":
                float(y_raw @ np.linalg.solve(S, y_raw)),
            "it uses S where S^-1 belongs (y^T S y). Use np.linalg.solve(S, y)":
                float(y @ S @ y),
            "it returns D, the distance, not D^2 = y^T S^-1 y (no square root)":
                float(np.sqrt(d2)),
            "it is the report's eq. (6): (y - h)^T S^-1 (y - h) subtracts the prediction twice. "
            "The innovation y = z - h is already the difference":
                float((y - z_pred) @ np.linalg.solve(S, y - z_pred)),
            "it ignores the off-diagonal (range-bearing correlation) of S. Use the full S^-1":
                float(y @ (y / np.diag(S))),
        }

    for (z, z_pred, S, prob), (d2, _) in zip(cases, got):
        ref, wrong = variants(z, z_pred, S)
        if not np.isclose(d2, ref, rtol=1e-6, atol=1e-9):
            say(f"{name}: d2 is wrong at {where(z, z_pred, prob)}: got {d2:.6g}, "
                f"expected {ref:.6g}.")
            for why, value in wrong.items():
                if np.isclose(d2, value, rtol=1e-6, atol=1e-9):
                    say(f"  Hint: {why}.")
                    break
            else:
                say("  Hint: y = z - z_pred with y[1] wrapped to [-pi, pi), then d2 = y^T S^-1 y.")
            return False

    # ---- the decision
    thresholds = [float(chi2.ppf(p, 2)) for *_, p in cases]
    wrong_rules = {
        "it accepts when d2 is ABOVE the threshold: the comparison is reversed":
            lambda d2, p, t: d2 > t,
        "your threshold looks like chi2.ppf(prob, 1); use chi2.ppf(prob, 2): the "
        "innovation has 2 degrees of freedom (range and bearing)":
            lambda d2, p, t: d2 < chi2.ppf(p, 1),
        "it compares d2 with the probability itself; compare it with the chi-square "
        "quantile chi2.ppf(prob, 2)":
            lambda d2, p, t: d2 < p,
        "your threshold looks like chi2.ppf(1 - prob, 2); use chi2.ppf(prob, 2): prob is "
        "the probability inside the gate":
            lambda d2, p, t: d2 < chi2.ppf(1.0 - p, 2),
        "it compares d2 with sqrt(threshold); compare D^2 with the chi-square quantile "
        "chi2.ppf(prob, 2) itself":
            lambda d2, p, t: d2 < np.sqrt(t),
        "your threshold looks fixed at 5.99, which is right only for prob = 0.95; use "
        "chi2.ppf(prob, 2)":
            lambda d2, p, t: d2 < 5.991,
    }
    for (z, z_pred, _S, prob), (d2, acc), thr in zip(cases, got, thresholds):
        if acc != (d2 < thr):
            say(f"{name}: wrong decision at {where(z, z_pred, prob)}: d2 = {d2:.4f}, the gate's "
                f"threshold is chi2.ppf({prob}, 2) = -2 ln(1 - {prob}) = {thr:.4f}, so the "
                f"reading should be {'accepted' if d2 < thr else 'rejected'}, got "
                f"accept = {acc}.")
            fits = [why for why, rule in wrong_rules.items()
                    if all(bool(rule(d, c[3], t)) == a
                           for c, (d, a), t in zip(cases, got, thresholds))]
            for why in fits:
                say(f"  Hint: {why}.")
            if not fits:
                say("  Hint: accept = d2 < chi2.ppf(prob, 2), which for 2 degrees of freedom "
                    "is -2 ln(1 - prob).")
            return False
    n_seam = len(range(0, n_points, 3))
    say(f"{name}: correct. d2 and the decision match at {n_points} readings "
        f"({n_seam} across the +-pi seam, gate probabilities 0.5 to 0.999).")
    return True
