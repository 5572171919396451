"""Data association for readings without ids: nearest neighbour and JCBB (chapter 09).

ArUco hands the filter an id with every reading, so association is a look-up
(chapter 05). Without ids, each reading ``z_i`` must be paired with a landmark
``j`` of the map, or with none (a new landmark, or clutter). This module holds
the association itself as pure functions on the quantities the filter already
computes at the prior: the innovations ``y_ij = z_i - h_j(x)`` (bearing
wrapped), the predicted readings' covariance ``H P H^T`` and the readings'
noise ``R_i``. :meth:`slamlib.ekf.EKFSLAM.update` (``association="nn"`` or
``"jcbb"``) calls them; the chapter derives and checks them.

Individual compatibility (the chi-square gate of chapter 05 for every pair)::

    S_ij  = H_j P H_j^T + R_i
    d2_ij = y_ij^T S_ij^-1 y_ij            compatible when d2_ij < chi2.ppf(gate, 2)

Nearest neighbour (:func:`nearest_neighbour`): each reading goes to the
compatible landmark of smallest ``d2_ij``; a landmark takes at most one reading
per frame. Conflicts are settled in increasing order of ``d2`` (the globally
closest pair first), so the result does not depend on the readings' order.

Joint compatibility (:func:`joint_distance`): a hypothesis ``H = {(i, j_i)}``
of m pairs is one stacked innovation ``y_H`` (2m) whose covariance is NOT
block-diagonal: every predicted reading depends on the same robot pose, so::

    S_H  = H_H P H_H^T + blockdiag(R_i)      (2m x 2m, cross terms H_j P H_j'^T)
    D2_H = y_H^T S_H^-1 y_H                  jointly compatible when D2_H < chi2.ppf(gate, 2m)

A robot error shifts all readings together; two readings that are each inside
their landmarks' gates but shifted in opposite directions are jointly
incompatible. That is what NN cannot see and what JCBB (Neira and Tardos 2001)
uses.

JCBB (:func:`jcbb`): depth-first over the readings in order; reading i is
paired with each individually compatible, not yet used landmark (in increasing
``d2_ij``) whose addition keeps the hypothesis jointly compatible, or left
unpaired. The answer is the hypothesis with the MOST pairs and, among those,
the smallest ``D2``. Branches are cut when they cannot beat the best so far
(pairs already made + readings left that have a candidate < best pairs, or
equal pairs and a ``D2`` already not smaller: ``D2`` never decreases as pairs
are added). As in the paper, joint compatibility is tested at every
extension, i.e. every prefix of the answer (in reading order) is jointly
compatible. ``D2`` is updated incrementally with a Cholesky factor ``L`` of
``S_H``: each node solves ``L B^T = C_q`` by forward substitution
(:func:`solve_lower`, O(m^2)) and copies ``L`` into the
enlarged factor (O(m^2)); for the few pairs of one frame the node's cost is
numpy's call overhead.

The bound on the search: ``max_nodes`` nodes (default 10 000). The first leaf
of the depth-first search is the sequential nearest neighbour (each reading,
in order, to its closest landmark that keeps the set jointly compatible); the
search never stops before it. When the budget runs out, the best hypothesis
found so far is returned, flagged ``complete=False``: never worse than the
sequential nearest neighbour.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .compiled import compiled
from .metrics import chi2_quantile

__all__ = ["individual_d2", "nearest_neighbour", "joint_distance", "solve_lower", "JCBBResult",
           "jcbb", "DEFAULT_MAX_NODES"]

#: Default bound on the number of nodes JCBB visits in one frame.
DEFAULT_MAX_NODES = 10_000


def solve_lower(L: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``L^-1 B`` for a lower-triangular ``L`` (m x m) and ``B`` (m x k), by forward
    substitution, O(m^2 k): row r is ``(B_r - sum_{j<r} L_rj X_j) / L_rr``."""
    X = np.array(B, dtype=float)
    for r in range(L.shape[0]):
        X[r] = (X[r] - L[r, :r] @ X[:r]) / L[r, r]
    return X


