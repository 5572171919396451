"""Chapter 09's exercise checkers: the joint distance of a hypothesis, and JCBB.

The student writes ``joint_d2(y, H, P, R) -> D2`` for a hypothesis of m
pairings: ``y`` (m, 2) the paired innovations (bearing already wrapped), ``H``
(2m, n) their stacked Jacobians over the whole state, ``P`` (n, n) the state's
covariance and ``R`` (m, 2, 2) each reading's noise. Expected::

    S  = H P H^T + blockdiag(R_1, ..., R_m)
    D2 = y_H^T S^-1 y_H,     y_H = [y_1; y_2; ...; y_m]  (reading by reading)

:func:`check_joint_distance` computes it independently at seeded cases in
which the cross terms matter (the robot's pose is uncertain and shared by all
readings) and names the usual mistakes.

The student also writes ``jcbb(d2, joint, gate) -> assignment`` (the search of
JCBB, on the individual distances and a function ``joint(pairs) -> D2``);
:func:`check_jcbb` compares it with an exhaustive enumeration of every
hypothesis (:func:`best_hypothesis`) at seeded small frames.
"""

from __future__ import annotations

import numpy as np

from ..models import observe_landmarks
from .harness import attempt, name_of, printer

__all__ = ["check_joint_distance", "joint_distance_cases", "check_jcbb", "jcbb_cases",
           "best_hypothesis"]


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
    say(f"{name}: correct. D2 matches at {n_cases} hypotheses of 2 and 3 pairings,")
    say("  where the sum of the individual distances would not.")
    return True


# --------------------------------------------------------------------------- JCBB
def jcbb_cases(n: int = 12, seed: int = 11):
    """Seeded small frames ``(d2, y, C, R)``: k readings, N landmarks (2 to 4 each), an
    uncertain pose shared by the predicted readings (``C = H P H^T``), readings made from
    a true pairing shifted by one pose error, so that some readings have several candidates.
    The first case is section 4's: A, B and C, NN wrong."""
    from ..models import observe

    # section 4: the robot believed at the origin (0.2 m sigma), in truth 0.15 m to the side
    P0 = np.diag([0.2 ** 2, 0.2 ** 2, 1e-8])
    R0 = np.diag([0.02 ** 2, np.radians(1.0) ** 2])
    lm = np.array([[2.0, 0.0], [2.0, -0.15], [2.0, 2.0]])
    h, Hp, _ = observe_landmarks(np.zeros(3), lm)
    z = np.array([observe(np.array([0.0, 0.15, 0.0]), lm[0]),
                  observe(np.array([0.0, 0.15, 0.0]), lm[2])])
    cases = [_frame(z, h, Hp, P0, np.array([R0, R0]))]
    rng = np.random.default_rng(seed)
    while len(cases) < n:
        k, N = int(rng.integers(2, 5)), int(rng.integers(2, 5))
        pose = np.zeros(3)
        ang = rng.uniform(-0.5, 0.5, N)
        rho = rng.uniform(1.5, 3.5, N)
        lm = np.column_stack([rho * np.cos(ang), rho * np.sin(ang)])
        P = np.diag([rng.uniform(0.05, 0.2), rng.uniform(0.05, 0.2), np.radians(2.0)]) ** 2
        R = np.array([np.diag([0.03, np.radians(1.5)]) ** 2 for _ in range(k)])
        truth = rng.normal(0.0, np.sqrt(np.diag(P)))          # the estimate is the origin
        seen = rng.integers(0, N, k)                  # several readings may see one landmark
        z = np.array([observe(truth, lm[j]) + rng.normal(0.0, [0.03, np.radians(1.5)])
                      for j in seen])
        h, Hp, _ = observe_landmarks(pose, lm)
        frame = _frame(z, h, Hp, P, R)
        d2 = frame[0]
        if np.sum(d2 < 5.99) >= 2:                    # at least two candidate pairs
            cases.append(frame)
    return cases


def _frame(z, h, Hp, P, R):
    """``(d2, y, C, R)`` of readings ``z`` against predictions ``h`` (known map, pose P)."""
    from ..association import individual_d2

    N = h.shape[0]
    A = Hp.reshape(2 * N, 3)
    C = A @ P @ A.T
    y = z[:, None, :] - h[None]
    y[:, :, 1] = (y[:, :, 1] + np.pi) % (2 * np.pi) - np.pi
    S = np.array([[C[2 * j:2 * j + 2, 2 * j:2 * j + 2] + R[i] for j in range(N)]
                  for i in range(z.shape[0])])
    return individual_d2(y, S), y, C, R


def _joint(y, C, R, pairs) -> float:
    """``D2`` of the hypothesis ``pairs`` [(reading, landmark), ...] (cross terms included)."""
    if not pairs:
        return 0.0
    idx = np.concatenate([[2 * j, 2 * j + 1] for _, j in pairs])
    S = C[np.ix_(idx, idx)].copy()
    for q, (i, _) in enumerate(pairs):
        S[2 * q:2 * q + 2, 2 * q:2 * q + 2] += R[i]
    yv = np.concatenate([y[i, j] for i, j in pairs])
    return float(yv @ np.linalg.solve(S, yv))


