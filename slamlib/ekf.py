"""The course's EKF: one implementation, in the chapters' order and names (chapters 03-06, 09).

The state ``x = [x, y, theta, x_F1, y_F1, ...]`` (n = 3 + 2N) and its covariance
``P`` are read through index sets, as in Sola's EKF-SLAM toolbox: ``r`` the robot's
entries 0-2, ``m`` the map's, ``l`` one landmark's two. Each step is one small
function on these blocks, the code the chapters print and the filters run:

- :func:`predict`: ``x_r = f(x_r, u)``, ``P_rm = A P_rm``, ``P_rr = A P_rr A' + W Q W'``, O(n);
- :func:`innovation`, :func:`stacked_jacobian` and :func:`innovation_covariance`:
  ``y = z - h(x)``, H over the columns it touches, ``S = H P H' + R``;
- :func:`gate`: each reading on its own, ``d2_i = y_i' S_i^-1 y_i`` against chi-square;
- :func:`joint_update`: ``K = P H' S^-1``, ``x = x + K y``, ``P = P - K S K'``, O(n^2 m);
- :func:`augment`: ``x_l = g(x_r, z)``, ``P_lx = J1 P_rx``, ``P_ll = J1 P_rr J1' + J2 R J2'``.

The filters are thin classes over them: :class:`EKFLocalization`, :class:`EKFSLAM`,
:class:`LinearisedEKFSLAM` and its presets :class:`FEJEKFSLAM` and :class:`IdealEKFSLAM`
(``ConfirmedSLAM``, in its own module, too; ``DelayedEKF`` wraps any of them). ``update(ids, z, R)``
follows the report (V.C, corrected): association by id (chapter 09: nearest
neighbour or JCBB), each reading gated against the prior, the accepted ones
fused jointly, then the ids never seen before added from the updated pose in the
order given (an id read twice in a call once, from its first reading). Where each
link is linearised is one hook, :meth:`EKFLocalization.jacobians`. Inputs are
checked once, in ``predict`` and ``update``; a step whose result is not finite
changes nothing, and the filter raises a ValueError (:func:`predict` returns False:
compiled code cannot format the message). The models live in :mod:`slamlib.models`.
The steps marked ``@compiled`` are these same functions compiled by numba
(:mod:`slamlib.compiled`; they take float arrays; how and why: ``bench/README.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .association import DEFAULT_MAX_NODES, individual_d2, jcbb, nearest_neighbour
from .compiled import compiled
from .metrics import chi2_quantile
from .models import (
    KOBUKI_WHEEL_BASE,
    _check_control,
    _motion_jacobians,
    _motion_model,
    _wrap,
    inverse_observation_jacobians,
    inverse_observe,
    observe_landmarks,
    wrap,
)
from .validate import (
    Checked,
    as_covariance,
    as_finite_scalar,
    as_landmark_map,
    as_marker_ids,
    as_positive,
    as_reading_covariances,
    as_readings,
    as_vector,
    count_readings,
    integer_at_least,
)

__all__ = ["EKFLocalization", "EKFSLAM", "LinearisedEKFSLAM", "FEJEKFSLAM", "IdealEKFSLAM",
           "UpdateReport", "gate_threshold", "predict", "innovation", "stacked_jacobian",
           "block_diagonal", "innovation_covariance", "gate", "joint_update", "augment",
           "landmark_covariance"]

#: What :meth:`EKFSLAM.update` can do with a reading (ConfirmedSLAM adds "candidate").
STATUSES = ("accepted", "rejected", "new", "duplicate", "unknown", "degenerate")
#: The association methods (chapter 09; ``"ids"`` is chapters 03-05's look-up).
ASSOCIATIONS = ("ids", "nn", "jcbb")
#: r: the robot's entries of the state.
ROBOT = slice(0, 3)


# --------------------------------------------------------------------------- the steps
@compiled
def predict(x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, b: float, Q: np.ndarray,
            A: np.ndarray, W: np.ndarray) -> bool:
    """One EKF prediction of the state ``x`` (n,) and ``P`` (n, n), in place (chapters 01, 05).

    The dense ``P = F P F' + F_w Q F_w'`` with ``F = blkdiag(A, I)``, ``F_w = [W; 0]``
    touches only the robot's rows and columns: the landmarks do not move. ``u``,
    ``dt``, ``b``: the wheel speeds ``[V_R, V_L]``, the step (s), the wheel base; ``Q``
    the covariance of u; ``A``, ``W`` the motion Jacobians where the filter
    linearises (:meth:`EKFLocalization.jacobians`). Returns False, having changed
    nothing, if the result would not be finite (an overflow). Compiled by numba.
    """
    r, m = slice(0, 3), slice(3, x.shape[0])              # r: ROBOT (numba: no global slice)
    x_r = _motion_model(x[r], u, dt, b)                   # x_r = f(x_r, u)
    P_rr = A @ P[r, r] @ A.T + W @ Q @ W.T                # [P1] P_rr = A P_rr A' + W Q W'
    if not math.isfinite(x_r.sum() + np.trace(P_rr)):     # (P_rm overflows only if P_rr does)
        return False
    x[r] = x_r
    P[r, m] = A @ P[r, m]                                 # [P2] P_rm = A P_rm
    P[m, r] = P[r, m].T                                   # [P3] P_mr = P_rm'
    P[r, r] = (P_rr + P_rr.T) / 2                         # (symmetric to the last bit)
    #                                                       [P4] P_mm = P_mm: the map stays
    return True


@compiled
def innovation(z: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``y = z - h(x)`` of readings ``[range, bearing]`` (..., 2), the bearing wrapped to
    [-pi, pi) (report eq. (1), which forgets the wrap; chapters 03, 05)."""
    y = z - h                                               # y = z - h(x)
    y[..., 1] = _wrap(y[..., 1])                            # (_wrap: models.wrap, compiled)
    return y


@compiled
def block_diagonal(blocks: np.ndarray) -> np.ndarray:
    """The (2m, 2m) block-diagonal matrix of m 2x2 blocks (m, 2, 2) (:func:`diagonal_blocks`)."""
    m = blocks.shape[0]
    out = np.zeros((2 * m, 2 * m))
    for j in range(m):
        out[2 * j:2 * j + 2, 2 * j:2 * j + 2] = blocks[j]
    return out


