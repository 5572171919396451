"""Checkers for the exercises in which the student writes the filter itself.

Each checker runs the student's function on seeded test states, compares the
answer with what the library's own steps give (:func:`slamlib.ekf.predict`,
:func:`~slamlib.ekf.stacked_jacobian`, :func:`~slamlib.ekf.joint_update`,
:func:`~slamlib.ekf.augment`: the code the filters run, in the textbook's
signatures below) and, when it is wrong, tries the known mistakes one by one
and names the one that reproduces the answer. They share
the harness of :mod:`slamlib.course.harness` (``"not written yet"`` for a stub, an
exception reported rather than raised, a verdict printed, True or False
returned).

- :func:`check_predict_covariance`  the prediction on the blocks (chapter 04; 01, 05)
- :func:`check_stacked_jacobian`    the stacked ``H`` of m readings (chapters 03, 05)
- :func:`check_joint_update`        one joint update, eqs. (1)-(5) (chapters 03, 05)
- :func:`check_augment`             a new landmark with its cross-covariances (chapter 04)
- :func:`check_trace_nees`          the NEES of a trace (chapters 03, 06)
- :func:`check_consistency_verdict` average NEES of N runs inside its band (chapter 06)

A mistake that uses a notebook variable in place of an argument (``Q``
where the argument ``R`` belongs) is found by trying the 2x2 arrays named
``Q`` and ``R`` among the student's globals.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .. import ekf
from ..metrics import chi2_band, nees, pose_error
from ..models import (
    inverse_observation_jacobians,
    inverse_observe,
    observation_jacobians,
    observe,
    wrap_angle,
)
from .checkers_ch04 import J1_ENTRIES, J2_ENTRIES
from .harness import attempt, call, name_of, not_ready, printer

__all__ = ["check_predict_covariance", "check_stacked_jacobian", "check_joint_update",
           "check_augment", "check_trace_nees", "check_consistency_verdict"]


# --------------------------------------------------------------------------- the expected answers
# The library's steps (slamlib.ekf) in the exercises' signatures: new arrays, the full H and R.
def _predict_covariance(P, A, W, Q) -> np.ndarray:
    """``P`` after :func:`slamlib.ekf.predict` with the Jacobians ``A``, ``W`` (a copy)."""
    P = np.array(P, dtype=float)
    if not ekf.predict(np.zeros(P.shape[0]), P, np.zeros(2), 0.0, 1.0, Q, A, W):
        raise ValueError("the expected prediction is not finite: check A, W and Q")
    return P


def _stacked_jacobian(n, slots, Hp, Hl) -> np.ndarray:
    """The full H (2m x n) from :func:`slamlib.ekf.stacked_jacobian`'s columns ``idx``."""
    slots, Hl = np.asarray(slots), np.asarray(Hl, dtype=float)
    known = slots >= 0                             # a known map's reading: no landmark columns
    idx, Hc = ekf.stacked_jacobian(np.where(known, slots, 0), np.asarray(Hp, dtype=float),
                                   np.where(known[:, None, None], Hl, 0.0))
    H = np.zeros((2 * slots.size, n))
    np.add.at(H.T, idx, Hc.T)
    return H


def _joint_update(x, P, z, h, H, R) -> tuple[np.ndarray, np.ndarray]:
    """``(x, P)`` after :func:`slamlib.ekf.joint_update` with the full H and R (copies)."""
    x, P = np.array(x, dtype=float), np.array(P, dtype=float)
    PHt, S = ekf.innovation_covariance(P, np.arange(x.size), H, R)
    ekf.joint_update(x, P, PHt, S, ekf.innovation(z, h).reshape(-1))
    return x, P


def _augment(x, P, z, R) -> tuple[np.ndarray, np.ndarray]:
    """``(x, P)`` with the landmark read as ``z`` appended by :func:`slamlib.ekf.augment`."""
    n = x.size
    xa, Pa = np.zeros(n + 2), np.zeros((n + 2, n + 2))
    xa[:n], Pa[:n, :n] = x, P
    ekf.augment(xa, Pa, n, inverse_observe(x[:3], z), *inverse_observation_jacobians(x[:3], z),
                R)
    return xa, Pa


# --------------------------------------------------------------------------- the shared parts
def _random_state(rng, n_landmarks: int, heading: float | None = None):
    """A mean and a fully correlated covariance (every block non-zero)."""
    n = 3 + 2 * n_landmarks
    th = rng.uniform(-np.pi, np.pi) if heading is None else heading
    x = np.concatenate([[rng.uniform(-2, 2), rng.uniform(-2, 2), th],
                        rng.uniform(-4, 4, 2 * n_landmarks)])
    M = rng.normal(0.0, 0.15, (n, n))
    return x, M @ M.T + 0.01 * np.eye(n)


def _as_array(out, shape) -> tuple[np.ndarray | None, str | None]:
    try:
        a = np.asarray(out, dtype=float)
    except (TypeError, ValueError):
        return None, f"expected a numpy array of shape {shape}, got {type(out).__name__}"
    if a.shape != shape:
        return None, f"expected shape {shape}, got {a.shape}"
    return a, None


def _as_pair(out, shapes) -> tuple[tuple | None, str | None]:
    if not isinstance(out, (tuple, list)) or len(out) != 2:
        return None, f"expected a pair (x, P) of shapes {shapes[0]} and {shapes[1]}"
    a, p1 = _as_array(out[0], shapes[0])
    b, p2 = _as_array(out[1], shapes[1])
    if p1 or p2:
        return None, f"x: {p1}" if p1 else f"P: {p2}"
    return (a, b), None


