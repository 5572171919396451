"""The EKF SLAM equations as the chapters write them, one equation per line.

Plain functions on numpy arrays, no state, no speed-ups: the code a student
reads next to the derivation (and writes in the exercises), and the reference
the fast filters of :mod:`slamlib.ekf` are tested against
(``tests/test_ekf_textbook.py``). Each line carries the label of the equation
it is:

- prediction (chapter 01, section 4, on the SLAM state's blocks, chapter 05):
  ``[P1]`` to ``[P4]``;
- the joint update (report V.C, chapter 05, section 2): the report's numbers
  ``(1)`` to ``(5)``, with the bearing wrapped in (1) and the Joseph form in
  (5), the two corrections chapter 05 makes;
- the gate (report eq. (6), corrected, chapter 05): ``(6)``;
- augmentation with cross-covariances (chapter 04, section 5): ``[A1]`` to ``[A4]``.

The state is ``x = [x, y, theta, x_F1, y_F1, ...]`` (n = 3 + 2N) with
covariance ``P``; the robot block is ``P_rr = P[:3, :3]``, the robot-map strip
``P_rm = P[:3, 3:]`` and the map block ``P_mm = P[3:, 3:]``.
"""

from __future__ import annotations

import numpy as np

from .models import (
    KOBUKI_WHEEL_BASE,
    inverse_observation_jacobians,
    inverse_observe,
    motion_jacobians,
    motion_model,
    observation_jacobians,
    observe,
    wrap_angle,
)

__all__ = ["predict_covariance", "predict", "innovation", "stacked_jacobian", "block_diagonal",
           "joint_update", "augment", "update", "nees"]


