"""The course's filters: map-based EKF localisation and EKF SLAM, written to scale.

Two filters with one interface (chapters 03, 04 and 05):

- :class:`EKFLocalization` (chapter 03): the map of landmarks is known exactly;
  the state is the robot's pose ``[x, y, theta]`` only.
- :class:`EKFSLAM` (chapters 04 and 05): the landmarks are unknown; each new
  marker id is appended to the state ``[x, y, theta, x_F1, y_F1, ...]`` with
  the inverse observation model, and re-observations correct pose and map.

Both run the same cycle::

    f.predict(u, dt)           # u = [V_R, V_L] (m/s), dt (s)
    report = f.update(ids, z)  # ids (k,), z (k, 2) = [range, bearing] rows

and both share one :meth:`update` (the *semantics*: association by marker id,
the chi-square gate, the order of fusion and augmentation). The observation
model it linearises is one public method, :meth:`reading_model` (default:
:func:`predict_readings`, the direct observation ``h`` and its Jacobians), so
that a teaching variant (chapter 03's filter with the report's sign error)
overrides one documented method and nothing else. Only the linear
algebra lives in four small methods (``_predict_cov``, ``_innovation_covs``,
``_fuse`` and ``_augment_cov``). This module implements them using the
structure of the problem; :mod:`slamlib.ekf_dense` overrides them with the
dense textbook formulas (full ``F``, ``H`` and ``G`` matrices) so that the two
can be compared number for number (``tests/test_ekf.py``) and timed side by
side (``bench/bench_ekf.py``).

What an update does, in order (report V.C, corrected)
-----------------------------------------------------
1. **Association.** A reading is matched to the landmark with its marker id.
   In :class:`EKFSLAM` an id that is not in the state yet is *new*; in
   :class:`EKFLocalization` an id that is not in the map is *unknown* and
   rejected (never an exception). An id that is new and read more than once in
   the same call is added once, from its first reading; its later readings
   are reported with ``status == "duplicate"``, ``new`` False, ``accepted``
   False and ``d2`` NaN (they are not used: fusing them against a landmark
   that was initialised from the same image would count that image twice).
   Without ids (``association="nn"`` or ``"jcbb"``, ``update(None, z)``,
   chapter 09) the filter pairs the readings itself with
   :mod:`slamlib.association`; see :meth:`_EKFBase._update_without_ids`.
2. **Gating, each reading on its own, against the prior.** For each reading
   of an already-mapped id, with the predicted observation ``h`` and its
   Jacobian ``H_i`` at the prior (predicted) state::

       y_i  = z_i - h(x)              (bearing wrapped to [-pi, pi))
       S_i  = H_i P H_i^T + R_i
       d2_i = y_i^T S_i^-1 y_i        (squared Mahalanobis distance)

   and the reading is accepted when ``d2_i < chi2.ppf(gate, 2)``, which for
   two degrees of freedom is ``-2 ln(1 - gate)`` (5.99 for gate = 0.95). The
   report writes the distance with ``y_k - h`` inside, i.e. ``z - 2h``: the
   innovation ``y`` itself is meant. ``gate=None`` accepts every reading.
3. **One joint update** with all the accepted readings stacked
   (``H`` of 2m rows, ``R`` block-diagonal)::

       S = H P H^T + R,   K = P H^T S^-1,   x <- x + K y,
       P <- (I - K H) P (I - K H)^T + K R K^T     (Joseph form)

   then the heading is wrapped to [-pi, pi).
4. **Augmentation (EKFSLAM).** The new ids are added in the order given, from
   the *updated* pose, with the inverse observation ``m = g(x_B, z)`` and its
   Jacobians ``J1 = dg/dx_B``, ``J2 = dg/dz`` (chapter 04)::

       P_LL = J1 P_rr J1^T + J2 R J2^T,   P_Lx = J1 P_r,:

   where ``P_r,:`` are the robot's rows of the covariance (including the
   landmarks added earlier in the same call).

Cost (what "fast" means here, n = 3 + 2 N state entries)
--------------------------------------------------------
- ``predict`` touches only the robot's rows and columns, O(n)::

      P_rr <- A P_rr A^T + W Q W^T,   P_rm <- A P_rm,   P_mr = P_rm^T

- ``update`` with m accepted readings forms ``H P`` from the rows of the
  robot and of the observed landmarks only (2m x n), ``S`` (2m x 2m), its
  Cholesky factor ``S = L L^T`` and the whitened gain ``W = L^-1 H P``
  (2m x n); then ``K = W^T L^-1`` and::

      x <- x + W^T (L^-1 y),    P <- P - W^T W   (= P - K S K^T)

  with ``P`` changed in place, O(n^2 m): one read and one write of each
  entry, no n x n temporary. Up to n = 200 (the course's worlds) the
  compiled kernel :func:`slamlib.kernels.fuse` does it all, entries (i, j)
  and (j, i) by the same sum; above, the kernel makes W and BLAS subtracts
  ``W^T W`` (``dgemm``, alpha = -1, beta = 1: one call over the active block
  of its storage, or one per strip of 32 rows when n > 2048;
  ``_subtract_symmetric_low_rank``).
  It never builds ``H`` (2m x n) nor an n x n identity, and never multiplies
  two n x n matrices. This is the Joseph form above: for any gain ``K``,
  ``(I - K H) P (I - K H)^T + K R K^T = P - G S^-1 G^T + D S D^T`` with
  ``G = P H^T`` and ``D = K - G S^-1``, so at the gain the filter applies
  (``K = G S^-1`` up to rounding) the two differ by a term of second order in
  the rounding error of K, as the Joseph form's own insensitivity to K
  promises; K itself is never formed. Above n = 200 ``P`` stays symmetric to
  rounding, not bitwise: entries (i, j) and (j, i) are sums of the same
  products, which the BLAS may add in different orders (``tests/test_ekf_inplace.py`` checks
  ``max |P - P^T| <= 1e-15 max |P|`` over 400 updates at n = 603).
- the arithmetic of one step (the prediction, ``h`` and ``H``, the gate's
  ``S_i`` and ``d2_i``, the joint update) runs in the compiled kernels of
  :mod:`slamlib.kernels`; this module keeps the logic (association, gate
  decisions, reports, hooks) in Python.
- a new landmark costs O(n): the state lives in preallocated arrays whose
  capacity doubles when it runs out, so adding N landmarks one by one costs
  O(N) reallocations of amortised O(n^2) in total, not one per landmark.

``f.x`` and ``f.P`` return **copies** of the active part of the state (a
snapshot you can store in a list without it changing under you). Copying ``P``
is one pass over it; inside a loop over many steps, keep what you need
(``f.pose``, ``f.pose_cov``, ``f.landmark(id)``), which are small copies.

Bad input (wrong shapes, NaN or inf, a negative range, a covariance that is
not positive definite, a non-integer id) raises a ``ValueError`` that names
the argument, *before* the filter changes: after the error ``x`` and ``P``
are exactly what they were.
"""

from __future__ import annotations

import functools
import math
import numbers
from dataclasses import dataclass

import numpy as np

from . import kernels as _kernels
from .association import DEFAULT_MAX_NODES, individual_d2, jcbb, nearest_neighbour, pair_covariance
from .metrics import chi2_quantile
from .models import (
    KOBUKI_WHEEL_BASE,
    _check_motion_args,
    _motion_step,
    _wrap_scalar,
    inverse_observation_jacobians,
    inverse_observe,
    observe_landmarks,
    wrap_angle,
)
from .validate import (
    as_covariance,
    as_finite_scalar,
    as_landmark_map,
    as_marker_ids,
    as_positive,
    as_reading_covariances,
    as_readings,
    as_vector,
    count_readings,
)

__all__ = ["EKFLocalization", "EKFSLAM", "LinearisedEKFSLAM", "FEJEKFSLAM", "IdealEKFSLAM",
           "UpdateReport", "gate_threshold", "predict_readings"]

#: The statuses a reading can get from :meth:`EKFSLAM.update`.
STATUSES = ("accepted", "rejected", "new", "duplicate", "unknown", "degenerate")


# --------------------------------------------------------------------------- helpers
def gate_threshold(gate: float | None, dof: int = 2) -> float:
    """The chi-square gate ``chi2.ppf(gate, dof)`` (chapter 05); ``inf`` for ``gate=None``.

    For ``dof = 2`` the chi-square CDF is ``1 - exp(-d2/2)``, so the threshold
    has the closed form ``-2 ln(1 - gate)``: 5.991 for ``gate = 0.95``.
    """
    if gate is None:
        return float("inf")
    return chi2_quantile(_check_gate(gate), dof)