def _close(a, b, tol: float = 1e-9) -> bool:
    a, b = (np.asarray(v, dtype=float) for v in (a, b))
    return a.shape == b.shape and bool(np.allclose(a, b, rtol=tol, atol=tol))


def _student_globals(fn, names=("Q", "R")) -> dict[str, np.ndarray]:
    """The 2x2 arrays the student's function can see under these names (notebook variables)."""
    g = getattr(fn, "__globals__", {})
    out = {}
    for k in names:
        v = g.get(k)
        if isinstance(v, np.ndarray) and v.shape == (2, 2):
            out[k] = v
    return out


def _first_fit(got, mistakes: dict[str, Callable[[], object]], same) -> str | None:
    """The first mistake whose answer equals the student's (``same(got, wrong)``)."""
    for why, wrong in mistakes.items():
        try:
            if same(got, wrong()):
                return why
        except Exception:  # noqa: BLE001 - a mistake that cannot be formed here does not fit
            continue
    return None


def _block_report(got: np.ndarray, want: np.ndarray, n_old: int | None = None) -> str:
    """Which blocks of a SLAM covariance are wrong: robot, robot-map strip, map."""
    n = want.shape[0] if n_old is None else n_old
    parts = []
    for label, rows, cols in (("the robot block P_rr", slice(0, 3), slice(0, 3)),
                              ("the robot-map strip P_rm", slice(0, 3), slice(3, n)),
                              ("its mirror P_mr", slice(3, n), slice(0, 3)),
                              ("the map block P_mm", slice(3, n), slice(3, n)),
                              ("P_Lx[:, :3] (the new landmark with the robot)",
                               slice(n, None), slice(0, 3)),
                              ("P_Lx[:, 3:] (with the old landmarks)", slice(n, None),
                               slice(3, n)),
                              ("P_LL (the new landmark's own block)", slice(n, None),
                               slice(n, None)),
                              ):
        g, w = got[rows, cols], want[rows, cols]
        if g.size and not np.allclose(g, w, rtol=1e-9, atol=1e-9):
            parts.append(label)
    return ", ".join(parts) if parts else "no block"


def _shape_hint(problem: str) -> str | None:
    if "matmul" in problem or "shapes" in problem or "broadcast" in problem:
        return ("a shape mismatch: H is 2m x n (one row per reading component, one column per "
                "state entry), so S = H P H^T is 2m x 2m and K = P H^T S^-1 is n x 2m")
    return None


# --------------------------------------------------------------------------- prediction
def _prediction_mistakes(fn, P, A, W, Q, want):
    """The known mistakes of this exercise: hint -> a function giving the wrong answer."""
    def with_blocks(rr=None, rm=None, mr=None, mm=None):
        out = want.copy()
        if rr is not None:
            out[:3, :3] = rr
        if rm is not None:
            out[:3, 3:] = rm
        if mr is not None:
            out[3:, :3] = mr
        if mm is not None:
            out[3:, 3:] = mm
        return out

    mistakes = {
        "the robot-map strip P_rm is still the old one: you forgot to propagate the "
        "cross-covariance, P_rm <- A P_rm (and P_mr = P_rm^T): the landmarks' correlation "
        "with the robot moves with the robot":
            lambda: with_blocks(rm=P[:3, 3:], mr=P[3:, :3]),
        "the robot-map strip is zero: the prediction does not forget the correlations, "
        "it turns them, P_rm <- A P_rm":
            lambda: with_blocks(rm=0.0, mr=0.0),
        "P_rm is updated but its mirror P_mr still has the old value: P must stay "
        "symmetric, P_mr = P_rm^T":
            lambda: with_blocks(mr=P[3:, :3]),
        "the mirror P_mr is updated but P_rm still has the old value: P must stay "
        "symmetric, P_rm = A P_rm and P_mr = P_rm^T":
            lambda: with_blocks(rm=P[:3, 3:]),
        "W Q W^T is missing in the robot block: the wheel noise is what makes the "
        "uncertainty grow":
            lambda: with_blocks(rr=A @ P[:3, :3] @ A.T),
        "A is transposed: P_rr <- A P_rr A^T (A on the left) and P_rm <- A P_rm":
            lambda: _predict_covariance(P, A.T, W, Q),
        "only the robot block is predicted: the strip must also become A P_rm":
            lambda: with_blocks(rm=P[:3, 3:], mr=P[3:, :3]),
    }
    for k, v in _student_globals(fn, ("R",)).items():
        mistakes[f"that is the notebook's {k} in place of the argument Q: the prediction "
                 "adds the wheel-speed noise W Q W^T; use the function's argument"] = (
            lambda v=v: _predict_covariance(P, A, W, v))
    return mistakes