@compiled
def individual_d2(y: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Squared Mahalanobis distance ``d2 = y' S^-1 y`` of 2-vectors (chapters 03, 05, 09).

    The one formula of the chi-square gate, for each reading against its own
    landmark (:func:`slamlib.ekf.gate`: shapes (m, 2) and (m, 2, 2)) and, without
    ids, for every pair of a reading and a landmark (shapes (k, N, 2) and
    (k, N, 2, 2)). ``S`` is symmetric, so its inverse is
    ``[[s22, -s12], [-s12, s11]] / det`` (only ``s12`` is read). Compiled by numba;
    it takes arrays of floats.

    Parameters
    ----------
    y : numpy.ndarray, shape (..., 2)
        Innovations ``y = z - h``, bearing wrapped to [-pi, pi).
    S : numpy.ndarray, shape (..., 2, 2)
        Their covariances ``S = H P H' + R``, positive definite.

    Returns
    -------
    numpy.ndarray, shape (...)
        ``d2`` of each vector: inf or NaN where ``S`` is singular (outside any gate); for one
        vector, shapes (2,) and (2, 2), a float, and a singular ``S`` raises ZeroDivisionError.
    """
    if y.shape[-1] != 2 or S.shape[-1] != 2 or S.shape[-2] != 2:
        raise ValueError("individual_d2: expected y (..., 2) and S (..., 2, 2)")
    s11, s12, s22 = S[..., 0, 0], S[..., 0, 1], S[..., 1, 1]     # S = [[s11, s12], [s12, s22]]
    det = s11 * s22 - s12 * s12                 # S^-1 = [[s22, -s12], [-s12, s11]] / det
    y0, y1 = y[..., 0], y[..., 1]
    return (s22 * y0 * y0 - 2.0 * s12 * y0 * y1 + s11 * y1 * y1) / det   # d2 = y' S^-1 y


def nearest_neighbour(d2: np.ndarray, threshold: float) -> np.ndarray:
    """Individual-compatibility nearest neighbour with one reading per landmark.

    Parameters
    ----------
    d2 : numpy.ndarray, shape (k, N)
        Squared Mahalanobis distances of reading i to landmark j (NaN: not a candidate).
    threshold : float
        The gate on ``d2`` (``chi2.ppf(gate, 2)``).

    Returns
    -------
    numpy.ndarray of int, shape (k,)
        The landmark (column) each reading is paired with, -1 for none. Pairs
        inside the gate are taken in increasing ``d2``; a reading or landmark
        already taken is skipped (ties: lower reading, then lower landmark first).
    """
    d2 = np.asarray(d2, dtype=float)
    k = d2.shape[0]
    out = np.full(k, -1, dtype=np.int64)
    if d2.size == 0:
        return out
    ii, jj = np.nonzero(d2 < threshold)            # NaN compares False: never a candidate
    order = np.lexsort((jj, ii, d2[ii, jj]))
    used = np.zeros(d2.shape[1], dtype=bool)
    for q in order:
        i, j = ii[q], jj[q]
        if out[i] < 0 and not used[j]:
            out[i] = j
            used[j] = True
    return out


def joint_distance(y: np.ndarray, C: np.ndarray) -> float:
    """Joint squared Mahalanobis distance ``y^T C^-1 y`` of one hypothesis.

    Parameters
    ----------
    y : numpy.ndarray, shape (m, 2)
        The paired innovations, stacked.
    C : numpy.ndarray, shape (2m, 2m)
        Their joint covariance ``H_H P H_H^T + blockdiag(R_i)`` (the cross terms included).
    """
    yv = np.asarray(y, dtype=float).reshape(-1)
    if yv.size == 0:
        return 0.0
    return float(yv @ np.linalg.solve(C, yv))


@dataclass(frozen=True)
class JCBBResult:
    """The answer of :func:`jcbb`.

    Attributes
    ----------
    assignment : numpy.ndarray of int (k,)
        Landmark paired with each reading, -1 for none.
    pairs : int
        Number of pairs.
    d2 : float
        Joint ``D2`` of the hypothesis (0 with no pair).
    nodes : int
        Nodes the search visited.
    complete : bool
        False when ``max_nodes`` stopped the search (the answer is then the best found).
    """

    assignment: np.ndarray
    pairs: int
    d2: float
    nodes: int
    complete: bool


def jcbb(y: np.ndarray, d2: np.ndarray, C: np.ndarray, R: np.ndarray, gate: float, *,
         max_nodes: int = DEFAULT_MAX_NODES) -> JCBBResult:
    """Joint Compatibility Branch and Bound (Neira and Tardos 2001).

    Parameters
    ----------
    y : numpy.ndarray, shape (k, N, 2)
        Innovations of every (reading, landmark) pair, bearing wrapped.
    d2 : numpy.ndarray, shape (k, N)
        Their individual distances (:func:`individual_d2`); a pair is a
        candidate when ``d2 < chi2.ppf(gate, 2)``.
    C : numpy.ndarray, shape (2N, 2N)
        Covariance of the N predicted readings ``H P H^T`` (the filter builds it with
        :func:`slamlib.ekf.innovation_covariance`, R = 0).
    R : numpy.ndarray, shape (k, 2, 2)
        The readings' noise.
    gate : float
        The probability of the individual and joint chi-square tests.
    max_nodes : int
        Bound on the nodes visited (see the module docstring for the fallback).

    Returns
    -------
    JCBBResult
    """
    y = np.asarray(y, dtype=float)
    d2 = np.asarray(d2, dtype=float)
    k = d2.shape[0]
    thr1 = chi2_quantile(gate, 2)
    cands = []
    for i in range(k):
        js = np.flatnonzero(d2[i] < thr1) if d2.size else np.zeros(0, np.int64)
        cands.append([int(j) for j in js[np.argsort(d2[i, js], kind="stable")]])
    # readings after i that have at least one candidate
    left = np.zeros(k + 1, dtype=int)
    for i in range(k - 1, -1, -1):
        left[i] = left[i + 1] + (1 if cands[i] else 0)
    thresholds = [0.0] + [chi2_quantile(gate, 2 * m) for m in range(1, k + 1)]

    best = {"assign": np.full(k, -1, dtype=np.int64), "pairs": 0, "d2": 0.0, "leaf": False}
    nodes = 0
    stopped = False
    assign = np.full(k, -1, dtype=np.int64)
    used = set()

    def worse(pairs_possible: int, d2_now: float) -> bool:
        """True if no completion of this node can beat the best hypothesis so far."""
        if not best["leaf"]:
            return False
        if pairs_possible != best["pairs"]:
            return pairs_possible < best["pairs"]
        return d2_now >= best["d2"]

    def search(i: int, pairs: int, L: np.ndarray, w: np.ndarray, idx: list, dist: float):
        nonlocal nodes, stopped
        nodes += 1
        if best["leaf"] and nodes > max_nodes:
            stopped = True
            return
        if i == k:
            if not worse(pairs, dist) or not best["leaf"]:
                best.update(assign=assign.copy(), pairs=pairs, d2=dist, leaf=True)
            return
        for j in cands[i]:
            if stopped:
                return
            if j in used or worse(pairs + 1 + left[i + 1], dist):
                continue
            # incremental Cholesky of the joint covariance with pair (i, j) appended
            cq = C[np.ix_(idx, [2 * j, 2 * j + 1])] if idx else np.zeros((0, 2))
            Cqq = C[2 * j:2 * j + 2, 2 * j:2 * j + 2] + R[i]
            B = solve_lower(L, cq).T if idx else np.zeros((2, 0))    # B' = L^-1 C_q, 2m x 2
            M = Cqq - B @ B.T
            try:
                Lc = np.linalg.cholesky(0.5 * (M + M.T))
            except np.linalg.LinAlgError:
                continue
            v = solve_lower(Lc, (y[i, j] - B @ w)[:, None])[:, 0]     # L_c^-1 (y - B w)
            dnew = dist + float(v @ v)
            if dnew >= thresholds[pairs + 1]:
                continue                                   # not jointly compatible
            m2 = L.shape[0]
            Ln = np.zeros((m2 + 2, m2 + 2))
            Ln[:m2, :m2] = L
            Ln[m2:, :m2] = B
            Ln[m2:, m2:] = Lc
            assign[i] = j
            used.add(j)
            search(i + 1, pairs + 1, Ln, np.concatenate([w, v]), idx + [2 * j, 2 * j + 1], dnew)
            used.discard(j)
            assign[i] = -1
        if stopped:
            return
        if not worse(pairs + left[i + 1], dist):
            search(i + 1, pairs, L, w, idx, dist)              # reading i unpaired

    search(0, 0, np.zeros((0, 0)), np.zeros(0), [], 0.0)
    return JCBBResult(assignment=best["assign"], pairs=int(best["pairs"]), d2=float(best["d2"]),
                      nodes=nodes, complete=not stopped)