def _check_gate(gate):
    if gate is None:
        return None
    g = as_finite_scalar("gate", gate)
    if not 0.0 < g < 1.0:
        raise ValueError(f"gate: expected a probability in (0, 1) or None, got {g}")
    return g


#: The association methods of the filters (chapter 09; ``"ids"`` is chapters 03-05's look-up).
ASSOCIATIONS = ("ids", "nn", "jcbb")


def _check_association(association, gate):
    if association not in ASSOCIATIONS:
        raise ValueError(f"association: expected one of {ASSOCIATIONS}, got {association!r}")
    if association != "ids" and gate is None:
        raise ValueError(f"gate: association={association!r} needs a gate probability (e.g. "
                         f"0.95), not None: without a gate every reading would match a landmark")
    return association


#: The vectorised direct observation and its Jacobians (chapter 03): the one implementation,
#: :func:`slamlib.models.observe_landmarks`, under the name the filters' update uses.
predict_readings = observe_landmarks


# --------------------------------------------------------------------------- the report
@dataclass(frozen=True)
class UpdateReport:
    """What :meth:`update` did with each of the k readings of one call.

    Attributes
    ----------
    ids : numpy.ndarray of int, shape (k,)
        The marker ids, as given.
    z : numpy.ndarray, shape (k, 2)
        The readings ``[range, bearing]``, as given.
    status : tuple of str
        Per reading: ``"accepted"`` (fused), ``"rejected"`` (failed the gate),
        ``"new"`` (added to the map), ``"duplicate"`` (a second reading of an id
        first seen in this call: not used), ``"unknown"`` (EKFLocalization: id
        not in the map), ``"degenerate"`` (the landmark's estimate lies on the
        robot, the bearing is undefined: not used).
    accepted : numpy.ndarray of bool, shape (k,)
        True for the readings fused in the joint update.
    new : numpy.ndarray of bool, shape (k,)
        True for the readings that added a landmark.
    d2 : numpy.ndarray, shape (k,)
        Squared Mahalanobis distance ``y^T S^-1 y`` of each gated reading
        against the prior; NaN for new, duplicate, unknown and degenerate ones.
    innovation : numpy.ndarray, shape (k, 2)
        ``y = z - h(x)`` at the prior, bearing wrapped; NaN where not gated.
    predicted : numpy.ndarray, shape (k, 2)
        ``h(x)``, the predicted reading at the prior; NaN where not gated.
    S : numpy.ndarray, shape (k, 2, 2)
        Each gated reading's innovation covariance ``H_i P H_i^T + R_i``.
    threshold : float
        The gate ``chi2.ppf(gate, 2)``; ``inf`` when gating is off.
    gate : float or None
        The gate probability.
    joint_nis : float
        ``y^T S^-1 y`` of the joint update (2m degrees of freedom, m = number
        accepted), NaN when nothing was fused: the NIS of chapter 03.
    matched_ids : numpy.ndarray of int, shape (k,), or None
        Without ids (``update(None, z)``, chapter 09): the association's answer,
        read through :attr:`matched`; None with ids.
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
        """int (k,): the map id each reading was fused into or added as; -1 when not used
        (rejected, duplicate, unknown, degenerate, candidate). With ids: ``ids`` where
        accepted or new; without ids (chapter 09): the association's answer."""
        if self.matched_ids is not None:
            return self.matched_ids
        used = np.asarray(self.accepted, dtype=bool) | np.asarray(self.new, dtype=bool)
        return np.where(used, np.asarray(self.ids, dtype=np.int64), -1)

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def n_accepted(self) -> int:
        """Number of readings fused."""
        return int(np.count_nonzero(self.accepted))

    @property
    def rejected(self) -> np.ndarray:
        """True for the readings that failed the gate."""
        return np.array([s == "rejected" for s in self.status], dtype=bool)

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