def check_predict_covariance(fn, n_cases: int = 6, seed: int = 11, verbose: bool = True) -> bool:
    """Check a student's ``fn(P, A, W, Q) -> P_new``, the prediction on the blocks (chapter 04).

    Expected (:func:`slamlib.ekf.predict`)::

        P_rr <- A P_rr A^T + W Q W^T,   P_rm <- A P_rm,   P_mr <- P_rm^T,   P_mm unchanged

    on SLAM states with 0 to 4 landmarks and every block correlated. Named
    mistakes: the robot-map strip left at its old value (forgot the
    cross-covariance), the strip zeroed, its mirror P_mr left at the old value,
    ``W Q W^T`` forgotten, ``A`` transposed, the map block changed, a notebook
    ``R`` where ``Q`` belongs.
    """
    say = printer(verbose)
    name = name_of(fn)
    rng = np.random.default_rng(seed)
    for i in range(n_cases):
        n_lm = (0, 2, 4, 1, 3, 4)[i % 6]
        _, P = _random_state(rng, n_lm)
        A = np.eye(3)
        A[0, 2], A[1, 2] = rng.normal(0, 0.1, 2)
        A[:2, :2] += rng.normal(0, 0.05, (2, 2))      # a general A: A^T differs from A
        W = rng.normal(0.0, 0.1, (3, 2))
        Q = np.diag(rng.uniform(1e-3, 5e-3, 2))
        out = attempt(fn, P.copy(), A.copy(), W.copy(), Q.copy(), say=say, what="the prediction")
        if out is None:
            return False
        got, problem = _as_array(out, P.shape)
        if problem:
            say(f"{name}: {problem} (the state has {n_lm} landmarks: P is {P.shape[0]} x "
                f"{P.shape[0]}, and so is the predicted P).")
            return False
        want = _predict_covariance(P, A, W, Q)
        if _close(got, want):
            continue
        say(f"{name}: not right yet (test case {i + 1} of {n_cases}, {n_lm} landmarks): wrong in "
            f"{_block_report(got, want)}.")
        n = P.shape[0]

        mistakes = _prediction_mistakes(fn, P, A, W, Q, want)
        fit = _first_fit(got, mistakes, _close)
        if fit:
            say(f"  Hint: {fit}.")
        elif n > 3 and not _close(got[3:, 3:], P[3:, 3:]):
            say("  Hint: the map block P_mm must not change in a prediction: the landmarks do "
                "not move.")
        else:
            say("  Hint: P_rr <- A P_rr A^T + W Q W^T, P_rm <- A P_rm, P_mr <- P_rm^T, "
                "P_mm unchanged.")
        return False
    say(f"{name}: correct. The predicted covariance matches at {n_cases} states "
        "(0 to 4 landmarks, every block correlated).")
    return True


# --------------------------------------------------------------------------- the stacked H
def _stacked_mistakes(n, slots, Hp, Hl, m):
    """The known mistakes of this exercise: hint -> a function giving the wrong answer."""
    mistakes = {
        "the landmark block is transposed: its columns are d/dx_F and d/dy_F, as they come "
        "from the Jacobian":
            lambda: _stacked_jacobian(n, slots, Hp, Hl.transpose(0, 2, 1)),
        "the landmark columns are one landmark off: the slot is already the index of x_F "
        "in the state (3 + 2j for the j-th landmark), use columns slot and slot + 1":
            lambda: _stacked_jacobian(n, [s + 2 if s >= 0 else s for s in slots], Hp, Hl),
        "the landmark columns are missing: a reading also depends on its landmark's "
        "position (H_landmark in columns slot, slot + 1)":
            lambda: _stacked_jacobian(n, [-1] * m, Hp, Hl),
        "the pose block is missing: every reading depends on the robot's pose "
        "(H_pose in columns 0-2)":
            lambda: _stacked_jacobian(n, slots, 0 * Hp, Hl),
    }
    return mistakes


def check_stacked_jacobian(fn, n_cases: int = 6, seed: int = 12, verbose: bool = True) -> bool:
    """Check a student's ``fn(n, slots, H_pose, H_landmark) -> H`` (chapters 03, 05).

    ``H`` is 2m x n: reading j's rows ``2j, 2j+1`` hold ``H_pose[j]`` in columns
    0-2 and ``H_landmark[j]`` in columns ``slots[j], slots[j]+1``, zeros
    elsewhere (:func:`slamlib.ekf.stacked_jacobian`; a slot of -1, a
    known map's landmark, has no landmark columns). Named mistakes: H
    transposed (n x 2m), the landmark block transposed, the landmark block one
    landmark off (``3 + 2 slot``), the landmark columns left out.
    """
    say = printer(verbose)
    name = name_of(fn)
    rng = np.random.default_rng(seed)
    for i in range(n_cases):
        n_lm = int(rng.integers(2, 6))
        n = 3 + 2 * n_lm
        m = int(rng.integers(1, 4))
        js = rng.choice(n_lm - 1, min(m, n_lm - 1), replace=False)   # never the last landmark
        m = len(js)
        slots = [int(3 + 2 * j) for j in js]
        if i == n_cases - 1:
            slots[0] = -1                                 # a known map's landmark (chapter 03)
        Hp = rng.normal(0.0, 1.0, (m, 2, 3))
        Hl = rng.normal(0.0, 1.0, (m, 2, 2))
        out = attempt(fn, n, list(slots), Hp.copy(), Hl.copy(), say=say, what="H")
        if out is None:
            return False
        want = _stacked_jacobian(n, slots, Hp, Hl)
        a = np.asarray(out, dtype=float) if isinstance(out, np.ndarray) else None
        if a is not None and a.shape == (n, 2 * m) and _close(a.T, want):
            say(f"{name}: your H is transposed: it is {n} x {2 * m}, but H has one ROW per "
                f"reading component (2m = {2 * m}) and one COLUMN per state entry (n = {n}), so "
                "that S = H P H^T is 2m x 2m.")
            return False
        got, problem = _as_array(out, want.shape)
        if problem:
            say(f"{name}: {problem} (m = {m} readings, n = {n}: H is 2m x n).")
            return False
        if _close(got, want):
            continue
        say(f"{name}: not right yet (test case {i + 1} of {n_cases}: n = {n}, slots = {slots}).")
        mistakes = _stacked_mistakes(n, slots, Hp, Hl, m)
        fit = _first_fit(got, mistakes, _close)
        say("  Hint: " + (fit or "rows 2j, 2j+1: H_pose[j] in columns 0-2 and H_landmark[j] in "
                             "columns slots[j], slots[j]+1 (none for slot -1)") + ".")
        return False
    say(f"{name}: correct. H is right for {n_cases} sets of readings (one of a known map).")
    return True