@compiled
def stacked_jacobian(slots: np.ndarray, H_pose: np.ndarray, H_landmark: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The Jacobian of m readings stacked, over the columns it touches (chapters 03, 05).

    Reading j's two rows hold ``H_pose[j]`` in the robot's columns ``r`` and
    ``H_landmark[j]`` in its landmark's ``l_j = (slots[j], slots[j] + 1)``; every
    other column of the full H (2m x n) is zero, so only the index set
    ``idx = [r, l_1, ..., l_m]`` is kept (a landmark read twice appears twice: the
    products below add its two parts). A known map (chapter 03: every slot -1) has
    no landmark columns; slots are either all -1 or all landmarks of the state.

    Returns
    -------
    (idx, H) : numpy.ndarray (c,) of int and (2m, c)
    """
    m = slots.shape[0]
    known_map = m == 0 or slots[0] < 0                      # chapter 03: the pose only
    idx = np.arange(3 if known_map else 3 + 2 * m)          # idx = [r, l_1, ..., l_m]
    H = np.zeros((2 * m, idx.size))
    for j in range(m):
        H[2 * j:2 * j + 2, :3] = H_pose[j]                  # d h_j / d x_r
        if not known_map:
            c = 3 + 2 * j                                   # l_j's columns in idx
            idx[c], idx[c + 1] = slots[j], slots[j] + 1
            H[2 * j:2 * j + 2, c:c + 2] = H_landmark[j]     # d h_j / d x_lj
    return idx, H


@compiled
def innovation_covariance(P: np.ndarray, idx: np.ndarray, H: np.ndarray, R: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
    """``P H'`` (n x 2m) and ``S = H P H' + R`` (2m x 2m) of stacked readings (chapters 03, 05).

    ``H`` is given over the columns ``idx`` of the state (:func:`stacked_jacobian`),
    so ``P H' = P[:, idx] H'`` and ``H P H' = H (P H')[idx]``: O(n m), no n x n product.
    ``R`` is the readings' noise, block-diagonal (2m x 2m).
    """
    PHt = P[:, idx] @ H.T                                   # P H'
    S = H @ PHt[idx] + R                                    # S = H P H' + R
    return PHt, (S + S.T) / 2


@compiled
def gate(y: np.ndarray, S: np.ndarray, threshold: float) -> tuple:
    """Each of m readings gated on its own against the prior (report eq. (6), chapter 05).

    ``S_i = H_i P H_i' + R_i`` is the i-th 2x2 block on the diagonal of the joint
    ``S``; ``d2_i = y_i' S_i^-1 y_i`` is chi-square with 2 degrees of freedom for a
    right reading, accepted when ``d2_i < threshold`` (:func:`gate_threshold`, inf
    without gating; the report writes ``y - h`` inside: ``y`` is meant). Returns
    ``d2`` (m,), ``S_i`` (m, 2, 2) and which readings are accepted (m,).
    """
    S_i = diagonal_blocks(S)                                # S_i = H_i P H_i' + R_i
    d2 = individual_d2(y, S_i)                              # d2 = y' S_i^-1 y
    if threshold == math.inf:                               # no gate: every reading
        return d2, S_i, np.ones(d2.shape, dtype=np.bool_)  # (numba's name of bool)
    return d2, S_i, d2 < threshold                          # d2 < chi2.ppf(gate, 2)


@compiled
def diagonal_blocks(S: np.ndarray) -> np.ndarray:
    """The m 2x2 blocks (m, 2, 2) on the diagonal of a (2m, 2m) matrix."""
    m = S.shape[0] // 2
    out = np.empty((m, 2, 2))
    for j in range(m):
        out[j] = S[2 * j:2 * j + 2, 2 * j:2 * j + 2]
    return out


#: Up to this n, :func:`joint_update` changes P with one product, symmetrised; above, a few
#: rows per product, rows x n x 2m below 2^18, which OpenBLAS computes in one thread, at
#: memory speed (bench/README.md).
_ONE_BLOCK, _PRODUCT = 512, 1 << 18


@compiled
def joint_update(x: np.ndarray, P: np.ndarray, PHt: np.ndarray, S: np.ndarray,
                 y: np.ndarray) -> float:
    """One joint EKF update with m readings stacked, in place (report V.C, chapters 03, 05).

    ``x``, ``P`` the prior (n,), (n, n), ``x[2]`` the heading; ``PHt``, ``S`` from
    :func:`innovation_covariance`; ``y`` (2m,) the innovations, stacked. With
    ``S = L L'`` (Cholesky) and ``W = L^-1 H P`` the gain is ``K = W' L^-1``, so
    ``K y = W' L^-1 y`` and ``K S K' = W' W``: P loses a rank-2m term, O(n^2 m) (in exact
    arithmetic the Joseph form ``(I - K H) P (I - K H)' + K R K'`` at the optimal gain).
    Returns the joint NIS ``y' S^-1 y`` (2m degrees of freedom). An S that is not positive
    definite (LinAlgError) or a result that is not finite (ValueError) changes nothing.
    """
    n, m2 = P.shape[0], y.shape[0]
    L = np.linalg.cholesky(S)                               # S = L L'
    HP_y = np.empty((m2, n + 1))                            # [H P, y]
    HP_y[:, :n], HP_y[:, n] = PHt.T, y
    Wv = np.linalg.solve(L, HP_y)                           # L^-1 [H P, y] (a general solver)
    W, v = Wv[:, :n], Wv[:, n]                              # W = L^-1 H P, v = L^-1 y
    if not math.isfinite(np.sum(Wv * Wv)):                  # (overflow: stop before x, P change)
        raise ValueError("z: these readings give a non-finite update (L^-1 [H P, y] "
                         "overflows); nothing was changed")
    x += W.T @ v                                            # x = x + K y = x + W' v
    x[2] = _wrap(x[2])                                      # (the heading back to [-pi, pi))
    if n <= _ONE_BLOCK:                                     # P = P - K S K' = P - W' W
        WtW = W.T @ W                                       # (numba's product rounds its two
        P -= (WtW + WtW.T) / 2                              #  triangles apart: symmetrised)
    else:                                                   # (a few rows per product; P is
        rows = max(1, _PRODUCT // (n * m2))                 #  symmetric to rounding only)
        Wc = np.ascontiguousarray(W)                        # (copied once, not per product)
        for i in range(0, n, rows):
            P_i = P[i:i + rows]                             # (numba subtracts fastest with
            np.subtract(P_i, Wc[:, i:i + rows].T @ Wc, P_i)  # out=: P_i = P_i - W_i' W)
    return v @ v                                            # NIS = y' S^-1 y


def landmark_covariance(J1: np.ndarray, P_rr: np.ndarray, J2: np.ndarray, R: np.ndarray
                        ) -> np.ndarray:
    """A new landmark's covariance ``J1 P_rr J1' + J2 R J2'`` (chapter 04), symmetric."""
    P_ll = J1 @ P_rr @ J1.T + J2 @ R @ J2.T                 # P_ll = J1 P_rr J1' + J2 R J2'
    return (P_ll + P_ll.T) / 2