def predict_covariance(P: np.ndarray, A: np.ndarray, W: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """The covariance prediction on the blocks of the SLAM state (chapters 01, 05).

    The dense form is ``P <- F P F^T + F_w Q F_w^T`` with ``F = blkdiag(A, I)``
    and ``F_w = [W; 0]``; multiplied out block by block it touches only the
    robot's rows and columns (the landmarks do not move).

    Parameters
    ----------
    P : numpy.ndarray, shape (n, n)
        The covariance before the step (n = 3 for localisation, 3 + 2N for SLAM).
    A, W : numpy.ndarray, shapes (3, 3), (3, 2)
        The motion Jacobians at the estimate (:func:`slamlib.models.motion_jacobians`).
    Q : numpy.ndarray, shape (2, 2)
        Covariance of the wheel speeds ``[V_R, V_L]``.

    Returns
    -------
    numpy.ndarray, shape (n, n)
        The predicted covariance (a new array; ``P`` is not changed).
    """
    P = np.asarray(P, dtype=float)
    P_rr, P_rm, P_mm = P[:3, :3], P[:3, 3:], P[3:, 3:]
    P_rr_new = A @ P_rr @ A.T + W @ Q @ W.T                 # [P1] robot block
    P_rm_new = A @ P_rm                                     # [P2] robot-map strip
    P_mr_new = P_rm_new.T                                   # [P3] its mirror, P symmetric
    P_mm_new = P_mm                                         # [P4] the map does not move
    P_new = np.block([[P_rr_new, P_rm_new], [P_mr_new, P_mm_new]])
    return 0.5 * (P_new + P_new.T)                          # exactly symmetric


def predict(x: np.ndarray, P: np.ndarray, u, dt: float, Q: np.ndarray,
            wheel_base: float = KOBUKI_WHEEL_BASE) -> tuple[np.ndarray, np.ndarray]:
    """One EKF prediction of the SLAM state with the wheel speeds ``u = [V_R, V_L]`` (chapter 01).

    ``x_B <- f(x_B, u)`` (the landmarks stay), ``P`` by :func:`predict_covariance`
    with ``A, W`` at the estimate before the step.

    Returns
    -------
    (x, P) : numpy.ndarray, shapes (n,), (n, n)
        New arrays; the inputs are not changed.
    """
    x = np.array(x, dtype=float)
    A, W = motion_jacobians(x[:3], u, dt, wheel_base)        # at the estimate before the step
    x[:3] = motion_model(x[:3], u, dt, wheel_base)           # x_k = f(x_{k-1}, u_k)
    return x, predict_covariance(P, A, W, Q)


def innovation(z: np.ndarray, z_pred: np.ndarray) -> np.ndarray:
    """``y = z - h(x)`` of m readings, bearings wrapped to [-pi, pi), stacked (report eq. (1)).

    Parameters
    ----------
    z, z_pred : numpy.ndarray, shape (m, 2)
        Readings ``[range, bearing]`` and their predictions ``h``.

    Returns
    -------
    numpy.ndarray, shape (2m,)
        ``[rho_1 - h_1, wrap(beta_1 - h_1), rho_2 - h_2, ...]``.
    """
    y = np.asarray(z, dtype=float).reshape(-1, 2) - np.asarray(z_pred, dtype=float).reshape(-1, 2)
    y[:, 1] = wrap_angle(y[:, 1])                           # the report's eq. (1) forgets this
    return y.reshape(-1)


def stacked_jacobian(n: int, slots, H_pose, H_landmark) -> np.ndarray:
    """The stacked observation Jacobian ``H`` (2m x n) of m readings (chapters 03, 05).

    Reading j's two rows hold ``H_pose[j]`` in the robot's columns 0-2 and
    ``H_landmark[j]`` in its landmark's columns ``slots[j], slots[j] + 1``; zeros
    elsewhere. A slot of -1 is a landmark of a known map (chapter 03): no
    landmark columns.

    Parameters
    ----------
    n : int
        Length of the state.
    slots : sequence of int, length m
        Index of each reading's ``x_F`` in the state, or -1.
    H_pose, H_landmark : numpy.ndarray, shapes (m, 2, 3), (m, 2, 2)
        Each reading's Jacobians (:func:`slamlib.models.observation_jacobians`).
    """
    m = len(slots)
    H = np.zeros((2 * m, n))
    for j, s in enumerate(slots):
        H[2 * j:2 * j + 2, :3] = H_pose[j]                  # d h_j / d x_B
        if s >= 0:
            H[2 * j:2 * j + 2, s:s + 2] = H_landmark[j]     # d h_j / d x_Fj
    return H


def block_diagonal(R) -> np.ndarray:
    """The 2m x 2m block-diagonal noise of m readings from their 2x2 covariances ``R[j]``."""
    R = np.asarray(R, dtype=float).reshape(-1, 2, 2)
    out = np.zeros((2 * R.shape[0], 2 * R.shape[0]))
    for j in range(R.shape[0]):
        out[2 * j:2 * j + 2, 2 * j:2 * j + 2] = R[j]
    return out


def joint_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, z_pred: np.ndarray,
                 H: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One joint EKF update with m readings stacked (report V.C eqs. (1)-(5), chapter 05).

    Parameters
    ----------
    x : numpy.ndarray, shape (n,)
        The prior mean.
    P : numpy.ndarray, shape (n, n)
        The prior covariance.
    z, z_pred : numpy.ndarray, shape (m, 2)
        The readings ``[range, bearing]`` and their predictions ``h(x)``.
    H : numpy.ndarray, shape (2m, n)
        The stacked Jacobian of the predictions (:func:`stacked_jacobian`).
    R : numpy.ndarray, shape (2m, 2m)
        The readings' noise, block-diagonal (:func:`block_diagonal`).

    Returns
    -------
    (x, P) : numpy.ndarray, shapes (n,), (n, n)
        The posterior (new arrays), heading wrapped, ``P`` exactly symmetric.
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    I = np.eye(x.size)
    y = innovation(z, z_pred)                               # (1) y = z - h(x), bearings wrapped
    S = H @ P @ H.T + R                                     # (2) S = H P H^T + R
    K = P @ H.T @ np.linalg.inv(S)                          # (3) K = P H^T S^-1
    x_new = x + K @ y                                       # (4) x <- x + K y
    x_new[2] = wrap_angle(x_new[2])                         #     heading back to [-pi, pi)
    P_new = (I - K @ H) @ P @ (I - K @ H).T + K @ R @ K.T   # (5) Joseph form
    return x_new, 0.5 * (P_new + P_new.T)                   #     symmetric to the last bit


def augment(x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """Append a new landmark read as ``z = [rho, beta]`` to the state (chapter 04, section 5).

    ``m = g(x_B, z)``; with ``J1 = dg/dx_B``, ``J2 = dg/dz``::

        P_new = [[P,          P_Lx^T],
                 [P_Lx,       P_LL  ]],   P_Lx = J1 P_r,:,   P_LL = J1 P_rr J1^T + J2 R J2^T

    where ``P_r,:`` are the robot's three rows of ``P``: the new landmark is
    correlated with the robot and, through it, with every landmark already mapped.

    Parameters
    ----------
    x : numpy.ndarray, shape (n,)
    P : numpy.ndarray, shape (n, n)
    z : numpy.ndarray, shape (2,)
        The reading of the new marker.
    R : numpy.ndarray, shape (2, 2)
        Its noise covariance (polar: range, bearing).

    Returns
    -------
    (x, P) : numpy.ndarray, shapes (n + 2,), (n + 2, n + 2)
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    pose = x[:3]
    J1, J2 = inverse_observation_jacobians(pose, z)
    m = inverse_observe(pose, z)                            # [A1] m = x_B (+) p(z)
    P_Lx = J1 @ P[:3, :]                                    # [A2] cross-covariance, all columns
    P_LL = J1 @ P[:3, :3] @ J1.T + J2 @ R @ J2.T            # [A3] the new landmark's own block
    P_new = np.block([[P, P_Lx.T], [P_Lx, P_LL]])           # [A4] the old P is untouched
    return np.concatenate([x, m]), 0.5 * (P_new + P_new.T)


def update(x: np.ndarray, P: np.ndarray, index: dict, ids, z, R, threshold: float = np.inf, *,
           stacked_jacobian=stacked_jacobian, joint_update=joint_update, augment=augment
           ) -> tuple[np.ndarray, np.ndarray, dict, np.ndarray]:
    """The whole update of one camera frame, as :meth:`slamlib.ekf.EKFSLAM.update` (chapter 05).

    Each reading of an id in ``index`` is gated on its own against the prior
    (eq. (6), squared Mahalanobis distance below ``threshold``); the accepted
    ones are fused in one :func:`joint_update`; then the ids never seen before
    are appended by :func:`augment` from the updated pose, in the order given
    (an id read twice is added once, from its first reading; its second reading
    is not used).

    Parameters
    ----------
    x, P : numpy.ndarray
        The prior state and covariance.
    index : dict {int: int}
        Marker id -> index of its ``x_F`` in the state (not changed).
    ids : sequence of int, length k
    z : numpy.ndarray, shape (k, 2)
    R : numpy.ndarray, shape (2, 2) or (k, 2, 2)
    threshold : float
        The gate ``chi2.ppf(gate, 2)``; ``inf`` accepts every reading.
    stacked_jacobian, joint_update, augment : callable, optional
        The three steps (this module's by default); chapter 05 passes the
        student's own to drive the recorded run with them.

    Returns
    -------
    (x, P, index, accepted)
        The posterior, the new id -> index map and which readings were fused.
    """
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    R = np.broadcast_to(np.asarray(R, dtype=float), (len(z), 2, 2))
    accepted = np.zeros(len(z), dtype=bool)
    rows, slots, z_pred, Hp, Hl = [], [], [], [], []
    for i, mid in enumerate(ids):
        if int(mid) not in index:
            continue
        s = index[int(mid)]
        h = observe(x[:3], x[s:s + 2])
        H_pose, H_lm = observation_jacobians(x[:3], x[s:s + 2])
        H_i = stacked_jacobian(x.size, [s], np.array([H_pose]), np.array([H_lm]))
        y_i = innovation(z[i], h)
        S_i = H_i @ P @ H_i.T + R[i]
        d2 = y_i @ np.linalg.solve(S_i, y_i)                # (6) D^2 = y^T S^-1 y
        if d2 < threshold:
            accepted[i] = True
            rows.append(i)
            slots.append(s)
            z_pred.append(h)
            Hp.append(H_pose)
            Hl.append(H_lm)
    if rows:
        H = stacked_jacobian(x.size, slots, np.array(Hp), np.array(Hl))
        x, P = joint_update(x, P, z[rows], np.array(z_pred), H, block_diagonal(R[rows]))
    index = dict(index)
    for i, mid in enumerate(ids):
        if int(mid) not in index:
            index[int(mid)] = x.size
            x, P = augment(x, P, z[i], R[i])
    return x, P, index, accepted


def nees(x_est: np.ndarray, x_true: np.ndarray, P: np.ndarray) -> np.ndarray:
    """NEES ``e^T P^-1 e`` of each step of a trace, heading error wrapped (chapters 03, 06).

    Parameters
    ----------
    x_est, x_true : numpy.ndarray, shape (T, d)
        Estimates and truths (d = 3 for a pose; column 2 is the heading).
    P : numpy.ndarray, shape (T, d, d)
        The filter's covariances.

    Returns
    -------
    numpy.ndarray, shape (T,)
        For a consistent filter, chi-square with d degrees of freedom at each step.
    """
    e = np.asarray(x_est, dtype=float) - np.asarray(x_true, dtype=float)
    e[:, 2] = wrap_angle(e[:, 2])                           # an angle error is wrapped
    return np.einsum("ti,ti->t", e, np.linalg.solve(P, e[:, :, None])[:, :, 0])