# --------------------------------------------------------------------------- the joint update
def _update_cases(rng, n_cases: int):
    """SLAM priors with 3 landmarks. Odd cases: m = 2 readings, one of them (landmark 5) with
    a predicted bearing near +pi and a reading across the seam, near -pi: the first reading in
    cases 2 and 6, the second in case 4 (so that wrapping only the first bearing fails);
    even cases: m = 1 reading. Cases 3 and 6 have a heading within 1e-6 of +-pi."""
    for i in range(n_cases):
        heading = {2: np.pi - 1e-6, 5: -np.pi + 1e-6}.get(i % 6)   # the update may cross +-pi
        x, P = _random_state(rng, 3, heading=heading)
        P *= 0.3
        slots = ([3, 5] if i % 4 == 3 else [5, 3]) if i % 2 else [7]
        if i % 2:                                    # landmark 5 straight behind the robot
            back = x[2] + np.pi - 0.01
            x[5:7] = x[:2] + rng.uniform(1.0, 3.0) * np.array([np.cos(back), np.sin(back)])
        h = np.array([observe(x[:3], x[s:s + 2]) for s in slots])
        Hs = [observation_jacobians(x[:3], x[s:s + 2]) for s in slots]
        H = _stacked_jacobian(x.size, slots, [a for a, _ in Hs], [b for _, b in Hs])
        noise = rng.normal(0.0, [0.05, 0.03], (len(slots), 2))
        if i % 2:
            noise[slots.index(5), 1] = 0.03               # pushes the bearing across +pi
        z = h + noise
        z[:, 1] = wrap_angle(z[:, 1])
        Rb = ekf.block_diagonal(np.array([np.diag([0.05 ** 2, 0.03 ** 2]) * (1 + j)
                                          for j in range(len(slots))]))
        yield x, P, z, h, H, Rb


_OPTIMAL_ONLY = ("; with this gain {form} is not the Joseph form either: (I - K H) P, "
                 "P - K S K^T and (I - K H) P (I - K H)^T + K R K^T agree only at the optimal "
                 "gain K = P H^T S^-1, "
                 "and for any other K only the Joseph form is the covariance of the estimate")

#: The gain mistakes of the joint update: hint -> how K is formed from P H^T, S, R and H P H^T.
_GAIN_MISTAKES = {
    "K = P H^T S^-1 with S = H P H^T + R: your gain uses R^-1 where S^-1 belongs (R is the "
    "readings' noise alone; S adds the prediction's uncertainty H P H^T)":
        lambda PHt, S, R, HPHt: PHt @ np.linalg.inv(R),
    "K = P H^T S^-1: the inverse of S is missing":
        lambda PHt, S, R, HPHt: PHt @ S,
    "S = H P H^T + R: R is missing":
        lambda PHt, S, R, HPHt: PHt @ np.linalg.inv(HPHt),
}


def _update_mistakes(fn, x, P, z, h, H, Rb, wx, wP, n, m):
    """The known mistakes of this exercise: hint -> a function giving the wrong answer."""
    def variant(y_wrap=True, noise_term=True, R_use=Rb, gain=None, form="joseph"):
        y = (z - h).reshape(-1)
        if y_wrap == "first":
            y[1] = wrap_angle(y[1])
        elif y_wrap:
            y = ekf.innovation(z, h).reshape(-1)
        HPHt = H @ P @ H.T
        S = HPHt + R_use
        K = (P @ H.T @ np.linalg.inv(S) if gain is None
             else gain(P @ H.T, S, R_use, HPHt))
        xn = x + K @ y
        xn[2] = wrap_angle(xn[2])
        I_KH = np.eye(n) - K @ H
        if form == "short":
            Pn = I_KH @ P
        elif form == "KSK":
            Pn = P - K @ S @ K.T
        else:
            Pn = I_KH @ P @ I_KH.T + (K @ R_use @ K.T if noise_term else 0.0)
        return xn, Pn

    def map_old():
        xn, Pn = wx.copy(), wP.copy()
        Pn[3:, 3:] = P[3:, 3:]
        return xn, Pn

    def map_old_x():
        xn = wx.copy()
        xn[3:] = x[3:]
        return xn, wP

    mistakes = {
        "only the first bearing is wrapped (y[1], as in my_gate's single reading): with m "
        "readings the flattened y holds a bearing at every odd index, y[1], y[3], ...; wrap "
        "each of them (here the second reading crosses the +-pi seam)":
            lambda: variant(y_wrap="first"),
        "the bearing of the innovation is not wrapped: z - h of two angles must be wrapped "
        "to [-pi, pi) (here one bearing is just below +pi, its reading just above -pi)":
            lambda: variant(y_wrap=False),
        "the map block of P is the prior's: an update changes the whole P, the landmarks' "
        "block too (they are correlated with the robot and with each other)":
            map_old,
        "the landmarks' means are the prior's: x <- x + K y changes every entry of x, "
        "not only the pose":
            map_old_x,
        "the Joseph form is missing K R K^T: P <- (I - K H) P (I - K H)^T + K R K^T":
            lambda: variant(noise_term=False),
    }
    forms = (("joseph", None), ("short", "(I - K H) P"), ("KSK", "P - K S K^T"))
    for why, gain in _GAIN_MISTAKES.items():
        for form, label in forms:
            hint = why + ("" if label is None else _OPTIMAL_ONLY.format(form=label))
            mistakes[hint] = lambda gain=gain, form=form: variant(gain=gain, form=form)
    for k, v in _student_globals(fn, ("Q",)).items():
        Rq = ekf.block_diagonal(np.array([v] * m))
        mistakes[f"that is the notebook's {k} (the wheel-speed noise) in place of the "
                 "argument R (the readings' noise): use the function's R"] = (
            lambda Rq=Rq: variant(R_use=Rq))
        mistakes[f"that is the notebook's {k} (the wheel-speed noise) in place of the "
                 "argument R (the readings' noise), in the short form: use the "
                 "function's R"] = (lambda Rq=Rq: variant(R_use=Rq, form="short"))
    return mistakes