# --------------------------------------------------------------------------- input checks
# --------------------------------------------------------------------------- the shared filter
class _EKFBase:
    """The semantics shared by every filter of the course; subclasses set the algebra."""

    _can_add = False  # EKFSLAM adds unknown ids to the state

    def __init__(self, x0, P0, Q, R, wheel_base: float = KOBUKI_WHEEL_BASE,
                 gate: float | None = 0.95, capacity: int = 0, association: str = "ids"):
        self.association = _check_association(association, gate)
        #: JCBB's bound on the nodes searched per frame (chapter 09; see slamlib.association).
        self.max_nodes = DEFAULT_MAX_NODES
        #: Without ids, a reading is new only if its d2 to every landmark is at least
        #: chi2.ppf(new_gate, 2) (13.8 for 0.999): between the gate and this, it is rejected
        #: (a true reading falls outside a 0.95 gate one time in twenty; chapter 09).
        self.new_gate = 0.999
        #: Without ids, what the last update's association saw: ``"d2"`` (k, N), every reading's
        #: d2 to every landmark in ``landmark_ids`` order (NaN: degenerate), ``"in_gate"`` (k,),
        #: the landmarks inside each reading's gate, ``"jcbb"``, JCBB's JCBBResult (or None).
        self.last_association: dict = {}
        x0 = as_vector("x0", x0, 3).copy()
        P0 = as_covariance("P0", P0, 3)
        self.Q = as_covariance("Q", Q, 2)
        self.R = as_covariance("R", R, 2)
        self.wheel_base = as_positive("wheel_base", wheel_base)
        self.gate = gate
        cap = 3 + 2 * max(int(capacity), 0)
        self._x = np.zeros(cap)
        self._Pbuf = np.zeros((cap, cap))
        self._shear = None            # (a, b) not yet applied to P_rm (see _predict_shear)
        self._n = 3
        x0[2] = wrap_angle(x0[2])
        self._x[:3] = x0
        self._P[:3, :3] = P0
        self._ids: list[int] = []
        self._slot: dict[int, int] = {}  # marker id -> index of x_F in the state

    # ------------------------------------------------------------------ read-out
    @property
    def _P(self) -> np.ndarray:
        """The covariance storage (capacity x capacity), brought up to date: the shear of
        the predictions since the last read is applied to ``P_rm`` first
        (see :meth:`_predict_shear`)."""
        if self._shear is not None:
            self._apply_shear()
        return self._Pbuf

    @_P.setter
    def _P(self, value: np.ndarray) -> None:
        self._shear = None
        self._Pbuf = value

    @property
    def gate(self) -> float | None:
        """Probability of the chi-square gate, or None (no gating); may be changed any time."""
        return self._gate

    @gate.setter
    def gate(self, value) -> None:
        self._gate = _check_gate(value)
        self._threshold = gate_threshold(self._gate)

    @property
    def threshold(self) -> float:
        """The gate on d2: ``chi2.ppf(gate, 2)``, ``inf`` without gating."""
        return self._threshold

    @property
    def x(self) -> np.ndarray:
        """The full mean ``[x, y, theta, x_F1, y_F1, ...]`` (a copy), shape (n,)."""
        return self._x[:self._n].copy()

    @property
    def P(self) -> np.ndarray:
        """The full covariance (a copy), shape (n, n)."""
        return self._P[:self._n, :self._n].copy()

    @property
    def pose(self) -> np.ndarray:
        """The robot's pose ``[x, y, theta]`` (a copy)."""
        return self._x[:3].copy()

    @property
    def pose_cov(self) -> np.ndarray:
        """The robot's 3x3 covariance block ``P_rr`` (a copy)."""
        return self._Pbuf[:3, :3].copy()           # always current (the shear is in P_rm only)

    @property
    def state_size(self) -> int:
        """n, the length of the state vector."""
        return self._n

    @property
    def capacity(self) -> int:
        """How many state entries fit before the storage is reallocated (doubled)."""
        return self._x.shape[0]

    # ------------------------------------------------------------------ predict
    def predict(self, u, dt: float, Q=None) -> None:
        """Prediction with the wheel speeds ``u = [V_R, V_L]`` over ``dt`` (chapter 01).

        ``x_B <- f(x_B, u)``, ``P_rr <- A P_rr A^T + W Q W^T``, ``P_rm <- A P_rm``;
        the landmarks do not move. ``Q``: this step's 2x2 covariance of ``u``
        (default the filter's own ``Q``; a real log's density gives each step
        its own, ``Q_c / dt``, chapter 10).
        """
        # u and dt are checked (ValueError naming them) once, before anything changes
        if not (type(u) is np.ndarray and u.dtype == np.float64 and u.shape == (2,)
                and type(dt) is float and dt >= 0.0 and math.isfinite(dt)
                and math.isfinite(u[0]) and math.isfinite(u[1])):
            _, u, dt, _ = _check_motion_args(self._x[:3], u, dt, self.wheel_base)
        if Q is not None:
            Q = as_covariance("Q", Q, 2)
        self._predict(u, dt, Q)

    def _predict(self, u: np.ndarray, dt: float, Q: np.ndarray | None = None) -> None:
        """:meth:`predict` on checked ``u`` (float array (2,)), ``dt`` and ``Q`` (None: the
        filter's own; the runners' loop)."""
        if self._fast_predict():
            # The course's motion model, unchanged hooks: f, A, W as scalars (no 3x3 arrays),
            # compiled (slamlib.kernels.predict_pose, from models.motion_terms, chapter 01).
            a, b = _kernels.predict_pose(self._x, self._Pbuf, self.Q if Q is None else Q,
                                         float(u[0]), float(u[1]), dt, self.wheel_base)
            self._add_shear(a, b)
            return
        new_pose, A, W = self.motion_step(self._x[:3], u, dt)
        if Q is None:
            self._predict_cov(A, W)
        else:
            self._predict_cov(A, W, Q)
        self._x[:3] = new_pose

    def _fast_predict(self) -> bool:
        """True when the prediction is the course's own (motion hooks unchanged): it then runs
        compiled, and the runners may predict many steps in one call (:meth:`_predict_block`)."""
        return (getattr(self.motion_step, "__func__", None) is _EKFBase.motion_step
                and getattr(self._predict_cov, "__func__", None) is _EKFBase._predict_cov)

    def _predict_block(self, u: np.ndarray, dt: np.ndarray, Q: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`predict` with each row of ``u`` (k, 2), ``dt`` (k,) and ``Q`` (k, 2, 2; None:
        the filter's own for every step), checked, in order; returns the pose (k, 3) and
        ``P_rr`` (k, 3, 3) after each step (what a trace records).

        The same arithmetic as k calls of :meth:`predict`, bit for bit
        (:func:`slamlib.kernels.predict_poses`), in one call; only for the
        course's own prediction (:meth:`_fast_predict`), else step by step.
        """
        k = dt.shape[0]
        poses, covs = np.empty((k, 3)), np.empty((k, 3, 3))
        if not self._fast_predict():
            for i in range(k):
                self._predict(u[i], float(dt[i]), None if Q is None else Q[i])
                poses[i], covs[i] = self._x[:3], self._Pbuf[:3, :3]
            return poses, covs
        has = self._shear is not None
        sa, sb = self._shear if has else (0.0, 0.0)
        Qk = np.broadcast_to(self.Q, (k, 2, 2)) if Q is None else Q
        has, sa, sb = _kernels.predict_poses(
            self._x, self._Pbuf, Qk, np.ascontiguousarray(u, dtype=float),
            np.ascontiguousarray(dt, dtype=float), self.wheel_base, has, sa, sb, poses, covs)
        if has and self._n > 3:
            self._shear = (sa, sb)
        return poses, covs

    def motion_step(self, pose: np.ndarray, u: np.ndarray, dt: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The motion model that :meth:`predict` linearises (chapter 01): a hook like
        :meth:`reading_model`.

        Returns ``(f(pose, u), A, W)``: the predicted pose and the Jacobians
        :func:`slamlib.models.motion_jacobians` at ``pose`` (u and dt checked).
        :class:`FEJEKFSLAM` and :class:`IdealEKFSLAM` override it to evaluate A
        elsewhere; the mean always moves with ``f(pose, u)``.
        """
        return _motion_step(pose, u, dt, self.wheel_base)

    # ------------------------------------------------------------------ update
    def _lookup(self, marker_id: int):
        """``(position, slot)`` of a landmark (slot -1: not in the state), or None."""
        raise NotImplementedError

    def reading_model(self, pose: np.ndarray, positions: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The observation model that :meth:`update` linearises (chapter 03): a public hook.

        :meth:`update` calls it once per call, at the prior (predicted) pose, with
        the positions of the landmarks read, and uses what it returns everywhere:
        the innovations, the gate's ``S_i`` and the joint update (also in the dense
        reference :mod:`slamlib.ekf_dense`, which inherits :meth:`update`).

        Parameters
        ----------
        pose : numpy.ndarray, shape (3,)
            The prior pose ``[x, y, theta]`` (a copy: changing it changes nothing).
        positions : numpy.ndarray, shape (k, 2)
            The landmarks' positions ``[x_F, y_F]`` (the known map or the state).

        Returns
        -------
        (h, H_pose, H_landmark) : arrays of shapes (k, 2), (k, 2, 3), (k, 2, 2)
            Predicted readings ``[range, bearing]`` and the Jacobians of each with
            respect to the pose and to its landmark. A row of ``h`` with a NaN
            bearing marks a degenerate reading (landmark on the robot): not used.

        The default is :func:`predict_readings`, the direct observation and its
        (correct) Jacobians. Override it to study a different model, e.g. a
        Jacobian with a sign error, without touching the filter's algebra::

            class Broken(EKFLocalization):
                def reading_model(self, pose, positions):
                    h, Hp, Hl = super().reading_model(pose, positions)
                    Hp[:, 1, 1] *= -1
                    return h, Hp, Hl
        """
        return predict_readings(pose, positions)

    def update(self, ids, z, R=None) -> UpdateReport:
        """Correct the state with the readings ``z`` of the markers ``ids`` (chapters 03-05).

        Parameters
        ----------
        ids : array_like of int, shape (k,)
            Marker ids, one per reading (may be empty).
        z : array_like, shape (k, 2)
            Readings ``[range (m, >= 0), bearing (rad)]`` in the robot frame.
        R : array_like, shape (2, 2) or (k, 2, 2), optional
            The readings' noise covariance, one for all or one per reading (the
            camera's noise grows with range); the constructor's ``R`` if None.

        Returns
        -------
        UpdateReport
            What happened to each reading (see the module docstring for the order:
            association, gate against the prior, one joint update, augmentation).

        Raises
        ------
        ValueError
            On bad input, before anything changes.
        """
        # -------- association step: without ids (chapter 09) the filter pairs the readings
        if ids is None or self.association != "ids":
            return self._update_without_ids(ids, z, R)
        ids = as_marker_ids(ids)
        k = ids.shape[0]
        z = as_readings(z, k)
        return self._update_ids(ids, z, as_reading_covariances(R, self.R, k))

    def _update_ids(self, ids: np.ndarray, z: np.ndarray, Rk: np.ndarray) -> UpdateReport:
        """:meth:`update` with ids on checked arrays: ids int (k,), z (k, 2), Rk (k, 2, 2).

        The runners of :mod:`slamlib.runner` call it directly with the
        readings of a :class:`~slamlib.runs.Run` (checked when the run was made)
        and the covariances of the run's own sensor model.
        """
        # steps 1 and 2, association by id and each reading's gate at the prior: nothing changes
        fields, fuse = self._gate_ids(ids, z, Rk)
        # -------- everything is checked: from here on the state changes
        # step 3: the accepted readings in ONE joint update
        joint_nis = float("nan")
        if fuse is not None:
            slots_a, Hp, Hl, y, Rg, acc = fuse
            if acc.all():
                joint_nis = self._fuse(slots_a, Hp, Hl, y, Rg)
            else:
                joint_nis = self._fuse(slots_a[acc], Hp[acc], Hl[acc], y[acc], Rg[acc])
            self._x[2] = _wrap_scalar(float(self._x[2]))
        # step 4: ids never seen before join the state, from the updated pose (inverse observation)
        for i in fields["new_index"]:
            self._add_landmark(int(ids[i]), z[i], Rk[i])
        return _report(fields, joint_nis)

    def _gate_ids(self, ids: np.ndarray, z: np.ndarray, Rk: np.ndarray):
        """Steps 1 and 2 of :meth:`update` (association by id, each reading gated at the prior):
        the report's fields (``joint_nis`` not yet known; see :func:`_report`) and what the
        joint update then fuses, ``(slots, H_pose, H_landmark, y, R, accepted)`` or None.
        Nothing changes."""
        k = ids.shape[0]
        status = [""] * k
        gated, positions, slots = [], [], []
        first_new: dict[int, int] = {}
        # step 1, association: each id is looked up (a mapped landmark, new, or unknown)
        lookup = self._lookup
        for i, mid in enumerate(ids.tolist()):
            found = lookup(mid)
            if found is not None:
                gated.append(i)
                positions.append(found[0])
                slots.append(found[1])
            elif not self._can_add:
                status[i] = "unknown"
            elif mid in first_new:
                status[i] = "duplicate"
            else:
                first_new[mid] = i
                status[i] = "new"
        every = len(gated) == k                      # the usual frame: every id mapped
        if every:
            d2 = innov = pred = S_all = None         # the gated arrays themselves, below
        else:
            d2 = np.full(k, np.nan)
            innov = np.full((k, 2), np.nan)
            pred = np.full((k, 2), np.nan)
            S_all = np.full((k, 2, 2), np.nan)
        accepted = np.zeros(k, dtype=bool)
        fuse = None

        if gated:
            g = np.array(gated)
            slots_a = np.array(slots, dtype=np.int64)
            h, Hp, Hl = self.reading_model(self._x[:3].copy(), np.array(positions))
            ok = np.isfinite(h[:, 1])
            if not ok.all():                     # a landmark estimate on the robot
                for i in g[~ok]:
                    status[i] = "degenerate"
                g, h, Hp, Hl, slots_a = g[ok], h[ok], Hp[ok], Hl[ok], slots_a[ok]
                if every:
                    every = False
                    d2, innov = np.full(k, np.nan), np.full((k, 2), np.nan)
                    pred, S_all = np.full((k, 2), np.nan), np.full((k, 2, 2), np.nan)
        if gated and g.size:
            # step 2, the gate: y_i = z_i - h_i, S_i = H_i P H_i^T + R_i, d2_i = y_i^T S_i^-1 y_i
            Rg = Rk if every else np.ascontiguousarray(Rk[g])
            S = self._innovation_covs(slots_a, Hp, Hl, Rg)
            y, d2g = np.empty((g.size, 2)), np.empty(g.size)
            h = _f64(h)
            _kernels.innovation_distances(z if every else z[g], h, S, y, d2g)
            acc = d2g < self.threshold if self.gate is not None else np.ones(g.size, dtype=bool)
            if every:
                d2, innov, pred, S_all, accepted = d2g, y, h, S, acc
            else:
                d2[g], innov[g], pred[g], S_all[g] = d2g, y, h, S
                accepted[g[acc]] = True
            flags = acc.tolist()
            for i, a in zip(g.tolist(), flags):
                status[i] = "accepted" if a else "rejected"
            if True in flags:
                fuse = (slots_a, Hp, Hl, y, Rg, acc)
        elif every:                                  # k = 0
            d2, innov = np.full(k, np.nan), np.full((k, 2), np.nan)
            pred, S_all = np.full((k, 2), np.nan), np.full((k, 2, 2), np.nan)

        new = np.zeros(k, dtype=bool)
        new_index = list(first_new.values())
        new[new_index] = True
        fields = dict(ids=ids, z=z, status=tuple(status), accepted=accepted, new=new, d2=d2,
                      innovation=innov, predicted=pred, S=S_all, threshold=self.threshold,
                      gate=self.gate, new_index=new_index)
        return fields, fuse

    def preview(self, ids, z, R=None) -> UpdateReport:
        """What :meth:`update` ``(ids, z, R)`` would report, without changing the filter.

        The same association and gate as :meth:`update` (the same code: every
        reading's ``h``, ``y``, ``S_i``, ``d2_i`` and verdict at the prior), so a
        chapter can look at a frame's numbers and keep the prior, instead of
        updating a deep copy. ``new`` marks the readings the update would add;
        ``joint_nis`` is NaN (nothing is fused). Filters that pair readings
        without ids, or whose :meth:`update` does more than this class's (e.g.
        :class:`~slamlib.confirmation.ConfirmedSLAM`), raise a ValueError.
        """
        if self.association != "ids" or ids is None:
            raise ValueError(f"preview: needs readings with ids and association='ids' (this "
                             f"filter has association={self.association!r})")
        if type(self).update is not _EKFBase.update:
            raise ValueError(f"preview: {type(self).__name__} has its own update (it does more "
                             f"than gate and fuse): apply it to a copy instead")
        ids = as_marker_ids(ids)
        k = ids.shape[0]
        z = as_readings(z, k)
        return _report(self._gate_ids(ids, z, as_reading_covariances(R, self.R, k))[0],
                       float("nan"))

    def _update_without_ids(self, ids, z, R) -> UpdateReport:
        """The association step without ids (chapter 09): pair, fuse jointly, then add new ones.

        1. Every reading against every mapped landmark at the prior: innovations
           ``y_ij``, ``S_ij = H_j P H_j^T + R_i``, ``d2_ij`` (individual compatibility).
        2. The pairs: :func:`slamlib.association.nearest_neighbour` (``"nn"``) or
           :func:`slamlib.association.jcbb` (``"jcbb"``, on the landmarks inside
           some reading's gate).
        3. The paired readings are fused in one joint update, as with ids.
        4. A reading far from every landmark (``d2 >= chi2.ppf(new_gate, 2)`` for
           all) goes to :meth:`_unmatched` (EKFSLAM adds it as a new landmark;
           ConfirmedSLAM holds it as a candidate; the map-based filter rejects
           it). Any other unpaired reading (just outside the gate, or inside one
           but its landmark took a closer reading, or JCBB left it out) is
           ``"rejected"``.

        The report's ``ids`` are -1 (none given); ``matched`` is the answer;
        ``d2``, ``innovation``, ``predicted`` and ``S`` refer to the landmark the
        reading was paired with or, when unpaired, to the one of smallest ``d2``.
        """
        if self.association == "ids":
            as_marker_ids(None)                     # raises: None needs association "nn"/"jcbb"
        if ids is not None:
            raise ValueError(f"ids: this filter (association={self.association!r}) pairs the "
                             f"readings itself: call update(None, z) without ids, or build "
                             f"it with association='ids' to use the ids")
        if self.gate is None:
            _check_association(self.association, None)
        k = count_readings(z)
        z = as_readings(z, k)
        Rk = as_reading_covariances(R, self.R, k)

        keys = list(self.landmark_ids)
        found = [self._lookup(m) for m in keys]
        self.last_association = {"in_gate": np.zeros(k, dtype=np.int64), "jcbb": None,
                                 "d2": np.full((k, len(keys)), np.nan)}
        status = ["rejected"] * k
        matched = np.full(k, -1, dtype=np.int64)
        d2 = np.full(k, np.nan)
        innov = np.full((k, 2), np.nan)
        pred = np.full((k, 2), np.nan)
        S_all = np.full((k, 2, 2), np.nan)
        accepted = np.zeros(k, dtype=bool)
        joint_nis = float("nan")
        outside = np.ones(k, dtype=bool)          # outside every landmark's gate
        if keys and k:
            positions = np.array([f[0] for f in found])
            slots = np.array([f[1] for f in found], dtype=np.int64)
            h, Hp, Hl = self.reading_model(self._x[:3].copy(), positions)
            ok = np.isfinite(h[:, 1])
            cols = np.flatnonzero(ok)
            h, Hp, Hl, slots = h[ok], Hp[ok], Hl[ok], slots[ok]
        if keys and k and cols.size:
            N = cols.size
            y = z[:, None, :] - h[None, :, :]
            y[:, :, 1] = wrap_angle(y[:, :, 1])
            S0 = self._innovation_covs(slots, Hp, Hl, np.zeros((N, 2, 2)))   # H_j P H_j^T
            S = S0[None, :, :, :] + Rk[:, None, :, :]
            D2 = individual_d2(y, S)
            inside = D2 < self.threshold
            outside = np.all(D2 >= gate_threshold(max(self.new_gate, self.gate)), axis=1)
            self.last_association["in_gate"] = np.count_nonzero(inside, axis=1)
            self.last_association["d2"][:, cols] = D2
            if self.association == "nn":
                a = nearest_neighbour(D2, self.threshold)
            else:
                cand = np.flatnonzero(np.any(inside, axis=0))
                a = np.full(k, -1, dtype=np.int64)
                if cand.size:
                    C = self._predicted_readings_cov(slots[cand], Hp[cand], Hl[cand])
                    res = jcbb(y[:, cand], D2[:, cand], C, Rk, self.gate,
                               max_nodes=self.max_nodes)
                    self.last_association["jcbb"] = res
                    paired = res.assignment >= 0
                    a[paired] = cand[res.assignment[paired]]
            near = np.where(a >= 0, a, np.argmin(D2, axis=1))
            r = np.arange(k)
            d2[:], innov[:], pred[:], S_all[:] = D2[r, near], y[r, near], h[near], S[r, near]
            fused = np.flatnonzero(a >= 0)
            for i in fused:
                status[i] = "accepted"
                matched[i] = keys[cols[a[i]]]
            accepted[fused] = True
            # -------- everything is checked: from here on the state changes
            if fused.size:
                j = a[fused]
                joint_nis = self._fuse(slots[j], Hp[j], Hl[j], np.ascontiguousarray(y[fused, j]),
                                       np.ascontiguousarray(Rk[fused]))
                self._x[2] = wrap_angle(self._x[2])
        new = np.zeros(k, dtype=bool)
        for i, (st, mid) in zip(np.flatnonzero(outside), self._unmatched(
                np.flatnonzero(outside), z, Rk)):
            status[i] = st
            if mid is not None:
                matched[i] = mid
                new[i] = st == "new"
        return UpdateReport(ids=np.full(k, -1, dtype=np.int64), z=z, status=tuple(status),
                            accepted=accepted, new=new, d2=d2, innovation=innov, predicted=pred,
                            S=S_all, threshold=self.threshold, gate=self.gate,
                            joint_nis=joint_nis, matched_ids=matched)

    def _predicted_readings_cov(self, slots, Hp, Hl) -> np.ndarray:
        """``H P H^T`` (2N x 2N) of N predicted readings, cross terms included (for JCBB)."""
        P = self._P
        N = slots.size
        if np.all(slots < 0):                    # known map: only the pose is uncertain
            return pair_covariance(Hp, Hl, P[:3, :3], np.zeros((3, 2 * N)),
                                   np.zeros((2 * N, 2 * N)))
        idx = np.column_stack([slots, slots + 1]).reshape(-1)
        return pair_covariance(Hp, Hl, P[:3, :3], P[:3, idx], P[np.ix_(idx, idx)])

    def _unmatched(self, readings: np.ndarray, z: np.ndarray, R: np.ndarray):
        """What becomes of readings without ids outside every gate: ``(status, map id)`` each.

        The map-based filter rejects them; EKFSLAM adds each as a new landmark
        named ``max(ids) + 1`` (0 for the first), from the updated pose.
        """
        if not self._can_add:
            return [("rejected", None) for _ in readings]
        out = []
        for i in readings:
            mid = max(self._ids) + 1 if self._ids else 0
            self._add_landmark(mid, z[i], R[i])
            out.append(("new", mid))
        return out

    def _initial_landmark(self, marker_id: int, z: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A new landmark's mean and the Jacobians of its initialisation, ``(m, J1, J2)``:
        the inverse observation ``g(x_B, z)`` and its Jacobians at the current pose (ch. 04)."""
        pose = self._x[:3].copy()
        return inverse_observe(pose, z), *inverse_observation_jacobians(pose, z)

    def _add_landmark(self, marker_id: int, z: np.ndarray, R: np.ndarray) -> None:
        """Append a landmark from the current pose and reading z (chapter 04)."""
        m, J1, J2 = self._initial_landmark(marker_id, z)
        n = self._n
        self._reserve(n + 2)
        self._augment_cov(J1, J2, R)
        self._x[n:n + 2] = m
        self._n = n + 2
        self._slot[marker_id] = n
        self._ids.append(marker_id)

    def _reserve(self, size: int) -> None:
        """Make room for ``size`` state entries, doubling the capacity when it runs out."""
        cap = self._x.shape[0]
        if size <= cap:
            return
        new_cap = max(size, 2 * cap)
        n = self._n
        x = np.zeros(new_cap)
        P = np.zeros((new_cap, new_cap))
        x[:n] = self._x[:n]
        P[:n, :n] = self._P[:n, :n]
        self._x, self._P = x, P

    # ------------------------------------------------------------------ the structured algebra
    def _predict_cov(self, A: np.ndarray, W: np.ndarray, Q: np.ndarray | None = None) -> None:
        """``P_rr <- A P_rr A^T + W Q W^T``, ``P_rm <- A P_rm``, ``P_mr = P_rm^T``: O(n).

        ``Q`` this step's (None: the filter's own). The motion Jacobians of the
        course's filters are all *shears*, ``A = I + c e_3^T`` with ``c = [a, b, 0]``
        (only ``A[0, 2]`` and ``A[1, 2]`` differ from the identity): those go to
        :meth:`_predict_shear`; any other A is applied as it is.
        """
        Q = self.Q if Q is None else Q
        a = A.tolist()
        if (a[0][0] == 1.0 and a[0][1] == 0.0 and a[1][0] == 0.0 and a[1][1] == 1.0
                and a[2] == [0.0, 0.0, 1.0]):
            self._predict_shear(a[0][2], a[1][2], tuple(np.ravel(W).tolist()), Q)
            return
        P, n = self._P, self._n
        Prr = A @ P[:3, :3] @ A.T + W @ Q @ W.T
        P[:3, :3] = 0.5 * (Prr + Prr.T)
        if n > 3:
            P[:3, 3:n] = A @ P[:3, 3:n]
            P[3:n, :3] = P[:3, 3:n].T

    def _predict_shear(self, a: float, b: float, W: tuple, Q: np.ndarray | None = None) -> None:
        """The prediction's covariance for ``A = I + c e_3^T``, ``c = [a, b, 0]`` (chapter 01).

        ``P_rr <- A P_rr A^T + W Q W^T`` element by element, exactly symmetric
        (:func:`slamlib.kernels.shear_cov`)::

            (A P A^T)_ij = P_ij + c_i P_3j + P_i3 c_j + c_i c_j P_33

        and ``P_rm <- A P_rm`` is *deferred*: shears compose by adding their
        ``c`` (``(I + c e_3^T)(I + c' e_3^T) = I + (c + c') e_3^T`` because
        ``e_3^T c' = 0``), so the predictions between two camera frames are one
        shear of ``P_rm``, applied (O(n)) when anything next reads ``P``
        (:attr:`_P`). ``W`` is the 3x2 noise Jacobian as 6 floats, row by row; ``Q``
        this step's (None: the filter's own).
        """
        _kernels.shear_cov(self._Pbuf, self.Q if Q is None else Q, a, b, *W)
        self._add_shear(a, b)

    def _add_shear(self, a: float, b: float) -> None:
        """Compose the shear ``c = [a, b, 0]`` of one more prediction with the pending one."""
        if self._n > 3:
            if self._shear is None:
                self._shear = (a, b)
            else:
                self._shear = (self._shear[0] + a, self._shear[1] + b)

    def _apply_shear(self) -> None:
        """``P_rm <- (I + c e_3^T) P_rm`` for the pending ``c`` of :meth:`_predict_shear`."""
        a, b = self._shear
        self._shear = None
        _kernels.apply_shear(self._Pbuf, self._n, a, b)

    def _blocks(self, slots: np.ndarray) -> np.ndarray:
        """State indices ``(m, c)`` of the robot and of each reading's landmark."""
        if np.all(slots < 0):
            return np.broadcast_to(np.arange(3), (slots.size, 3))
        idx = np.empty((slots.size, 5), dtype=slots.dtype)
        idx[:, :3] = (0, 1, 2)
        idx[:, 3] = slots
        idx[:, 4] = slots + 1
        return idx

    def _reading_jacobians(self, slots, Hp, Hl) -> np.ndarray:
        """Each reading's Jacobian restricted to the columns of ``_blocks``: (m, 2, c)."""
        if np.all(slots < 0):
            return Hp
        return np.concatenate([Hp, Hl], axis=2)

    def _innovation_covs(self, slots, Hp, Hl, R) -> np.ndarray:
        """``S_i = H_i P H_i^T + R_i`` from the 5x5 (or 3x3) blocks each reading touches
        (:func:`slamlib.kernels.innovation_covs`)."""
        S = np.empty((slots.shape[0], 2, 2))
        _kernels.innovation_covs(self._P, slots, _f64(Hp), _f64(Hl), _f64(R), S)
        return S

    def _fuse(self, slots, Hp, Hl, y, R) -> float:
        """One joint update with m readings, O(n^2 m) in one pass over P; returns the joint NIS.

        With ``S = H P H^T + R = L L^T`` (Cholesky, 2m x 2m) and the whitened
        gain ``W = L^-1 H P`` (2m x n), ``K = W^T L^-1``, so::

            x <- x + W^T (L^-1 y),   P <- P - W^T W,   NIS = |L^-1 y|^2

        and ``P - W^T W = P - K S K^T`` is the Joseph form at this gain (see the
        module docstring). Only W, 2m x n, is made; P changes in place, in the
        compiled kernel :func:`slamlib.kernels.fuse` up to ``n = _IN_PLACE_FROM``, above
        by BLAS (:func:`_subtract_symmetric_low_rank`).
        """
        P, n = self._P, self._n
        ok, nis, W = _kernels.fuse(self._x, P, n, slots, _f64(Hp), _f64(Hl), _f64(y), _f64(R),
                                   n <= _IN_PLACE_FROM)
        if not ok:
            raise np.linalg.LinAlgError(
                "update: the joint innovation covariance S = H P H^T + R is not positive "
                "definite (nothing was changed)")
        if n > _IN_PLACE_FROM:
            _subtract_symmetric_low_rank(P, n, W)    # P - K S K^T, in place (BLAS)
        return float(nis)

    def _augment_cov(self, J1: np.ndarray, J2: np.ndarray, R: np.ndarray) -> None:
        """Fill the new landmark's rows and columns (storage already reserved): O(n)."""
        P, n = self._P, self._n
        PLx = J1 @ P[:3, :n]
        PLL = J1 @ P[:3, :3] @ J1.T + J2 @ R @ J2.T
        P[n:n + 2, :n] = PLx
        P[:n, n:n + 2] = PLx.T
        P[n:n + 2, n:n + 2] = 0.5 * (PLL + PLL.T)


def _report(fields: dict, joint_nis: float) -> UpdateReport:
    """The :class:`UpdateReport` from the fields :meth:`_EKFBase._gate_ids` made."""
    f = dict(fields)
    del f["new_index"]
    return UpdateReport(joint_nis=joint_nis, **f)


def _f64(a: np.ndarray) -> np.ndarray:
    """``a`` as a C-contiguous float64 array (no copy if it is one): the kernels' input."""
    return np.ascontiguousarray(a, dtype=np.float64)


@functools.cache
def _dgemm():
    """BLAS ``dgemm`` of :mod:`scipy.linalg.cython_blas` as a ctypes function.

    ``scipy.linalg.blas.dgemm`` (f2py) takes no leading dimension: given the
    active block ``P[:n, :n]`` of the larger storage it would copy it. The
    Cython BLAS table exports the Fortran routine itself (every argument by
    pointer), which takes ``ldc`` and so works in place on a block.
    """
    import ctypes

    from scipy.linalg import cython_blas

    # private prototypes (not by setting argtypes on the shared ctypes.pythonapi)
    name = ctypes.PYFUNCTYPE(ctypes.c_char_p, ctypes.py_object)(
        ("PyCapsule_GetName", ctypes.pythonapi))
    pointer = ctypes.PYFUNCTYPE(ctypes.c_void_p, ctypes.py_object, ctypes.c_char_p)(
        ("PyCapsule_GetPointer", ctypes.pythonapi))
    capsule = cython_blas.__pyx_capi__["dgemm"]
    address = pointer(capsule, name(capsule))
    return ctypes.CFUNCTYPE(None, *[ctypes.c_void_p] * 13)(address)


#: Up to this state size, :func:`_subtract_symmetric_low_rank` subtracts one n x n product (at
#: most 320 kB; the ctypes call of the in-place path costs more than that temporary there).
_IN_PLACE_FROM = 200
#: Up to this n, :func:`_subtract_symmetric_low_rank` makes one BLAS call over the whole block.
_ONE_CALL_MAX = 2048
#: Above it, one call per strip of this many rows of P (see the function's docstring).
_STRIP_ROWS = 32


def _subtract_symmetric_low_rank(P: np.ndarray, n: int, W: np.ndarray) -> None:
    """``P[:n, :n] -= W^T W`` in place with BLAS (``dgemm``), O(n^2 k), no n x n temporary.

    ``P`` is the filter's C-ordered storage (rows contiguous, row stride ``ld >= n``),
    ``W`` is k x n. Read as a Fortran (column-major) matrix with leading
    dimension ``ld``, the block ``P[:n, :n]`` is ``P^T = P``, and ``W`` (C-ordered)
    is the n x k matrix ``W^T``; ``dgemm`` with ``alpha = -1``, ``beta = 1`` then
    computes ``P <- P - W^T W`` where P lies, reading and writing each entry once.

    Up to ``n = _IN_PLACE_FROM`` (the course's worlds) it is ``P -= W.T @ W``
    instead: numpy's BLAS forms ``W^T W`` with ``syrk`` (exactly symmetric) in
    a temporary of at most 320 kB, cheaper than the ctypes call below.
    Up to ``n = _ONE_CALL_MAX`` this is one call over the whole block. Above,
    it is one call per strip of ``_STRIP_ROWS`` rows of P (the same products,
    the strips one after the other): OpenBLAS sweeps all n columns for every
    block of 512 rows, and at n = 8003 that pattern ran at half the speed of a
    plain copy of P, while 32-row strips stream through memory at the speed of
    a copy (``bench/bench_ekf.py``).

    Entries ``(i, j)`` and ``(j, i)`` are sums of the same k products
    ``W_li W_lj``, which the BLAS may add in different orders, so P stays
    symmetric to rounding (bitwise in small cases), not always bitwise.
    """
    k = W.shape[0]
    if W.shape != (k, n):
        raise ValueError(f"W: expected shape (k, {n}), got {W.shape}")
    if (P.dtype != np.float64 or P.ndim != 2 or P.strides[1] != 8 or P.strides[0] % 8
            or P.strides[0] < 8 * n or P.shape[0] < n or P.shape[1] < n
            or not P.flags.writeable):
        raise ValueError(f"P: expected a writeable float64 array with contiguous rows of at "
                         f"least {n} entries, got dtype {P.dtype}, strides {P.strides}")
    if n == 0 or k == 0:
        return
    if n <= _IN_PLACE_FROM:
        # small P: one product (W^T W is done by BLAS's syrk, exactly symmetric) costs less
        # than the call below
        P[:n, :n] -= W.T @ W
        return
    import ctypes

    W = np.ascontiguousarray(W, dtype=np.float64)
    ld = P.strides[0] // 8
    step = n if n <= _ONE_CALL_MAX else _STRIP_ROWS
    dims = (ctypes.c_int * 4)(n, k, ld, step)           # n, k, ldc, rows of a strip
    last = (ctypes.c_int * 1)(n - (n - 1) // step * step)   # rows of the last strip
    coef = (ctypes.c_double * 2)(-1.0, 1.0)             # alpha, beta
    nn, kk, ldc, rows = (ctypes.addressof(dims) + 4 * i for i in range(4))
    alpha, beta = ctypes.addressof(coef), ctypes.addressof(coef) + 8
    dgemm, w, p = _dgemm(), W.ctypes.data, P.ctypes.data
    for i0 in range(0, n, step):
        b = rows if i0 + step <= n else ctypes.addressof(last)
        # rows i0.. of P = Fortran columns i0.. of C (n x b) <- -A B^T + C, with
        # A = W^T (n x k) and B = rows i0.. of W^T (b x k), both of leading dimension n
        dgemm(b"N", b"T", nn, b, kk, alpha, w, nn, w + 8 * i0, nn, beta, p + 8 * i0 * ld, ldc)


# --------------------------------------------------------------------------- the two filters
class EKFLocalization(_EKFBase):
    """Map-based EKF localisation with a known map of landmarks (chapter 03).

    The state is the robot's pose only; ``x`` is (3,) and ``P`` is 3x3.

    Parameters
    ----------
    x0 : array_like, shape (3,)
        Initial pose ``[x, y, theta]``.
    P0 : array_like, shape (3, 3)
        Its covariance (positive definite).
    Q : array_like, shape (2, 2)
        Covariance of the wheel speeds ``[V_R, V_L]`` (positive definite).
    R : array_like, shape (2, 2)
        Default covariance of a reading ``[range, bearing]`` (positive definite).
    landmarks : dict {int: (2,)}
        The known map: marker id -> position ``[x, y]`` in N.
    wheel_base : float
        b (m).
    gate : float or None
        Probability of the chi-square gate (0.95); None accepts every reading.
    association : {"ids", "nn", "jcbb"}
        How readings find their landmark: by marker id (default), or without
        ids, ``update(None, z)``, by nearest neighbour or JCBB (chapter 09).

    An id that is not in the map is rejected (``status == "unknown"``), never an
    exception.
    """

    def __init__(self, x0, P0, Q, R, landmarks, wheel_base: float = KOBUKI_WHEEL_BASE,
                 gate: float | None = 0.95, association: str = "ids"):
        lm = as_landmark_map(landmarks)
        super().__init__(x0, P0, Q, R, wheel_base=wheel_base, gate=gate, capacity=0,
                         association=association)
        self._map = lm

    @property
    def landmarks(self) -> dict[int, np.ndarray]:
        """The known map (a copy)."""
        return {k: v.copy() for k, v in self._map.items()}

    @property
    def landmark_ids(self) -> list[int]:
        """The ids of the known map (none of them is in the state)."""
        return list(self._map)

    def _lookup(self, marker_id: int):
        p = self._map.get(marker_id)
        return None if p is None else (p, -1)


class EKFSLAM(_EKFBase):
    """EKF SLAM with marker ids for association and a chi-square gate (chapters 04, 05).

    The state is ``[x, y, theta, x_F1, y_F1, ...]``; a marker id seen for the
    first time is appended with the inverse observation model.

    Parameters
    ----------
    x0 : array_like, shape (3,)
        Initial pose ``[x, y, theta]``; the map starts empty.
    P0 : array_like, shape (3, 3)
        Its covariance (positive definite; for a pose known exactly, use a tiny
        variance such as 1e-12 rather than zero).
    Q, R : array_like, shape (2, 2)
        Covariances of the wheel speeds and (default) of a reading.
    wheel_base : float
        b (m).
    gate : float or None
        Probability of the chi-square gate (0.95); None accepts every reading
        of a mapped id (chapter 05 shows why that fails with misread ids).
    capacity : int
        Number of landmarks to make room for at the start (the storage doubles
        when more arrive).
    association : {"ids", "nn", "jcbb"}
        How readings find their landmark: by marker id (default), or without
        ids, ``update(None, z)``, by nearest neighbour or JCBB (chapter 09); a
        reading outside every gate is then added as a new landmark, named by
        the filter (0, 1, 2, ...).
    """

    _can_add = True

    def __init__(self, x0, P0, Q, R, wheel_base: float = KOBUKI_WHEEL_BASE,
                 gate: float | None = 0.95, capacity: int = 16, association: str = "ids"):
        if isinstance(capacity, (bool, np.bool_)) or not isinstance(
                capacity, (numbers.Integral, np.integer)) or capacity < 0:
            raise ValueError(f"capacity: expected a non-negative integer, got {capacity!r}")
        super().__init__(x0, P0, Q, R, wheel_base=wheel_base, gate=gate, capacity=capacity,
                         association=association)

    @property
    def landmark_ids(self) -> list[int]:
        """Marker ids in state order (a copy)."""
        return list(self._ids)

    @property
    def n_landmarks(self) -> int:
        """Number of landmarks in the state."""
        return len(self._ids)

    def landmark_index(self, marker_id: int) -> int:
        """Index of ``x_F`` of that marker in the state vector (``y_F`` is the next one)."""
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

    @property
    def landmarks(self) -> dict[int, np.ndarray]:
        """The estimated map: marker id -> ``[x_F, y_F]`` (copies)."""
        return {mid: self._x[s:s + 2].copy() for mid, s in self._slot.items()}

    def _lookup(self, marker_id: int):
        s = self._slot.get(marker_id)
        return None if s is None else (self._x[s:s + 2], s)


# --------------------------------------------------------------------------- linearisation points
#: Where each link of EKF SLAM's chain may be linearised (chapter 06): option -> allowed points.
LINKS = {"motion": ("estimate", "first", "truth"), "observation": ("estimate", "first", "truth"),
         "initialisation": ("estimate", "truth"), "innovation": ("estimate", "truth")}


class LinearisedEKFSLAM(EKFSLAM):
    """EKF SLAM with each link of its chain linearised at a point of your choice (ch. 06).

    EKF SLAM linearises four links, all at the current estimate. Each can be
    moved on its own, so that a chapter can change one thing and measure what
    it does (a one-factor ablation); the means always move with ``f`` and with
    the inverse observation ``g`` at the estimate, as in EKF SLAM.

    - **motion** ``A_k`` (and ``W_k``). ``"estimate"``: ``A`` from ``f(x_k|k) - x_k|k``, ``W``
      at ``x_k|k``; ``"first"``: ``A`` from the propagated poses ``x_k+1|k - x_k|k-1``, ``W`` at
      ``x_k|k``; ``"truth"``: ``A`` from the true poses ``p_k+1 - p_k``, ``W`` at the true heading.
    - **observation** ``H`` of a mapped landmark. ``"estimate"``: at the prior pose and the
      landmark's current estimate; ``"first"``: at ``x_k|k-1`` and the landmark's FIRST
      estimate (where it was put when mapped); ``"truth"``: at the true pose and landmark.
    - **initialisation** ``J1, J2`` of a new landmark. ``"estimate"``: at the updated pose and
      the reading, mean ``g(x, z)``; ``"truth"``: at the true pose and the true reading
      ``z_t = h(p_t, m_t)``, mean ``m_t + J1 (x - p_t) + J2 (z - z_t)``.
    - **innovation**, the predicted reading. ``"estimate"``: ``z - h(x)``; ``"truth"``:
      ``z - [h(p_t, m_t) + H_t (x - p_t) + H_t,m (m - m_t)]``, first order about the truth.

    The all-``"estimate"`` filter is :class:`EKFSLAM`, bit for bit;
    :class:`FEJEKFSLAM` is ``motion="first", observation="first"`` and
    :class:`IdealEKFSLAM` ``motion="truth", observation="truth"``. The
    ``"first"`` motion Jacobians chain: matrices of the form
    ``[[1, 0, a], [0, 1, b], [0, 0, 1]]`` multiply by adding their corners, so
    the product of FEJ's ``A`` over any interval is the ``A`` of the whole
    interval ``x_end|end-1 - x_start|start-1``, whatever the updates between.

    Parameters
    ----------
    x0, P0, Q, R, wheel_base, gate, capacity, association
        As for :class:`EKFSLAM`.
    motion, observation : {"estimate", "first", "truth"}
    initialisation, innovation : {"estimate", "truth"}
        The linearisation point of each link (table above).
    truth : callable ``t -> (3,)``, optional
        The true pose at time ``t`` (s), e.g. :func:`slamlib.runner.truth_function`;
        needed by any ``"truth"`` choice.
    landmarks : dict {int: (2,)}, optional
        The true map; needed by any ``"truth"`` choice. A reading or landmark
        whose id is not in it (a misread) is linearised at the estimate.
    t0 : float
        The time of ``x0``; each :meth:`predict` adds its ``dt`` (attribute ``t``).
    """

    def __init__(self, x0, P0, Q, R, *, motion: str = "estimate", observation: str = "estimate",
                 initialisation: str = "estimate", innovation: str = "estimate", truth=None,
                 landmarks=None, t0: float = 0.0, **kwargs):
        links = {"motion": motion, "observation": observation, "initialisation": initialisation,
                 "innovation": innovation}
        for name, value in links.items():
            if not isinstance(value, str) or value not in LINKS[name]:
                raise ValueError(f"{name}: expected one of {LINKS[name]}, got {value!r}")
        needs = [name for name, value in links.items() if value == "truth"]
        if needs and (not callable(truth) or landmarks is None):
            raise ValueError(f"truth, landmarks: {', '.join(needs)}='truth' needs truth (a "
                             f"callable t -> true pose (3,)) and landmarks (the true map "
                             f"{{id: (2,)}}), got truth={truth!r}, landmarks={landmarks!r}")
        t = as_finite_scalar("t0", t0)
        true_map = {} if landmarks is None else as_landmark_map(landmarks)
        super().__init__(x0, P0, Q, R, **kwargs)        # EKFSLAM's constructor
        self._links = links
        self._truth = truth
        self._true_map = true_map
        self.t = t
        self._propagated = self._x[:3].copy()     # x_{k|k-1}: the pose the last predict made
        self._first: dict[int, np.ndarray] = {}   # state slot -> first estimate of the landmark

    motion = property(lambda self: self._links["motion"], doc="Where ``A`` is linearised.")
    observation = property(lambda self: self._links["observation"],
                           doc="Where a mapped landmark's ``H`` is linearised.")
    initialisation = property(lambda self: self._links["initialisation"],
                              doc="Where a new landmark's ``J1, J2`` are linearised.")
    innovation = property(lambda self: self._links["innovation"],
                          doc="How the predicted reading of the innovation is formed.")

    @property
    def propagated_pose(self) -> np.ndarray:
        """``x_{k|k-1}``: the pose the latest prediction produced, before any update (a copy)."""
        return self._propagated.copy()

    def first_estimate(self, marker_id: int) -> np.ndarray:
        """Where the landmark was put when it was mapped (FEJ's linearisation point)."""
        return self._first[self.landmark_index(marker_id)].copy()

    def _true_pose(self, t: float) -> np.ndarray:
        return as_vector("truth(t)", self._truth(t), 3)

    # ------------------------------------------------------------------ motion
    def _fast_predict(self) -> bool:
        return (self.motion == "estimate"
                and getattr(self.motion_step, "__func__", None) is LinearisedEKFSLAM.motion_step
                and getattr(self._predict_cov, "__func__", None) is _EKFBase._predict_cov)

    def motion_step(self, pose, u, dt):
        """``f`` at the estimate; ``A`` (and ``W``) at the point of :attr:`motion`."""
        new, A, W = super().motion_step(pose, u, dt)
        if self.motion == "first":        # A from f(pose, u) - x_{k|k-1}: the chained Jacobian
            A[0, 2] = -(new[1] - self._propagated[1])
            A[1, 2] = new[0] - self._propagated[0]
        elif self.motion == "truth":      # A from the true poses, W at the true heading
            p0, p1 = self._true_pose(self.t), self._true_pose(self.t + dt)
            _, _, W = super().motion_step(p0, u, dt)
            A = np.array([[1.0, 0.0, -(p1[1] - p0[1])],
                          [0.0, 1.0, p1[0] - p0[0]],
                          [0.0, 0.0, 1.0]])
        return new, A, W

    def _predict(self, u, dt, Q=None) -> None:
        super()._predict(u, dt, Q)
        self._propagated = self._x[:3].copy()
        self.t += dt

    def _predict_block(self, u, dt, Q=None):
        if not self._fast_predict():
            return super()._predict_block(u, dt, Q)      # step by step, through _predict
        out = super()._predict_block(u, dt, Q)
        self._propagated = self._x[:3].copy()
        for d in dt.tolist():
            self.t += d
        return out

    # ------------------------------------------------------------------ initialisation
    def _initial_landmark(self, marker_id, z):
        """With ``initialisation="truth"``: ``J1, J2`` at the true pose and the true reading,
        the mean by the first-order expansion ``m_t + J1 (x - p_t) + J2 (z - z_t)``."""
        if self.initialisation != "truth" or marker_id not in self._true_map:
            return super()._initial_landmark(marker_id, z)
        pt, mt = self._true_pose(self.t), self._true_map[marker_id]
        zt = observe_landmarks(pt, mt[None, :])[0][0]
        J1, J2 = inverse_observation_jacobians(pt, zt)
        dp = self._x[:3] - pt
        dp[2] = wrap_angle(dp[2])
        dz = np.asarray(z, dtype=float) - zt
        dz[1] = wrap_angle(dz[1])
        return mt + J1 @ dp + J2 @ dz, J1, J2

    def _add_landmark(self, marker_id, z, R) -> None:
        super()._add_landmark(marker_id, z, R)
        s = self._slot[marker_id]
        self._first[s] = self._x[s:s + 2].copy()

    # ------------------------------------------------------------------ observation
    def _linearisation_jacobians(self, slots, Hp, Hl):
        """The readings' Jacobians at the point of :attr:`observation` (``Hp, Hl``: at the
        estimate, kept where that point is degenerate or the id not in the true map)."""
        if self.observation == "estimate":
            return Hp, Hl
        if self.observation == "first":     # at x_{k|k-1} and each landmark's first estimate
            known = np.ones(len(slots), dtype=bool)
            pose = self._propagated.copy()
            L = np.array([self._first[int(s)] for s in slots]).reshape(-1, 2)
        else:                               # at the true pose and the true landmarks
            ids = [self._ids[(int(s) - 3) // 2] for s in slots]
            known = np.array([i in self._true_map for i in ids], dtype=bool)
            pose = self._true_pose(self.t)
            L = np.array([self._true_map.get(i, np.zeros(2)) for i in ids]).reshape(-1, 2)
        _, Hp2, Hl2 = self.reading_model(pose, L)
        ok = known & np.all(np.isfinite(Hp2), axis=(1, 2)) & np.all(np.isfinite(Hl2), axis=(1, 2))
        return np.where(ok[:, None, None], Hp2, Hp), np.where(ok[:, None, None], Hl2, Hl)

    def _innovation_covs(self, slots, Hp, Hl, R):
        return super()._innovation_covs(slots, *self._linearisation_jacobians(slots, Hp, Hl), R)

    def _fuse(self, slots, Hp, Hl, y, R):
        return super()._fuse(slots, *self._linearisation_jacobians(slots, Hp, Hl), y, R)

    # ------------------------------------------------------------------ innovation
    def reading_model(self, pose, positions):
        """With ``innovation="truth"``: ``h`` linearised about the truth,
        ``h(p_t, m_t) + H_t (x - p_t) + H_t,m (m - m_t)`` (an ideal filter's prediction of a
        reading); the Jacobians returned are at the estimate (see :attr:`observation`)."""
        h, Hp, Hl = super().reading_model(pose, positions)
        if self.innovation != "truth" or positions.shape[0] == 0:
            return h, Hp, Hl
        L = self._x[3:self._n].reshape(-1, 2)
        pt = self._true_pose(self.t)
        for i, p in enumerate(positions):
            j = np.flatnonzero((L[:, 0] == p[0]) & (L[:, 1] == p[1]))
            mid = self._ids[int(j[0])] if j.size else None
            if mid is None or mid not in self._true_map or not np.isfinite(h[i, 1]):
                continue
            lt = self._true_map[mid]
            ht, Hpt, Hlt = super().reading_model(pt, lt[None, :])
            dp = pose - pt
            dp[2] = wrap_angle(dp[2])
            lin = ht[0] + Hpt[0] @ dp + Hlt[0] @ (p - lt)
            h[i] = [lin[0], wrap_angle(lin[1])]
        return h, Hp, Hl


class FEJEKFSLAM(LinearisedEKFSLAM):
    """EKF SLAM with First-Estimates Jacobians (Huang, Mourikis & Roumeliotis 2008/2010; ch. 06):
    ``LinearisedEKFSLAM(motion="first", observation="first")``, the same numbers.

    The same constructor, :meth:`update` and report as :class:`EKFSLAM`; the
    means move exactly as in EKF SLAM. ``A_k`` is built from the two latest
    *propagated* poses, ``x_{k+1|k} - x_{k|k-1}`` (EKF SLAM: ``x_{k+1|k} -
    x_{k|k}``), so the motion Jacobians chain through the updates, and each
    reading's Jacobians are evaluated at ``x_{k|k-1}`` and at its landmark's
    *first* estimate. With these the linearised system keeps the true system's
    unobservable directions (a translation in x and y, a rotation about the
    origin): chapter 06 derives it and measures it. A new landmark is
    initialised at the estimate, as in EKF SLAM; ``W`` stays at the estimate.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, motion="first", observation="first", **kwargs)


class IdealEKFSLAM(LinearisedEKFSLAM):
    """EKF SLAM linearised about the TRUE state: a diagnostic only a simulation can run (ch. 06).

    ``LinearisedEKFSLAM(motion="truth", observation="truth",
    initialisation=landmark_init, innovation=innovation)``, the same numbers.
    It is given the true trajectory and the true map; the means move with
    ``f`` and ``g`` at the estimate, as in EKF SLAM.

    - ``A_k`` from the true poses (so that the Jacobians chain exactly), ``W`` at
      the true heading; each reading's ``H_t`` at the true pose and landmark;
    - ``innovation="truth"`` (default): the predicted reading is the first-order
      expansion about the truth, ``y = z - h(x_t) - H_t (x - x_t)``: what a Kalman
      filter of the system linearised about the true trajectory sees.
      ``"estimate"``: EKF SLAM's ``z - h(x)``;
    - ``landmark_init="estimate"`` (default): a new landmark is placed and its
      covariance built with ``J1, J2`` at the *estimated* pose, as in EKF SLAM;
      ``"truth"``: at the true pose and reading.

    **Huang et al.'s ideal EKF** (2008) linearises every Jacobian at the truth,
    the initialisation's included, and keeps the innovation ``z - h(x)``:
    ``innovation="estimate", landmark_init="truth"`` (up to the new landmark's mean: here the
    first-order expansion about the truth, there ``g(x, z)``). The default here keeps the
    initialisation at the estimate, and so does ``innovation="estimate"`` alone:
    neither is Huang's filter. Chapter 06 measures each link on its own: the
    innovation at the estimate is harmless once the initialisation is at the
    truth; the initialisation's Jacobians at the estimate are what breaks the
    chain.

    Parameters
    ----------
    x0, P0, Q, R, wheel_base, gate, capacity, association
        As for :class:`EKFSLAM`.
    truth : callable ``t -> (3,)``
        The true pose at time ``t`` (s), e.g. :func:`slamlib.runner.truth_function`.
    landmarks : dict {int: (2,)}
        The true map. A reading of an id that is not in it (a misread) is
        linearised at the estimate, as in EKF SLAM.
    t0 : float
        The time of ``x0``; each :meth:`predict` adds its ``dt``.
    innovation : {"truth", "estimate"}
    landmark_init : {"estimate", "truth"}
    """

    def __init__(self, *args, truth, landmarks, t0: float = 0.0, innovation: str = "truth",
                 landmark_init: str = "estimate", **kwargs):
        if landmark_init not in LINKS["initialisation"]:
            raise ValueError(f"landmark_init: expected one of {LINKS['initialisation']}, got "
                             f"{landmark_init!r}")
        super().__init__(*args, motion="truth", observation="truth", initialisation=landmark_init,
                         innovation=innovation, truth=truth, landmarks=landmarks, t0=t0, **kwargs)

    @property
    def landmark_init(self) -> str:
        """Where a new landmark's initialisation is linearised (:attr:`initialisation`)."""
        return self.initialisation