def augment(x: np.ndarray, P: np.ndarray, n: int, x_l: np.ndarray, J1: np.ndarray,
            J2: np.ndarray, R: np.ndarray) -> None:
    """Append a landmark read as ``z`` to the state (chapter 04, section 5), in place.

    ``x`` and ``P`` are the filter's storage, larger than the state's n
    entries; the landmark goes to ``l = (n, n + 1)``. ``x_l = g(x_r, z)`` and
    ``J1 = dg/dx_r``, ``J2 = dg/dz`` where the filter linearises
    (:meth:`EKFLocalization.jacobians`). The new landmark is correlated with the robot and,
    through it, with every landmark already mapped; the old block of P is untouched.
    """
    r, l, old = ROBOT, slice(n, n + 2), slice(0, n)        # old: the n entries before
    x[l] = x_l                                              # [A1] x_l = g(x_r, z)
    P[l, old] = J1 @ P[r, old]                              # [A2] P_lx = J1 P_rx
    P[old, l] = P[l, old].T                                 #      P_xl = P_lx'
    P[l, l] = landmark_covariance(J1, P[r, r], J2, R)       # [A3] P_ll = J1 P_rr J1' + J2 R J2'
    #                                                         [A4] the old block of P untouched


def gate_threshold(gate: float | None, dof: int = 2) -> float:
    """The chi-square gate ``chi2.ppf(gate, dof)`` (chapter 05); ``inf`` for ``gate=None``.

    For ``dof = 2`` the chi-square CDF is ``1 - exp(-d2/2)``, so the threshold
    has the closed form ``-2 ln(1 - gate)``: 5.991 for ``gate = 0.95``.
    """
    return float("inf") if gate is None else chi2_quantile(_check_gate(gate), dof)


def _check_gate(gate, name: str = "gate", none: bool = True):
    """A probability in (0, 1), or None (no gating) when ``none``."""
    if gate is None and none:
        return None
    g = as_finite_scalar(name, gate)
    if not 0.0 < g < 1.0:
        raise ValueError(f"{name}: expected a probability in (0, 1){' or None' * none}, got {g}")
    return g


def _not_finite(name: str, what: str) -> ValueError:
    return ValueError(f"{name}: the step's result is not finite ({what}); nothing was changed")


# --------------------------------------------------------------------------- the report
@dataclass(frozen=True)
class UpdateReport:
    """What :meth:`EKFSLAM.update` did with each of the k readings of one call.

    ``ids`` (-1 without ids) and ``z`` as given; per reading its ``status`` (one of
    :data:`STATUSES`: ``"duplicate"`` is a second reading of an id new in this call,
    not used; ``"unknown"`` an id not in a known map; ``"degenerate"`` a landmark on
    the robot), ``accepted`` and ``new`` (bool), and at the prior, for the gated
    readings (NaN otherwise), ``d2 = y' S^-1 y``, ``innovation`` y, ``predicted`` h(x)
    and ``S`` (k, 2, 2); the gate's ``threshold`` and probability ``gate``; the joint
    update's ``joint_nis`` (NaN if nothing fused); without ids the association's
    answer ``matched_ids`` (read :attr:`matched`).
    """

    ids: np.ndarray
    z: np.ndarray
    status: tuple
    accepted: np.ndarray
    new: np.ndarray
    d2: np.ndarray
    innovation: np.ndarray
    predicted: np.ndarray
    S: np.ndarray
    threshold: float
    gate: float | None
    joint_nis: float
    matched_ids: np.ndarray | None = None

    @property
    def matched(self) -> np.ndarray:
        """int (k,): the map id each reading was fused into or added as; -1 when not used."""
        if self.matched_ids is not None:
            return self.matched_ids
        return np.where(self.accepted | self.new, np.asarray(self.ids, dtype=np.int64), -1)

    def __len__(self) -> int:
        return len(self.ids)

    n_accepted = property(lambda self: int(np.count_nonzero(self.accepted)),
                          doc="Number of readings fused.")
    rejected = property(lambda self: np.array([s == "rejected" for s in self.status], bool),
                        doc="True for the readings that failed the gate.")

    def table(self) -> str:
        """A plain-text table of the readings, one line each (for notebooks)."""
        lines = [f"gate {self.gate}  threshold {self.threshold:.3f}",
                 f"{'id':>6} {'range':>8} {'bearing':>8} {'d2':>9}  status"]
        for i in range(len(self)):
            d2 = "" if np.isnan(self.d2[i]) else f"{self.d2[i]:.3f}"
            lines.append(f"{self.ids[i]:>6d} {self.z[i, 0]:>8.3f} {self.z[i, 1]:>8.3f} "
                         f"{d2:>9}  {self.status[i]}")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.table()


def _report(fields: dict, joint_nis: float) -> UpdateReport:
    return UpdateReport(**{**fields, "status": tuple(fields["status"])}, joint_nis=joint_nis)


def _fields(ids, z, status, gate, threshold, g=None, d2=None, y=None, h=None, S=None,
            accepted=None, matched=None) -> dict:
    """The report's fields of k readings, the gated ones ``g`` filled in (NaN elsewhere)."""
    k = len(status)
    if g is not None and g.size == k:                        # the usual frame: all gated
        fields = dict(d2=d2, innovation=y, predicted=h, S=S, accepted=accepted)
    else:
        fields = dict(d2=np.full(k, np.nan), innovation=np.full((k, 2), np.nan),
                      predicted=np.full((k, 2), np.nan), S=np.full((k, 2, 2), np.nan),
                      accepted=np.zeros(k, dtype=bool))
        if g is not None:
            for name, v in zip(("d2", "innovation", "predicted", "S", "accepted"),
                               (d2, y, h, S, accepted)):
                fields[name][g] = v
    return dict(ids=ids, z=z, status=status, new=np.array([s == "new" for s in status], bool),
                threshold=threshold, gate=gate, matched_ids=matched, **fields)