def check_joint_update(fn, n_cases: int = 6, seed: int = 13, verbose: bool = True) -> bool:
    """Check a student's ``fn(x, P, z, z_pred, H, R) -> (x_new, P_new)`` (chapters 03, 05).

    ``z, z_pred`` (m, 2) readings and predictions, ``H`` (2m x n) stacked, ``R``
    (2m x 2m) block-diagonal. Expected (:func:`slamlib.ekf.joint_update`):
    ``y`` with wrapped bearings, ``S = H P H^T + R``, ``K = P H^T S^-1``,
    ``x + K y`` with the heading wrapped, and ``P`` by the Joseph form (or the
    short form, or ``P - K S K^T``: the three agree at this gain), returned
    exactly symmetric. Named mistakes: an unwrapped bearing, ``(I - K H) P`` (or
    Joseph) without symmetrising, a notebook ``Q`` where ``R`` belongs, the map
    block of P (or of x) left at its old value, the Joseph form without
    ``K R K^T``, a gain with ``R^-1`` where ``S^-1`` belongs, ``S`` without
    ``R``, ``K`` without the inverse (each of the three with the Joseph form,
    the short form or ``P - K S K^T``: with a wrong gain the last two are not
    the Joseph form, and the hint says so), only the first bearing wrapped, the heading
    not wrapped; a shape
    error gets a hint on H's layout.
    """
    say = printer(verbose)
    name = name_of(fn)
    rng = np.random.default_rng(seed)
    for i, (x, P, z, h, H, Rb) in enumerate(_update_cases(rng, n_cases)):
        n = x.size
        out, problem = call(fn, x.copy(), P.copy(), z.copy(), h.copy(), H.copy(), Rb.copy())
        if problem:
            say(not_ready(name, problem, "the update"))
            hint = _shape_hint(problem)
            if hint:
                say(f"  Hint: {hint}.")
            return False
        pair, problem = _as_pair(out, ((n,), (n, n)))
        if problem:
            say(f"{name}: {problem} (the state has {n} entries).")
            return False
        gx, gP = pair
        wx, wP = _joint_update(x, P, z, h, H, Rb)
        m = z.shape[0]
        where = (f"test case {i + 1} of {n_cases}: n = {n}, {m} reading(s)"
                 + (", one bearing across the +-pi seam" if i % 2 else ""))
        x_ok = _close(np.r_[gx[:2], wrap_angle(gx[2] - wx[2]), gx[3:]],
                      np.r_[wx[:2], 0.0, wx[3:]])
        if x_ok and _close(gP, wP):
            if not -np.pi <= gx[2] < np.pi:
                say(f"{name}: right, but the heading {gx[2]:.4f} is not wrapped to [-pi, pi) "
                    f"({where}). Wrap x[2] after x + K y.")
                return False
            if not np.array_equal(gP, gP.T):
                say(f"{name}: the numbers are right, but P is not exactly symmetric "
                    f"(max |P - P^T| = {np.abs(gP - gP.T).max():.1e}; {where}).")
                say("  Hint: (I - K H) P is symmetric only in exact arithmetic (and so is the "
                    "Joseph form, computed in floating point): the round-off asymmetry grows "
                    "over a long run. Return 0.5 * (P + P.T).")
                return False
            continue
        say(f"{name}: not right yet ({where}).")
        if not x_ok:
            say(f"  x: got {np.round(gx, 4)}, expected {np.round(wx, 4)}")
        if not _close(gP, wP):
            say(f"  P: wrong in {_block_report(gP, wP)}.")

        mistakes = _update_mistakes(fn, x, P, z, h, H, Rb, wx, wP, n, m)

        def same(got, wrong):
            return _close(got[0], wrong[0], 1e-7) and _close(got[1], wrong[1], 1e-7)

        fit = _first_fit((gx, gP), mistakes, same)
        if fit:
            say(f"  Hint: {fit}.")
        else:
            say("  Hint: y = z - z_pred (bearings wrapped, flattened to 2m), S = H P H^T + R, "
                "K = P H^T S^-1, x + K y (heading wrapped), "
                "P <- (I - K H) P (I - K H)^T + K R K^T.")
        return False
    say(f"{name}: correct. The update matches at {n_cases} priors (bearings across the +-pi "
        "seam included) and P is exactly symmetric.")
    return True


