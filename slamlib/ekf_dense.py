"""The textbook EKF, written with full matrices: the reference for :mod:`slamlib.ekf`.

:class:`DenseEKFLocalization` and :class:`DenseEKFSLAM` have exactly the
semantics of :class:`slamlib.ekf.EKFLocalization` and
:class:`slamlib.ekf.EKFSLAM`: they *inherit* association, gating, the order of
fusion and augmentation, input checks, the report and the observation model
(the public hook ``reading_model``, so a variant that overrides it behaves the
same in both). Only the four
linear-algebra steps are replaced by the formulas as printed in the
textbooks (and in the report, section V.C), with matrices as large as the
state:

- prediction (chapter 01): ``F = blkdiag(A, I)``, ``F_w = [W; 0]``,
  ``P <- F P F^T + F_w Q F_w^T``, an O(n^3) product;
- gating (chapter 05): each reading's full ``H_i`` (2 x n),
  ``S_i = H_i P H_i^T + R_i``;
- the joint update (chapters 03, 05): the stacked ``H`` (2m x n),
  ``S = H P H^T + R``, ``K = P H^T S^-1``, ``x <- x + K y``,
  ``P <- (I - K H) P``, an O(n^3) product with an n x n identity;
- augmentation (chapter 04): ``G_x = [[I_n], [J1 0]]`` ((n+2) x n),
  ``G_z = [[0], [J2]]`` ((n+2) x 2), ``P <- G_x P G_x^T + G_z R G_z^T``.

They are meant to be read next to the derivations and used as the reference
in the tests (the structured filters must agree to 1e-9) and in
``bench/bench_ekf.py``, where their cost is shown to grow as n^3.

Why this module is not :mod:`slamlib.ekf_textbook`
--------------------------------------------------
Both are "the textbook EKF", on purpose in two different forms. The
functions of :mod:`slamlib.ekf_textbook` work on the *blocks* of the state
(``P_rr``, ``P_rm``; the Joseph form in the update) and carry their own
gating loop: they are what a chapter prints. This module keeps the
*semantics* of :mod:`slamlib.ekf` (it inherits ``update``) and replaces the
algebra by *full* matrices as large as the state (``F``, ``F_w``, ``G_x``,
``G_z``; ``(I - K H) P`` instead of the Joseph form), which is the form whose
cost the benchmark shows. The fast filters are tested against both, so a
mistake shared by one of them and :mod:`slamlib.ekf` would still be caught by
the other. What the two would otherwise write twice, the stacked Jacobian
``H`` and the block-diagonal ``R``, is taken from :mod:`slamlib.ekf_textbook`
(:func:`~slamlib.ekf_textbook.stacked_jacobian`,
:func:`~slamlib.ekf_textbook.block_diagonal`) and not copied.
"""

from __future__ import annotations

import numpy as np

from .ekf import EKFSLAM, EKFLocalization
from .ekf_textbook import block_diagonal, stacked_jacobian

__all__ = ["DenseEKFLocalization", "DenseEKFSLAM"]


def _symmetrise(P: np.ndarray) -> np.ndarray:
    # (I - K H) P is symmetric only in exact arithmetic; without this line the
    # round-off asymmetry accumulates over a long run.
    return 0.5 * (P + P.T)


class _DenseAlgebra:
    """The four linear-algebra steps of the EKF with full matrices (see the module docstring)."""

    def _full_H(self, slots, Hp, Hl) -> np.ndarray:
        """The stacked observation Jacobian H, shape (2m, n), zeros outside the blocks."""
        return stacked_jacobian(self._n, slots, Hp, Hl)

    def _predict_cov(self, A, W, Q=None) -> None:
        n = self._n
        F = np.eye(n)
        F[:3, :3] = A
        Fw = np.zeros((n, 2))
        Fw[:3, :] = W
        P = self._P[:n, :n]
        Q = self.Q if Q is None else Q
        self._P[:n, :n] = _symmetrise(F @ P @ F.T + Fw @ Q @ Fw.T)

    def _innovation_covs(self, slots, Hp, Hl, R) -> np.ndarray:
        n = self._n
        P = self._P[:n, :n]
        S = np.empty((len(slots), 2, 2))
        for j in range(len(slots)):
            Hj = self._full_H(slots[j:j + 1], Hp[j:j + 1], Hl[j:j + 1])
            S[j] = Hj @ P @ Hj.T + R[j]
        return 0.5 * (S + S.transpose(0, 2, 1))

    def _fuse(self, slots, Hp, Hl, y, R) -> float:
        n = self._n
        P = self._P[:n, :n].copy()
        H = self._full_H(slots, Hp, Hl)
        Rb = block_diagonal(R)
        yv = y.reshape(-1)
        S = H @ P @ H.T + Rb
        K = P @ H.T @ np.linalg.inv(S)
        self._x[:n] = self._x[:n] + K @ yv
        self._P[:n, :n] = _symmetrise((np.eye(n) - K @ H) @ P)
        return float(yv @ np.linalg.solve(S, yv))

    def _augment_cov(self, J1, J2, R) -> None:
        n = self._n
        Gx = np.zeros((n + 2, n))
        Gx[:n, :n] = np.eye(n)
        Gx[n:, :3] = J1
        Gz = np.zeros((n + 2, 2))
        Gz[n:, :] = J2
        P = self._P[:n, :n]
        self._P[:n + 2, :n + 2] = _symmetrise(Gx @ P @ Gx.T + Gz @ R @ Gz.T)


class DenseEKFLocalization(_DenseAlgebra, EKFLocalization):
    """:class:`slamlib.ekf.EKFLocalization` with the textbook dense algebra (same arguments)."""


class DenseEKFSLAM(_DenseAlgebra, EKFSLAM):
    """:class:`slamlib.ekf.EKFSLAM` with the textbook dense algebra (same arguments)."""
