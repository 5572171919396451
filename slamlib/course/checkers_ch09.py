"""Chapter 09's exercise checker: the joint distance of an association hypothesis.

The student writes ``joint_d2(y, H, P, R) -> D2`` for a hypothesis of m
pairings: ``y`` (m, 2) the paired innovations (bearing already wrapped), ``H``
(2m, n) their stacked Jacobians over the whole state, ``P`` (n, n) the state's
covariance and ``R`` (m, 2, 2) each reading's noise. Expected::

    S  = H P H^T + blockdiag(R_1, ..., R_m)
    D2 = y_H^T S^-1 y_H,     y_H = [y_1; y_2; ...; y_m]  (reading by reading)

:func:`check_joint_distance` computes it independently at seeded cases in
which the cross terms matter (the robot's pose is uncertain and shared by all
readings) and names the usual mistakes.
"""

from __future__ import annotations

import numpy as np

from ..models import observe_landmarks
from .harness import attempt, name_of, printer

__all__ = ["check_joint_distance", "joint_distance_cases"]


def joint_distance_cases(n: int = 8, seed: int = 9):
    """Seeded hypotheses ``(y, H, P, R)`` with an uncertain pose shared by the readings.

    Each case: a pose, 2 to 4 mapped landmarks, m = 2 or 3 pairings (landmarks
    in random order), P with a pose block much larger than the landmarks'
    relative uncertainty, and a different R per reading.
    """
    rng = np.random.default_rng(seed)
    for c in range(n):
        N = int(rng.integers(2, 5))
        m = int(min(N, 2 + c % 2))
        pose = np.array([rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-np.pi, np.pi)])
        ang = pose[2] + rng.uniform(-0.5, 0.5, N)
        rho = rng.uniform(1.0, 4.0, N)
        L = pose[:2] + np.column_stack([rho * np.cos(ang), rho * np.sin(ang)])
        nstate = 3 + 2 * N
        A = rng.normal(size=(nstate, nstate)) * 0.02
        P = A @ A.T + 1e-4 * np.eye(nstate)
        J = np.zeros((nstate, 3))                    # the landmarks share the pose's error
        J[:3] = np.eye(3)
        J[3:] = np.tile(np.eye(2, 3), (N, 1))
        Ppose = np.diag([0.15, 0.15, 0.05]) ** 2
        P = P + J @ Ppose @ J.T
        which = rng.permutation(N)[:m]
        _, Hp, Hl = observe_landmarks(pose, L[which])
        H = np.zeros((2 * m, nstate))
        for q, j in enumerate(which):
            H[2 * q:2 * q + 2, :3] = Hp[q]
            H[2 * q:2 * q + 2, 3 + 2 * j:5 + 2 * j] = Hl[q]
        R = np.array([np.diag([rng.uniform(0.02, 0.06), np.radians(rng.uniform(0.5, 2.0))]) ** 2
                      for _ in range(m)])
        S = _joint_S(H, P, R)
        y = (np.linalg.cholesky(S) @ rng.normal(size=2 * m)).reshape(m, 2)
        yield y, H, P, R


def _joint_S(H, P, R):
    m = R.shape[0]
    S = H @ P @ H.T
    for q in range(m):
        S[2 * q:2 * q + 2, 2 * q:2 * q + 2] += R[q]
    return S


def _mistakes(y, H, P, R) -> dict[str, float]:
    """What the usual mistakes compute, by name (the hint the checker prints)."""
    m = R.shape[0]
    S = _joint_S(H, P, R)
    yv = y.reshape(-1)
    HPH = H @ P @ H.T
    ind = sum(float(y[q] @ np.linalg.solve(HPH[2 * q:2 * q + 2, 2 * q:2 * q + 2] + R[q], y[q]))
              for q in range(m))
    S0 = HPH.copy()
    for q in range(m):
        S0[2 * q:2 * q + 2, 2 * q:2 * q + 2] += R[0]
    d2 = float(yv @ np.linalg.solve(S, yv))
    yc = y.T.reshape(-1)                             # ranges first, then bearings
    return {
        "it is the SUM of the individual distances y_i^T S_i^-1 y_i: that ignores the cross "
        "terms H_i P H_j^T between readings (they share the robot's pose). Invert the whole "
        "2m x 2m S":
            ind,
        "R is missing: S = H P H^T + blockdiag(R_1, ..., R_m), the readings' own noise on the "
        "diagonal blocks":
            float(yv @ np.linalg.solve(HPH, yv)),
        "it uses S where S^-1 belongs (y^T S y). Use np.linalg.solve(S, y)":
            float(yv @ S @ yv),
        "it returns D, not D^2 (no square root)":
            float(np.sqrt(d2)),
        "it uses R[0] for every reading: each reading has its own R_i (the noise grows "
        "with range)":
            float(yv @ np.linalg.solve(S0, yv)),
        "y is stacked as [ranges..., bearings...], but H's rows are reading by reading "
        "[rho_1, beta_1, rho_2, beta_2, ...]: use y.reshape(-1)":
            float(yc @ np.linalg.solve(S, yc)),
    }


def check_joint_distance(fn, n_cases: int = 8, seed: int = 9, verbose: bool = True) -> bool:
    """Check a student's ``fn(y, H, P, R) -> D2`` (chapter 09); prints a verdict, returns it.

    The reference ``y_H^T (H P H^T + blockdiag(R))^-1 y_H`` is computed here at
    ``n_cases`` seeded hypotheses (:func:`joint_distance_cases`). A wrong answer
    is named when it matches a known mistake: the sum of the individual
    distances (no cross terms), R left out, S instead of S^-1, D instead of
    D^2, one R for all readings, or y stacked ranges-first.
    """
    say = printer(verbose)
    name = name_of(fn)
    for y, H, P, R in joint_distance_cases(n_cases, seed):
        out = attempt(fn, y.copy(), H.copy(), P.copy(), R.copy(), say=say)
        if out is None:
            return False
        try:
            a = np.asarray(out, dtype=float)
            if a.size != 1:
                raise ValueError(f"expected one number, got shape {a.shape}")
            got = float(a.reshape(-1)[0])
        except (TypeError, ValueError) as exc:
            say(f"{name}: expected one number D2 ({exc}).")
            return False
        S = _joint_S(H, P, R)
        ref = float(y.reshape(-1) @ np.linalg.solve(S, y.reshape(-1)))
        if not np.isclose(got, ref, rtol=1e-6, atol=1e-9):
            say(f"{name}: wrong for a hypothesis of {R.shape[0]} pairings: got {got:.6g}, "
                f"expected {ref:.6g}.")
            for why, value in _mistakes(y, H, P, R).items():
                if np.isclose(got, value, rtol=1e-6, atol=1e-9):
                    say(f"  Hint: {why}.")
                    break
            else:
                say("  Hint: S = H P H^T + blockdiag(R_i), then D2 = y^T S^-1 y with "
                    "y = y.reshape(-1).")
            return False
    say(f"{name}: correct. D2 matches at {n_cases} hypotheses of 2 and 3 pairings, where the "
        f"sum of the individual distances would not.")
    return True