# --------------------------------------------------------------------------- augmentation
def _augment_mistakes(fn, x, P, z, R, wx, wP, n):
    """The known mistakes of this exercise: hint -> a function giving the wrong answer."""
    J1, J2 = inverse_observation_jacobians(x[:3], z)

    def with_new(PLx=None, PLL=None, m=None):
        Pn = wP.copy()
        if PLx is not None:
            Pn[n:, :n] = PLx
            Pn[:n, n:] = np.asarray(PLx).T if np.ndim(PLx) else PLx
        if PLL is not None:
            Pn[n:, n:] = PLL
        xn = wx.copy()
        if m is not None:
            xn[n:] = m
        return xn, Pn

    robot_only = np.zeros((2, n))
    robot_only[:, :3] = J1 @ P[:3, :3]
    mistakes = {
        "the cross-covariances are missing (zero): the new landmark is computed from the "
        "robot's pose, so it inherits its error, P_Lx = J1 P_r,: (the robot's rows of P)":
            lambda: with_new(PLx=np.zeros((2, n))),
        "the cross-covariance with the old landmarks is missing: P_Lx = J1 P_r,: over ALL "
        "columns, J1 P_rr for the robot and J1 P_rm for the landmarks already mapped (they "
        "are correlated with the new one through the robot)":
            lambda: with_new(PLx=robot_only),
        "the new landmark's own block lacks J1 P_rr J1^T: the robot's uncertainty moves "
        "the landmark too":
            lambda: with_new(PLL=J2 @ R @ J2.T),
        "the new landmark's own block lacks J2 R J2^T: the reading's noise":
            lambda: with_new(PLL=J1 @ P[:3, :3] @ J1.T),
        "R is added as if it were the covariance of a point in N (J1 P_rr J1^T + R): R is "
        "the noise of [range, bearing], and J2 carries it to x_F, y_F: + J2 R J2^T":
            lambda: with_new(PLL=J1 @ P[:3, :3] @ J1.T + R),
        "J2 is transposed (the report's layout): its columns are d/d rho and d/d beta":
            lambda: with_new(PLL=J1 @ P[:3, :3] @ J1.T + J2.T @ R @ J2),
        "the new landmark's position ignores the heading: m = [x + rho cos(theta + beta), "
        "y + rho sin(theta + beta)]":
            lambda: with_new(m=x[:2] + z[0] * np.array([np.cos(z[1]), np.sin(z[1])])),
    }
    for k, v in _student_globals(fn, ("Q",)).items():
        mistakes[f"that is the notebook's {k} (the wheel-speed noise) in place of the "
                 "argument R (the reading's noise): use the function's R"] = (
            lambda v=v: _augment(x, P, z, v))

    def with_jacobians(J1_, J2_):
        PLx = J1_ @ P[:3, :]
        return with_new(PLx=PLx, PLL=J1_ @ P[:3, :3] @ J1_.T + J2_ @ R @ J2_.T)

    for (r, c), (what, formula) in J1_ENTRIES.items():
        if J1[r, c] == 0.0:
            continue
        slip = J1.copy()
        slip[r, c] = -slip[r, c]
        mistakes[f"J1[{r},{c}] has the wrong sign: J1[{r},{c}] = {what} = {formula} "
                 "(chapter 04, section 3)"] = lambda slip=slip: with_jacobians(slip, J2)
    for c in (0, 1):
        # with a diagonal R, J2 R J2^T cannot tell which entry of a column has its sign
        # flipped: the hint names both
        slip = J2.copy()
        slip[0, c] = -slip[0, c]
        both = "; ".join(f"J2[{r},{c}] = {J2_ENTRIES[r, c][0]} = {J2_ENTRIES[r, c][1]}"
                         for r in (0, 1))
        mistakes[f"one sign in J2's column {c} is wrong ({both}; chapter 04, section 3)"] = (
            lambda slip=slip: with_jacobians(J1, slip))
    return mistakes