# --------------------------------------------------------------------------- the filters
class EKFLocalization:
    """Map-based EKF localisation with a known map of landmarks (chapter 03).

    The state is the robot's pose only (``x`` (3,), ``P`` 3x3). An id that is not
    in the map is rejected (``status == "unknown"``), never an exception.

    Parameters
    ----------
    x0, P0 : array_like (3,), (3, 3)
        Initial pose ``[x, y, theta]`` and its covariance (positive definite).
    Q, R : array_like (2, 2)
        Covariances of the wheel speeds ``[V_R, V_L]`` and (default) of a reading.
    landmarks : dict {int: (2,)}
        The known map: marker id -> ``[x, y]`` in N.
    wheel_base : float
        b (m).
    gate : float or None
        Probability of the chi-square gate (0.95); None accepts every reading.
    association : {"ids", "nn", "jcbb"}
        By marker id (default), or without ids, ``update(None, z)``, by nearest
        neighbour or JCBB (chapter 09).

    ``Q``, ``R``, ``wheel_base``, ``gate``, ``max_nodes`` and ``new_gate`` may be
    set at any time (checked on set).
    """

    _can_add = False

    def __init__(self, x0, P0, Q, R, landmarks=None, wheel_base: float = KOBUKI_WHEEL_BASE,
                 gate: float | None = 0.95, association: str = "ids", *, _capacity: int = 0):
        if association not in ASSOCIATIONS:
            raise ValueError(f"association: expected one of {ASSOCIATIONS}, got {association!r}")
        self._association = association
        self._map = as_landmark_map({} if landmarks is None else landmarks)
        x0 = as_vector("x0", x0, 3)
        P0 = as_covariance("P0", P0, 3)
        self.Q, self.R, self.wheel_base, self.gate = Q, R, wheel_base, gate
        self.max_nodes = DEFAULT_MAX_NODES
        self.new_gate = 0.999
        #: Without ids, what the last update's association saw (chapter 09): ``"d2"`` (k, N)
        #: every reading's d2 to every landmark (NaN: degenerate), ``"in_gate"`` (k,) the
        #: landmarks inside each reading's gate, ``"jcbb"`` JCBB's JCBBResult (or None).
        self.last_association: dict = {}
        cap = 3 + 2 * _capacity
        self._x, self._P, self._n = np.zeros(cap), np.zeros((cap, cap)), 3
        self._x[:3] = [x0[0], x0[1], wrap(float(x0[2]))]
        self._P[:3, :3] = P0
        self._ids: list[int] = []
        self._slot: dict[int, int] = {}           # marker id -> index of its x_F in the state

    # ------------------------------------------------------------------ parameters
    Q = Checked(lambda v: as_covariance("Q", v, 2), "Covariance of the wheel speeds (2x2).")
    R = Checked(lambda v: as_covariance("R", v, 2), "Default covariance of a reading (2x2).")
    wheel_base = Checked(lambda v: as_positive("wheel_base", v), "b (m).")
    new_gate = Checked(lambda v: _check_gate(v, "new_gate", none=False), """Without ids: a
        reading is new only if its d2 to every landmark is at least chi2.ppf(new_gate, 2) (and
        at least the gate's threshold, if the gate is wider).""")
    max_nodes = Checked(lambda v: integer_at_least("max_nodes", v, 1),
                        "JCBB's bound on the nodes searched per frame.")

    @property
    def gate(self) -> float | None:
        """Probability of the chi-square gate, or None (no gating; only with ids)."""
        return self._gate

    @gate.setter
    def gate(self, value) -> None:
        if value is None and self._association != "ids":
            raise ValueError(f"gate: association={self._association!r} needs a gate probability "
                             f"(e.g. 0.95), not None: without it every reading would match")
        self._gate = _check_gate(value)
        self._threshold = gate_threshold(self._gate)

    @property
    def threshold(self) -> float:
        """The gate on d2: ``chi2.ppf(gate, 2)``, ``inf`` without gating."""
        return self._threshold

    @property
    def association(self) -> str:
        """How readings find their landmark: ``"ids"``, ``"nn"`` or ``"jcbb"`` (read-only)."""
        return self._association

    # ------------------------------------------------------------------ read-out (copies)
    x = property(lambda self: self._x[:self._n].copy(), doc="The mean, shape (n,).")
    P = property(lambda self: self._P[:self._n, :self._n].copy(), doc="The covariance (n, n).")
    pose = property(lambda self: self._x[:3].copy(), doc="The robot's pose [x, y, theta].")
    pose_cov = property(lambda self: self._P[:3, :3].copy(), doc="The robot's block P_rr.")
    state_size = property(lambda self: self._n, doc="n, the length of the state.")
    capacity = property(lambda self: self._x.shape[0], doc="State entries before reallocation.")
    landmarks = property(lambda self: {k: v.copy() for k, v in self._map.items()},
                         doc="The known map {id: [x, y]}.")
    landmark_ids = property(lambda self: list(self._map), doc="The known map's ids.")

    def _slots(self, ids: list) -> list:
        """Index of each id's ``x_F`` in the state, -1 for a landmark of the known map, or None."""
        return [-1 if i in self._map else None for i in ids]

    def _positions(self, ids) -> np.ndarray:
        """The landmarks' positions (k, 2): the known map's, or the state's."""
        if not self._can_add:
            return np.array([self._map[int(i)] for i in ids]).reshape(-1, 2)
        s = np.array([self._slot[int(i)] for i in ids], dtype=np.int64)
        return self._x[s[:, None] + (0, 1)]                 # rows x_F = x[(s, s + 1)]

    # ------------------------------------------------------------------ the hooks
    def reading_model(self, pose: np.ndarray, positions: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The observation model (chapter 03): ``(h, H_pose, H_landmark)`` of landmarks at
        ``positions`` (k, 2) from ``pose``, :func:`slamlib.models.observe_landmarks`.

        Override it to study another model without touching the algebra, e.g.
        the report's sign error (chapter 03)::

            class Broken(EKFLocalization):
                def reading_model(self, pose, positions):
                    h, Hp, Hl = super().reading_model(pose, positions)
                    Hp[:, 1, 1] *= -1
                    return h, Hp, Hl
        """
        return observe_landmarks(pose, positions)

    def jacobians(self, link: str, ids=None, z=None, u=None, dt=None) -> tuple:
        """Where the EKF linearises each link of its chain: the one hook of chapter 06.

        Here everything at the estimate (EKF SLAM):

        - ``"motion"`` (``u``, ``dt``): ``(A, W)`` at the pose before the step;
        - ``"observation"`` (``ids`` of mapped landmarks): ``(h, H_pose,
          H_landmark)``, the predicted readings (the innovation's ``h(x)``) and their
          Jacobians at the pose and the landmarks' estimates (:meth:`reading_model`);
        - ``"initialisation"`` (``ids`` of new landmarks, ``z`` (k, 2)): ``(m, J1,
          J2)``, the landmarks ``g(x_r, z)`` and the Jacobians at the pose and readings.

        :class:`LinearisedEKFSLAM` evaluates each link elsewhere by overriding this.
        """
        pose = self._x[:3]
        if link == "motion":
            return _motion_jacobians(pose, u, dt, self._wheel_base)
        if link == "observation":
            return self.reading_model(pose.copy(), self._positions(ids))
        if link == "initialisation":
            J = [inverse_observation_jacobians(pose, zi) for zi in z]
            return (np.array([inverse_observe(pose, zi) for zi in z]).reshape(-1, 2),
                    np.array([j[0] for j in J]).reshape(-1, 2, 3),
                    np.array([j[1] for j in J]).reshape(-1, 2, 2))
        raise ValueError(f"link: expected 'motion', 'observation' or 'initialisation', "
                         f"got {link!r}")

    # ------------------------------------------------------------------ predict
    def predict(self, u, dt: float, Q=None) -> None:
        """Prediction with the wheel speeds ``u = [V_R, V_L]`` over ``dt`` (chapter 01):
        :func:`predict` with the Jacobians of :meth:`jacobians`. ``Q``: this step's 2x2
        covariance of ``u``, default the filter's own (a real log's noise density gives
        each step its own, ``Q_c / dt``, chapter 10)."""
        u, dt = _check_control(u, dt)
        Q = self._Q if Q is None else as_covariance("Q", Q, 2)
        A, W = self.jacobians("motion", u=u, dt=dt)
        n = self._n
        if not predict(self._x[:n], self._P[:n, :n], u, dt, self._wheel_base, Q, A, W):
            raise _not_finite("u, dt", f"u = {u}, dt = {dt}")   # (an overflow: nothing changed)

    # ------------------------------------------------------------------ update
    def update(self, ids, z, R=None) -> UpdateReport:
        """Correct the state with the readings ``z`` of the markers ``ids`` (chapters 03-05).

        Parameters
        ----------
        ids : array_like of int (k,), or None
            Marker ids, one per reading (None: chapter 09's readings without ids).
        z : array_like (k, 2)
            Readings ``[range (m, >= 0), bearing (rad)]`` in the robot frame.
        R : array_like (2, 2) or (k, 2, 2), optional
            The readings' noise, one for all or one per reading; the filter's R if None.

        Returns
        -------
        UpdateReport

        Raises
        ------
        ValueError
            On bad input, or when the result would not be finite: nothing changes.
        """
        with np.errstate(all="ignore"):            # an overflow is refused, without a warning
            if self._association != "ids":
                return self._update_without_ids(ids, z, R)
            return self._update_ids(ids, z, R)

    def _update_ids(self, ids, z, R) -> UpdateReport:
        ids = as_marker_ids(ids)
        k = ids.shape[0]
        z = as_readings(z, k)
        R = as_reading_covariances(R, self._R, k)
        fields, fused = self._gate_ids(ids, z, R)
        new = [i for i, s in enumerate(fields["status"]) if s == "new"]
        undo = self._save(fused is not None and len(new) > 0)
        try:
            nis = float("nan") if fused is None else self._fuse(*fused)
            if new:                                         # ids never seen before
                for i, (status, _) in zip(new, self._admit(ids[new], z[new], R[new])):
                    fields["status"][i] = status
                fields["new"] = np.array([s == "new" for s in fields["status"]], dtype=bool)
        except ValueError:
            self._restore(undo)
            raise
        return _report(fields, nis)

    def preview(self, ids, z, R=None) -> UpdateReport:
        """What :meth:`update` would report (the same association and gate), changing nothing."""
        if self._association != "ids" or ids is None:
            raise ValueError(f"preview: needs readings with ids and association='ids' (this "
                             f"filter has association={self._association!r})")
        ids = as_marker_ids(ids)
        z = as_readings(z, ids.shape[0])
        fields, _ = self._gate_ids(ids, z, as_reading_covariances(R, self._R, ids.shape[0]))
        return _report(fields, float("nan"))

    def _gate_ids(self, ids: np.ndarray, z: np.ndarray, R: np.ndarray):
        """Association by id and each reading's gate at the prior; nothing changes.

        Returns the report's fields and what :meth:`_fuse` fuses (or None)."""
        k, id_list = ids.shape[0], ids.tolist()
        status, seen, gated, slots = [""] * k, set(), [], []
        for i, (mid, s) in enumerate(zip(id_list, self._slots(id_list))):   # association by id
            if s is not None:                                   # a mapped landmark: gated
                gated.append(i)
                slots.append(s)
            elif not self._can_add:
                status[i] = "unknown"
            elif mid in seen:
                status[i] = "duplicate"
            else:
                status[i] = "new"
                seen.add(mid)
        if not gated:
            return _fields(ids, z, status, self._gate, self._threshold), None
        if len(gated) < k:                                      # some readings are not gated
            g = np.array(gated, dtype=np.int64)
            ids_g, z_g, R_g = ids[g], z[g], R[g]
        else:                                                   # (the usual frame: all are)
            g, ids_g, z_g, R_g = np.arange(k), ids, z, R
        h, Hp, Hl = self.jacobians("observation", ids=ids_g)    # h(x), H at the prior
        slots = np.array(slots, dtype=np.int64)
        if not math.isfinite(h[:, 1].sum()):                    # a landmark on the robot
            ok = np.isfinite(h[:, 1])
            for i in g[~ok]:
                status[i] = "degenerate"
            g, z_g, R_g, h, Hp, Hl, slots = (a[ok] for a in (g, z_g, R_g, h, Hp, Hl, slots))
            if g.size == 0:
                return _fields(ids, z, status, self._gate, self._threshold), None
        y = innovation(z_g, h)                                  # y = z - h(x)
        idx, H = stacked_jacobian(slots, Hp, Hl)
        PHt, S = innovation_covariance(self._P[:self._n, :self._n], idx, H, block_diagonal(R_g))
        d2, S_i, acc = gate(y, S, self._threshold)
        accepted = acc.tolist()
        for i, a in zip(g.tolist(), accepted):
            status[i] = "accepted" if a else "rejected"
        fields = _fields(ids, z, status, self._gate, self._threshold, g, d2, y, h, S_i, acc)
        return fields, ((PHt, S, y, acc) if any(accepted) else None)

    def _fuse(self, PHt: np.ndarray, S: np.ndarray, y: np.ndarray, acc: np.ndarray) -> float:
        """The accepted readings' rows and columns of ``P H'``, ``S`` and ``y``, jointly fused."""
        if not acc.all():
            rows = np.flatnonzero(np.repeat(acc, 2))
            PHt, S, y = PHt[:, rows], S[np.ix_(rows, rows)], y[acc]
        n = self._n
        return joint_update(self._x[:n], self._P[:n, :n], PHt, S, y.reshape(-1))

    def _admit(self, ids, z: np.ndarray, R: np.ndarray, g=None) -> list[tuple[str, int | None]]:
        """What becomes of readings of no mapped landmark (new ids, or chapter 09's readings far
        from every landmark, ``ids`` None): ``(status, map id)`` each. The known map rejects
        them; :class:`EKFSLAM` adds them; ``ConfirmedSLAM`` holds them as candidates. ``g``:
        their ``(m, J1, J2)`` at the current pose, when the caller has them already."""
        return [("unknown" if ids is not None else "rejected", None)] * z.shape[0]

    def _save(self, copy_state: bool) -> tuple:
        """What undoes an update: the state's size, and a copy of x and P when it both fuses
        and adds (a new landmark that fails comes after the joint update)."""
        n = self._n
        state = (self._x[:n].copy(), self._P[:n, :n].copy()) if copy_state else None
        return n, list(self._ids), state

    def _restore(self, saved: tuple) -> None:
        n, ids, state = saved
        if state is not None:
            self._x[:n], self._P[:n, :n] = state
        for mid in self._ids[len(ids):]:
            del self._slot[mid]
        self._n, self._ids = n, ids

    def _update_without_ids(self, ids, z, R) -> UpdateReport:
        """The association step without ids (chapter 09): pair, fuse jointly, then admit.

        1. Every reading against every mapped landmark at the prior: ``y_ij``,
           ``S_ij = H_j P H_j' + R_i`` (the diagonal blocks of ``C = H P H'`` of all
           predicted readings), ``d2_ij``.
        2. The pairs: :func:`~slamlib.association.nearest_neighbour` (``"nn"``) or
           :func:`~slamlib.association.jcbb` (``"jcbb"``, on the landmarks inside
           some reading's gate, with the cross terms of C).
        3. The paired readings in one joint update, as with ids.
        4. A reading far from every landmark (``d2 >= chi2.ppf(max(new_gate, gate), 2)``) goes
           to :meth:`_admit`; any other unpaired reading is ``"rejected"``.

        The report's ``ids`` are -1; ``matched`` is the answer; ``d2``, ``innovation``,
        ``predicted`` and ``S`` refer to the paired landmark, else the nearest.
        """
        if ids is not None:
            raise ValueError(f"ids: this filter (association={self._association!r}) pairs the "
                             f"readings itself: call update(None, z) without ids, or build "
                             f"it with association='ids' to use the ids")
        k = count_readings(z)
        z = as_readings(z, k)
        R = as_reading_covariances(R, self._R, k)
        keys = np.array(self.landmark_ids, dtype=np.int64)
        fields = _fields(np.full(k, -1, dtype=np.int64), z, ["rejected"] * k, self._gate,
                         self._threshold, matched=np.full(k, -1, dtype=np.int64))
        self.last_association = {"in_gate": np.zeros(k, dtype=np.int64), "jcbb": None,
                                 "d2": np.full((k, keys.size), np.nan)}
        outside, pairs = np.ones(k, dtype=bool), None
        if keys.size and k:
            h, Hp, Hl = self.jacobians("observation", ids=keys)
            cols = np.flatnonzero(np.isfinite(h[:, 1]))
            if cols.size:
                pairs = self._pair(z, R, keys, cols, h[cols], Hp[cols], Hl[cols], fields)
                outside = np.all(self.last_association["d2"][:, cols]
                                 >= gate_threshold(max(self._new_gate, self._gate)), axis=1)
        undo = self._save(pairs is not None and outside.any())
        try:
            nis = float("nan") if pairs is None else joint_update(
                self._x[:self._n], self._P[:self._n, :self._n], *pairs)
            out = np.flatnonzero(outside)
            for i, (st, mid) in zip(out, self._admit(None, z[out], R[out])):
                fields["status"][i] = st
                fields["matched_ids"][i] = -1 if mid is None else mid
                fields["new"][i] = st == "new"
        except ValueError:
            self._restore(undo)
            raise
        return _report(fields, nis)

    def _pair(self, z, R, keys, cols, h, Hp, Hl, fields):
        """Steps 1-2 of :meth:`_update_without_ids`; returns what the joint update fuses."""
        slots = np.array(self._slots(keys[cols].tolist()), dtype=np.int64)
        N, k, P = cols.size, z.shape[0], self._P[:self._n, :self._n]

        def C(js):                                          # H P H' of landmarks js' readings
            return innovation_covariance(P, *stacked_jacobian(slots[js], Hp[js], Hl[js]), 0.0)[1]

        C_j = np.concatenate([diagonal_blocks(C(np.arange(j, min(j + 32, N))))
                              for j in range(0, N, 32)])    # H_j P H_j', 32 landmarks at a time
        y = innovation(z[:, None, :], h[None, :, :])            # y_ij = z_i - h_j(x)
        S = C_j[None] + R[:, None]                              # S_ij = H_j P H_j' + R_i
        D2 = individual_d2(y, S)
        inside = D2 < self._threshold
        self.last_association["in_gate"] = np.count_nonzero(inside, axis=1)
        self.last_association["d2"][:, cols] = D2
        if self._association == "nn":
            a = nearest_neighbour(D2, self._threshold)
        else:
            cand = np.flatnonzero(np.any(inside, axis=0))
            a = np.full(k, -1, dtype=np.int64)
            if cand.size:
                res = jcbb(y[:, cand], D2[:, cand], C(cand), R, self._gate,
                           max_nodes=self._max_nodes)
                self.last_association["jcbb"] = res
                a[res.assignment >= 0] = cand[res.assignment[res.assignment >= 0]]
        near, r = np.where(a >= 0, a, np.argmin(D2, axis=1)), np.arange(k)
        fields["d2"][:], fields["innovation"][:] = D2[r, near], y[r, near]
        fields["predicted"][:], fields["S"][:] = h[near], S[r, near]
        fused = np.flatnonzero(a >= 0)
        if fused.size == 0:
            return None
        fields["accepted"][fused] = True
        fields["matched_ids"][fused] = keys[cols[a[fused]]]
        for i in fused:
            fields["status"][i] = "accepted"
        j = a[fused]
        idx, H = stacked_jacobian(slots[j], Hp[j], Hl[j])
        return (*innovation_covariance(P, idx, H, block_diagonal(R[fused])),
                y[fused, j].reshape(-1))


class EKFSLAM(EKFLocalization):
    """EKF SLAM with marker ids for association and a chi-square gate (chapters 04, 05).

    The state is ``[x, y, theta, x_F1, y_F1, ...]``; a marker id seen for the
    first time is appended with the inverse observation model.

    Parameters
    ----------
    x0, P0, Q, R, wheel_base, gate, association
        As for :class:`EKFLocalization` (no map: it starts empty). Without ids a
        reading outside every landmark's ``new_gate`` is added as a new landmark,
        named by the filter (0, 1, 2, ...).
    capacity : int
        Landmarks to make room for at the start (the storage doubles when needed).
    """

    _can_add = True

    def __init__(self, x0, P0, Q, R, wheel_base: float = KOBUKI_WHEEL_BASE,
                 gate: float | None = 0.95, capacity: int = 16, association: str = "ids"):
        super().__init__(x0, P0, Q, R, None, wheel_base, gate, association,
                         _capacity=integer_at_least("capacity", capacity, 0))

    landmark_ids = property(lambda self: list(self._ids), doc="Marker ids in state order.")
    n_landmarks = property(lambda self: len(self._ids), doc="Landmarks in the state.")
    landmarks = property(lambda self: {i: self._x[s:s + 2].copy() for i, s in self._slot.items()},
                         doc="The estimated map {id: [x_F, y_F]}.")

    def landmark_index(self, marker_id: int) -> int:
        """Index of ``x_F`` of that marker in the state (``y_F`` is the next one)."""
        try:
            return self._slot[int(marker_id)]
        except KeyError:
            raise ValueError(f"marker_id: {marker_id} is not in the map") from None

    def landmark(self, marker_id: int) -> np.ndarray:
        """Estimated position ``[x_F, y_F]`` of a marker (a copy)."""
        i = self.landmark_index(marker_id)
        return self._x[i:i + 2].copy()

    def landmark_cov(self, marker_id: int) -> np.ndarray:
        """The 2x2 covariance of a marker's position (a copy)."""
        i = self.landmark_index(marker_id)
        return self._P[i:i + 2, i:i + 2].copy()

    def _slots(self, ids: list) -> list:
        return [self._slot.get(i) for i in ids]

    def _admit(self, ids, z, R, g=None):
        """Add every reading as a new landmark, in order (without ids named ``max + 1``)."""
        if ids is None:
            start = max(self._ids) + 1 if self._ids else 0
            ids = np.arange(start, start + z.shape[0])
        self._add_landmarks(ids, z, R, g)
        return [("new", int(i)) for i in ids]

    def _add_landmarks(self, ids, z: np.ndarray, R: np.ndarray, g=None) -> None:
        """Append landmarks from the current pose (chapter 04): :func:`augment` each, in order;
        ``g = (m, J1, J2)`` of the readings if already computed at this pose."""
        if len(ids) == 0:
            return
        self._reserve(self._n + 2 * len(ids))
        m, J1, J2 = self.jacobians("initialisation", ids=ids, z=z) if g is None else g
        for j, mid in enumerate(np.asarray(ids).tolist()):
            n = self._n
            augment(self._x, self._P, n, m[j], J1[j], J2[j], R[j])
            if not math.isfinite(self._x[n:n + 2].sum() + self._P[n:n + 2, :n + 2].sum()):
                raise _not_finite("z", f"the new landmark {mid} from z = {z[j]}")
            self._n = n + 2
            self._slot[mid] = n
            self._ids.append(mid)

    def _reserve(self, size: int) -> None:
        """Room for ``size`` state entries, doubling the capacity when it runs out."""
        cap = self._x.shape[0]
        if size > cap:
            cap, n = max(size, 2 * cap), self._n
            x, P = np.zeros(cap), np.zeros((cap, cap))
            x[:n], P[:n, :n] = self._x[:n], self._P[:n, :n]
            self._x, self._P = x, P


# --------------------------------------------------------------------------- linearisation
class LinearisedEKFSLAM(EKFSLAM):
    """EKF SLAM with each link of its chain linearised where you choose (chapter 06).

    The means move with ``f``, ``h`` and ``g`` at the estimate, as in EKF SLAM; each
    link's Jacobians (and for ``"truth"`` its first-order expansion) are evaluated:

    - ``motion`` (A, W): ``"estimate"`` at ``x_k|k``; ``"first"``: A from ``x_k+1|k -
      x_k|k-1`` (the propagated poses), W at ``x_k|k``; ``"truth"``: A from the true
      ``p_k+1 - p_k``, W at the true heading;
    - ``observation`` (H of a mapped landmark): at the prior pose and the landmark's
      estimate; ``"first"``: at ``x_k|k-1`` and its first estimate (where it was put);
      ``"truth"``: at the true pose and landmark;
    - ``initialisation`` (J1, J2 of a new one): at the updated pose and the reading;
      ``"truth"``: at the true pose and reading ``z_t``, mean ``m_t + J1 dx + J2 dz``;
    - ``innovation`` (the predicted reading): ``h(x)``; ``"truth"``: ``h(p_t, m_t) + H_t
      (x - p_t) + H_t,m (m - m_t)``.

    ``truth`` (a callable ``t -> (3,)``) and ``landmarks`` (the true map; an id not in
    it is linearised at the estimate) are needed by any ``"truth"``; ``t0`` is the
    time of ``x0`` (each :meth:`predict` adds its ``dt``). The other arguments are
    :class:`EKFSLAM`'s; the choices are read-only attributes of the links' names.
    """

    CHOICES = {"motion": ("estimate", "first", "truth"),
               "observation": ("estimate", "first", "truth"),
               "initialisation": ("estimate", "truth"), "innovation": ("estimate", "truth")}

    def __init__(self, x0, P0, Q, R, *, motion: str = "estimate", observation: str = "estimate",
                 initialisation: str = "estimate", innovation: str = "estimate", truth=None,
                 landmarks=None, t0: float = 0.0, **kwargs):
        links = {"motion": motion, "observation": observation,
                 "initialisation": initialisation, "innovation": innovation}
        for link, choice in links.items():
            if not isinstance(choice, str) or choice not in self.CHOICES[link]:
                raise ValueError(f"{link}: expected one of {self.CHOICES[link]}, got {choice!r}")
        missing = [name for name, ok in (("truth", callable(truth)),
                                         ("landmarks", landmarks is not None)) if not ok]
        if "truth" in links.values() and missing:
            raise ValueError(f"{', '.join(missing)}: a 'truth' linearisation needs the true pose "
                             f"(truth, a callable t -> (3,)) and the true map (landmarks, "
                             f"{{id: (2,)}}), got truth={truth!r}")
        self.t = as_finite_scalar("t0", t0)
        super().__init__(x0, P0, Q, R, **kwargs)
        self._links = links
        self._truth = truth
        self._true_map = {} if landmarks is None else as_landmark_map(landmarks)
        self._propagated = self.pose                 # x_k|k-1, the pose the last predict made
        self._first: dict[int, np.ndarray] = {}      # id -> first estimate of the landmark

    motion = property(lambda self: self._links["motion"], doc="Where A, W are evaluated.")
    observation = property(lambda self: self._links["observation"], doc="Where H is evaluated.")
    initialisation = property(lambda self: self._links["initialisation"],
                              doc="Where a new landmark's J1, J2 are evaluated.")
    innovation = property(lambda self: self._links["innovation"],
                          doc="How the predicted reading h(x) is formed.")

    @property
    def propagated_pose(self) -> np.ndarray:
        """``x_k|k-1``: the pose the latest prediction produced, before any update (a copy)."""
        return self._propagated.copy()

    def first_estimate(self, marker_id: int) -> np.ndarray:
        """Where the landmark was put when it was mapped (a copy)."""
        self.landmark_index(marker_id)                       # ValueError if not mapped
        return self._first[int(marker_id)].copy()

    def predict(self, u, dt: float, Q=None) -> None:
        super().predict(u, dt, Q)
        self._propagated = self.pose
        self.t += float(dt)

    def _admit(self, ids, z, R, g=None):
        out = super()._admit(ids, z, R, g)
        for _, mid in out:
            self._first[mid] = self.landmark(mid)
        return out

    def _true_pose(self, t: float) -> np.ndarray:
        return as_vector("truth(t)", self._truth(t), 3)

    def jacobians(self, link: str, ids=None, z=None, u=None, dt=None) -> tuple:
        """:meth:`EKFSLAM.jacobians`, each link where the constructor says."""
        out = super().jacobians(link, ids=ids, z=z, u=u, dt=dt)           # at the estimate
        if link == "motion" and self.motion != "estimate":
            if self.motion == "first":                                    # x_k+1|k - x_k|k-1
                p0, p1, W = self._propagated, _motion_model(self._x[:3], u, dt,
                                                            self._wheel_base), out[1]
            else:                                                         # p_k+1 - p_k
                p0, p1 = self._true_pose(self.t), self._true_pose(self.t + dt)
                W = _motion_jacobians(p0, u, dt, self._wheel_base)[1]
            A = np.eye(3)
            A[0, 2], A[1, 2] = -(p1[1] - p0[1]), p1[0] - p0[0]
            return A, W
        if link == "observation" and (self.observation, self.innovation) != ("estimate",) * 2:
            return self._observation(ids, *out)
        if link == "initialisation" and self.initialisation == "truth":
            return self._initialisation(ids, z, *out)
        return out

    def _observation(self, ids, h, Hp, Hl):
        h, Hp, Hl, ids = h.copy(), Hp.copy(), Hl.copy(), np.asarray(ids)
        if self.observation == "first":                                   # x_k|k-1, first
            first = np.array([self._first[int(i)] for i in ids]).reshape(-1, 2)
            _, Hp1, Hl1 = self.reading_model(self._propagated.copy(), first)
            ok = np.all(np.isfinite(Hp1), axis=(1, 2))
            Hp[ok], Hl[ok] = Hp1[ok], Hl1[ok]
        if "truth" not in (self.observation, self.innovation):
            return h, Hp, Hl
        kk = np.flatnonzero([int(i) in self._true_map for i in ids])       # in the true map
        if kk.size == 0:
            return h, Hp, Hl
        pt = self._true_pose(self.t)
        mt = np.array([self._true_map[int(i)] for i in ids[kk]])
        ht, Hpt, Hlt = self.reading_model(pt, mt)                          # at the truth
        ok = np.all(np.isfinite(Hpt), axis=(1, 2)) & np.all(np.isfinite(Hlt), axis=(1, 2))
        kk, ht, Hpt, Hlt, mt = kk[ok], ht[ok], Hpt[ok], Hlt[ok], mt[ok]
        if self.innovation == "truth":                     # h_t + H_t (x - p_t) + H_t,m (m - m_t)
            dp = self._x[:3] - pt
            dp[2] = wrap(dp[2])
            lin = ht + Hpt @ dp + np.einsum("kab,kb->ka", Hlt, self._positions(ids[kk]) - mt)
            lin[:, 1] = wrap(lin[:, 1])
            use = np.isfinite(h[kk, 1])                    # (a degenerate reading stays so)
            h[kk[use]] = lin[use]
        if self.observation == "truth":
            Hp[kk], Hl[kk] = Hpt, Hlt
        return h, Hp, Hl

    def _initialisation(self, ids, z, m, J1, J2):
        m, J1, J2 = m.copy(), J1.copy(), J2.copy()
        pt = self._true_pose(self.t)
        for j, mid in enumerate(np.asarray(ids).tolist()):
            if mid not in self._true_map:
                continue
            mt = self._true_map[mid]
            zt = self.reading_model(pt, mt[None, :])[0][0]                # the true reading
            J1[j], J2[j] = inverse_observation_jacobians(pt, zt)
            dp, dz = self._x[:3] - pt, z[j] - zt
            dp[2], dz[1] = wrap(dp[2]), wrap(dz[1])
            m[j] = mt + J1[j] @ dp + J2[j] @ dz                           # m_t + J1 dx + J2 dz
        return m, J1, J2


class FEJEKFSLAM(LinearisedEKFSLAM):
    """EKF SLAM with First-Estimates Jacobians (Huang, Mourikis & Roumeliotis; chapter 06):
    :class:`LinearisedEKFSLAM` with ``motion="first"`` and ``observation="first"``.

    With these, the linearised system keeps the true system's unobservable
    directions (a translation and a rotation of everything), so the filter gains
    no information about them from its own linearisation errors.
    """

    def __init__(self, x0, P0, Q, R, **kwargs):
        super().__init__(x0, P0, Q, R, motion="first", observation="first", **kwargs)


class IdealEKFSLAM(LinearisedEKFSLAM):
    """EKF SLAM linearised about the TRUE state, a diagnostic only a simulation can run
    (chapter 06): :class:`LinearisedEKFSLAM` with ``motion="truth"``,
    ``observation="truth"``, ``initialisation=landmark_init`` and ``innovation``.

    ``innovation="estimate"`` keeps EKF SLAM's ``z - h(x)`` with the Jacobians at the
    truth (chapter 06 measures that this mixture is worse than EKF SLAM once the
    heading error is a few degrees).
    """

    def __init__(self, x0, P0, Q, R, *, truth, landmarks, t0: float = 0.0,
                 innovation: str = "truth", landmark_init: str = "estimate", **kwargs):
        super().__init__(x0, P0, Q, R, motion="truth", observation="truth",
                         initialisation=landmark_init, innovation=innovation, truth=truth,
                         landmarks=landmarks, t0=t0, **kwargs)