def _problems(assign, d2, joint, gate) -> list[str]:
    """Why ``assign`` is not a JCBB hypothesis at all (empty list: it is one)."""
    from ..metrics import chi2_quantile

    out = []
    pairs = [(i, int(j)) for i, j in enumerate(assign) if j >= 0]
    js = [j for _, j in pairs]
    if len(set(js)) < len(js):
        out.append("a landmark takes two readings: one reading per landmark per frame")
    for i, j in pairs:
        if not d2[i, j] < chi2_quantile(gate, 2):
            out.append(f"reading {i} is paired with landmark {j} outside its individual gate "
                       f"(d2 {d2[i, j]:.2f} >= {chi2_quantile(gate, 2):.2f})")
    for m in range(1, len(pairs) + 1):
        D = joint(pairs[:m])
        if not D < chi2_quantile(gate, 2 * m):
            out.append(f"the first {m} pairings are not jointly compatible (D2 {D:.2f} >= "
                       f"chi2_{2 * m}({gate:g}) = {chi2_quantile(gate, 2 * m):.2f}): test "
                       f"each pair as you add it")
            break
    return out


def best_hypothesis(d2, joint, gate) -> tuple[np.ndarray, int, float, int]:
    """The answer JCBB must find, by enumerating every hypothesis: every pairing inside its
    individual gate, one reading per landmark, every prefix jointly compatible; the most
    pairings, then the smallest ``D2``. Returns ``(assignment, pairs, D2, hypotheses)``."""
    import itertools

    k, N = d2.shape
    best, key, count = None, None, 0
    for hyp in itertools.product(range(-1, N), repeat=k):
        count += 1
        if _problems(hyp, d2, joint, gate):
            continue
        pairs = [(i, j) for i, j in enumerate(hyp) if j >= 0]
        kk = (-len(pairs), joint(pairs))
        if key is None or kk < key:
            best, key = np.array(hyp), kk
    return best, -key[0], key[1], count


def check_jcbb(fn, n_cases: int = 12, seed: int = 11, gate: float = 0.95,
               verbose: bool = True) -> bool:
    """Check a student's ``fn(d2, joint, gate) -> assignment`` (JCBB's search, chapter 09).

    ``d2`` is the (k, N) table of individual distances, ``joint(pairs)`` the joint ``D2``
    of a list of ``(reading, landmark)`` pairs (cross terms included), ``gate`` the
    probability of both tests. The answer, one landmark per reading (-1: none), is compared
    with :func:`best_hypothesis` (every hypothesis enumerated) at ``n_cases`` seeded frames,
    the first of them section 4's. Named problems: a pair outside its gate, a landmark
    used twice, a hypothesis not jointly compatible, fewer pairings than possible (the
    sequential nearest neighbour stops there), a larger ``D2`` among as many pairings.
    """
    say = printer(verbose)
    name = name_of(fn)
    calls_total = 0
    enumerated = 0
    for c, case in enumerate(jcbb_cases(n_cases, seed)):
        verdict = _check_jcbb_case(fn, name, c, *case, gate, say)
        if verdict is None:
            return False
        calls_total += verdict[0]
        enumerated += verdict[1]
    say(f"{name}: correct. The best hypothesis at {n_cases} frames, section 4's first;")
    say(f"  your search evaluated D2 {calls_total} times; the frames hold {enumerated} "
        f"hypotheses in all.")
    return True


def _check_jcbb_case(fn, name, c, d2, y, C, R, gate, say):
    """One frame of :func:`check_jcbb`: ``(D2 evaluations, hypotheses)`` if right, else None."""
    calls = [0]

    def joint(pairs):
        calls[0] += 1
        return _joint(y, C, R, [(int(i), int(j)) for i, j in pairs])

    def exact(pairs):
        return _joint(y, C, R, pairs)

    out = attempt(fn, d2.copy(), joint, gate, say=say)
    if out is None:
        return None
    k = d2.shape[0]
    try:
        a = np.asarray(out).astype(int).reshape(-1)
        if a.size != k:
            raise ValueError(f"expected {k} entries, one per reading, got {a.size}")
    except (TypeError, ValueError) as exc:
        say(f"{name}: expected one landmark index per reading (-1: none) ({exc}).")
        return None
    where = "section 4's frame" if c == 0 else \
        f"frame {c} ({k} readings, {d2.shape[1]} landmarks)"
    ref, pairs, D, count = best_hypothesis(d2, exact, gate)
    if np.array_equal(a, ref):
        return calls[0], count
    say(f"{name}: wrong for {where}: got {a.tolist()}, expected {ref.tolist()}.")
    bad = _problems(a, d2, exact, gate)
    if bad:
        say(f"  Hint: {bad[0]}.")
        return None
    got = [(i, int(j)) for i, j in enumerate(a) if j >= 0]
    if len(got) < pairs:
        say(f"  Hint: yours has {len(got)} pairings; {pairs} are possible together. After a "
            f"first answer, keep searching: try leaving a reading unpaired, and later "
            f"readings may pair then. (The first leaf, each reading in turn to its closest "
            f"compatible landmark, is the sequential nearest neighbour, not JCBB.)")
    else:
        say(f"  Hint: as many pairings, but D2 {exact(got):.3f} where {D:.3f} is possible: "
            f"among the hypotheses with the most pairings, keep the one of smallest D2.")
    return None