def check_augment(fn, n_cases: int = 6, seed: int = 14, verbose: bool = True) -> bool:
    """Check a student's ``fn(x, P, z, R) -> (x_new, P_new)``: a new landmark (chapter 04).

    Expected (:func:`slamlib.ekf.augment`): ``m = g(x_B, z)`` appended,
    the old ``P`` untouched, ``P_Lx = J1 P_r,:`` (with the robot AND every old
    landmark) and ``P_LL = J1 P_rr J1^T + J2 R J2^T``. Named mistakes: the
    cross-covariances forgotten, kept with the robot only, ``J1 P_rr J1^T``
    or ``J2 R J2^T`` missing, ``R`` added as a cartesian covariance (the
    report's slip), ``J2`` transposed, a notebook ``Q`` where ``R`` belongs,
    the bearing not turned by the heading.
    """
    say = printer(verbose)
    name = name_of(fn)
    rng = np.random.default_rng(seed)
    R = np.diag([0.05 ** 2, np.radians(2.0) ** 2])
    for i in range(n_cases):
        n_lm = (2, 0, 3, 1, 4, 2)[i % 6]
        x, P = _random_state(rng, n_lm)
        P *= 0.2
        z = np.array([rng.uniform(0.5, 4.0), rng.uniform(-1.2, 1.2)])
        n = x.size
        out = attempt(fn, x.copy(), P.copy(), z.copy(), R.copy(), say=say, what="the augmentation")
        if out is None:
            return False
        pair, problem = _as_pair(out, ((n + 2,), (n + 2, n + 2)))
        if problem:
            say(f"{name}: {problem} (the state has {n} entries and gets 2 more).")
            return False
        gx, gP = pair
        wx, wP = _augment(x, P, z, R)
        if _close(gx, wx) and _close(gP, wP):
            continue
        say(f"{name}: not right yet (test case {i + 1} of {n_cases}: {n_lm} landmarks, "
            f"pose [{x[0]:.3f}, {x[1]:.3f}, {x[2]:.3f}], z = [{z[0]:.3f}, {z[1]:.3f}]).")
        if not _close(gx, wx):
            say(f"  the new landmark: got {np.round(gx[n:], 4)}, expected {np.round(wx[n:], 4)}")
        if not _close(gP, wP):
            say(f"  P: wrong in {_block_report(gP, wP, n_old=n)}.")
        mistakes = _augment_mistakes(fn, x, P, z, R, wx, wP, n)
        def same(got, wrong):
            return _close(got[0], wrong[0]) and _close(got[1], wrong[1])

        fit = _first_fit((gx, gP), mistakes, same)
        if fit:
            say(f"  Hint: {fit}.")
        elif not _close(gP[:n, :n], P):
            say("  Hint: the old covariance P must stay as it is: adding a landmark tells "
                "nothing new about the old state.")
        else:
            say("  Hint: m = inverse_observe(pose, z); P_new = [[P, P_Lx^T], [P_Lx, P_LL]], "
                "P_Lx = J1 P[:3, :], P_LL = J1 P_rr J1^T + J2 R J2^T.")
        return False
    say(f"{name}: correct. The augmented state and covariance match at {n_cases} states "
        "(0 to 4 landmarks already mapped).")
    return True


# --------------------------------------------------------------------------- NEES of a trace
def check_trace_nees(fn, seed: int = 15, verbose: bool = True) -> bool:
    """Check a student's ``fn(x_est, x_true, P) -> nees`` for a trace of T poses (chapters 03, 06).

    ``x_est, x_true`` (T, 3), ``P`` (T, 3, 3); expected the (T,) values
    ``e^T P^-1 e`` with ``e = x_est - x_true``, its heading wrapped
    (:func:`slamlib.metrics.nees`). The test trace has headings on both
    sides of the +-pi seam. Named mistakes: heading not wrapped, ``e^T P e``,
    the square root (a Mahalanobis distance), divided by the 3 degrees of
    freedom, the position only, the mean over the trace instead of one value
    per step.
    """
    say = printer(verbose)
    name = name_of(fn)
    rng = np.random.default_rng(seed)
    T = 40
    M = rng.normal(0.0, 0.1, (T, 3, 3))
    P = M @ M.transpose(0, 2, 1) + np.diag([0.01, 0.01, 0.002])
    truth = np.column_stack([rng.uniform(-3, 3, T), rng.uniform(-3, 3, T),
                             np.where(np.arange(T) % 2, np.pi - 0.02, rng.uniform(-3, 3, T))])
    e = np.einsum("tij,tj->ti", np.linalg.cholesky(P), rng.standard_normal((T, 3)))
    e[1::2, 2] = np.abs(e[1::2, 2]) + 0.03                 # these estimates cross the seam
    est = truth + e
    est[:, 2] = wrap_angle(est[:, 2])
    out = attempt(fn, est.copy(), truth.copy(), P.copy(), say=say, what="the NEES")
    if out is None:
        return False
    want = nees(pose_error(est, truth), P)
    a = np.asarray(out, dtype=float) if not isinstance(out, (tuple, list)) else None
    if a is not None and a.size == 1:
        say(f"{name}: expected one NEES per step, shape ({T},), got one number "
            f"{float(a.reshape(-1)[0]):.4f}.")
        if np.isclose(float(a.reshape(-1)[0]), want.mean()):
            say("  Hint: that is the mean over the trace; return the (T,) values (average "
                "them afterwards).")
        return False
    got, problem = _as_array(out, (T,))
    if problem:
        say(f"{name}: {problem} (one NEES per step of the {T}-step trace).")
        return False
    if _close(got, want):
        say(f"{name}: correct. The NEES matches at all {T} steps, half of them with the "
            "heading error across the +-pi seam.")
        return True
    bad = int(np.flatnonzero(~np.isclose(got, want, rtol=1e-9, atol=1e-9))[0])
    say(f"{name}: not right yet: step {bad} has NEES {got[bad]:.4f}, expected {want[bad]:.4f}.")
    raw = est - truth
    mistakes = {
        "the heading error is not wrapped: an estimate of -3.13 rad against a truth of "
        "+3.12 rad is 0.03 rad off, not 6.25":
            lambda: np.einsum("ti,ti->t", raw, np.linalg.solve(P, raw[:, :, None])[:, :, 0]),
        "that is e^T P e: the NEES uses the INVERSE of P, e^T P^-1 e":
            lambda: np.einsum("ti,tij,tj->t", raw_w(), P, raw_w()),
        "that is the square root (the Mahalanobis distance): the NEES is its square":
            lambda: np.sqrt(want),
        "that is divided by the 3 degrees of freedom: the NEES itself is e^T P^-1 e, its "
        "MEAN is 3 for a consistent filter":
            lambda: want / 3.0,
        "that uses the position only: the NEES of the pose has 3 components, x, y and theta":
            lambda: np.einsum("ti,ti->t", raw_w()[:, :2],
                              np.linalg.solve(P[:, :2, :2], raw_w()[:, :2, None])[:, :, 0]),
    }

    def raw_w():
        r = raw.copy()
        r[:, 2] = wrap_angle(r[:, 2])
        return r

    fit = _first_fit(got, mistakes, _close)
    say("  Hint: " + (fit or "e = x_est - x_true with e[2] wrapped; nees = e^T P^-1 e per step")
        + ".")
    return False


# --------------------------------------------------------------------------- N runs, one band
def _consistency_cases(seed: int):
    """NEES of N runs by T steps: chi-square(dof) draws, scaled up or down in some segments."""
    rng = np.random.default_rng(seed)
    for n_runs, dof, T, prob in ((25, 3, 120, 0.95), (10, 2, 80, 0.99), (50, 3, 100, 0.9)):
        scale = np.ones(T)
        scale[T // 4:T // 2] = 1.4                        # over-confident for a while
        scale[3 * T // 4:] = 0.75                         # under-confident at the end
        runs = np.where(np.arange(n_runs) % 5 == 0, 1.8, 1.0)   # and a few bad runs
        yield rng.chisquare(dof, (n_runs, T)) * scale * runs[:, None], dof, prob


def _verdict_mistakes(nees_runs, dof, prob, avg, lo, hi):
    """The known mistakes of this exercise: hint -> a function giving the wrong answer."""
    from scipy.stats import chi2

    N = nees_runs.shape[0]
    lo1, hi1 = chi2.ppf((1 - prob) / 2, dof), chi2.ppf((1 + prob) / 2, dof)
    per_time = nees_runs.mean(axis=1)
    mistakes = {
        "that is the band of ONE run used for the average of N: the average of N runs "
        "varies much less; its sum is chi-square with N*dof degrees of freedom, so the band "
        "is chi2.ppf(., N*dof) / N":
            lambda: np.mean((avg >= lo1) & (avg <= hi1)),
        "that tests every run's own NEES against the one-run band: the verdict is about "
        "the average over the N runs at each step":
            lambda: np.mean((nees_runs >= lo1) & (nees_runs <= hi1)),
        "that averages over time (axis 1), one value per run: average over the runs "
        "(axis 0), one value per step":
            lambda: np.mean((per_time >= lo) & (per_time <= hi)),
        "the band is one-sided (quantiles 1 - prob and prob): a two-sided band of "
        "probability prob leaves (1 - prob)/2 on each side":
            lambda: np.mean((avg >= chi2.ppf(1 - prob, N * dof) / N)
                            & (avg <= chi2.ppf(prob, N * dof) / N)),
        "that is the band of the SUM of the N values: divide the quantiles by N":
            lambda: np.mean((avg >= lo * N) & (avg <= hi * N)),
    }
    return mistakes


def check_consistency_verdict(fn, seed: int = 16, verbose: bool = True) -> bool:
    """Check a student's ``fn(nees_runs, dof, prob) -> fraction`` (chapter 06).

    ``nees_runs`` (N, T) are the NEES of N Monte-Carlo runs over T steps. The
    answer is the fraction of steps whose AVERAGE over the N runs lies inside
    the two-sided ``prob`` band of that average, ``chi2.ppf((1 -+ prob)/2, N dof) / N``
    (:func:`slamlib.metrics.chi2_band`). Named mistakes: the band of one run
    used for the average of N, every run's own NEES against the one-run band,
    the average over time instead of over runs, a one-sided band, the band of
    the sum.
    """
    say = printer(verbose)
    name = name_of(fn)
    for nees_runs, dof, prob in _consistency_cases(seed):
        N, T = nees_runs.shape
        out = attempt(fn, nees_runs.copy(), dof, prob, say=say)
        if out is None:
            return False
        a = np.asarray(out, dtype=float) if not isinstance(out, (tuple, list)) else None
        if a is None or a.size != 1:
            say(f"{name}: expected one number (a fraction of the {T} steps), got "
                f"{type(out).__name__} {np.shape(out)}.")
            return False
        got = float(a.reshape(-1)[0])
        avg = nees_runs.mean(axis=0)
        lo, hi = chi2_band(dof, N, prob)
        want = float(np.mean((avg >= lo) & (avg <= hi)))
        if abs(got - want) < 1e-9:
            continue
        say(f"{name}: not right for {N} runs of {T} steps, dof = {dof}, prob = {prob}: got "
            f"{got:.4f}, expected {want:.4f} (band of the average: [{lo:.3f}, {hi:.3f}]).")
        mistakes = _verdict_mistakes(nees_runs, dof, prob, avg, lo, hi)
        fit = _first_fit(got, mistakes, lambda g, w: abs(g - float(w)) < 1e-9)
        say("  Hint: " + (fit or "avg = nees_runs.mean(axis=0); lo, hi = chi2.ppf((1 -/+ prob)/2, "
                             "N*dof)/N; the fraction of steps with lo <= avg <= hi") + ".")
        return False
    say(f"{name}: correct. The verdict matches for 3 studies (10 to 50 runs, 2 and 3 degrees "
        "of freedom, probabilities 0.9 to 0.99).")
    return True
