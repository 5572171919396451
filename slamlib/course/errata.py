"""The report's errata: its equations as printed, and the checks that expose its errors.

The course implements the system of one report and corrects it. This module
transcribes the report's Jacobians and formulas *exactly as printed* (errors
included), so that chapters 01, 03, 04 and 05 and the errata appendix can put
them next to finite differences and to the library's corrected versions.

Each :class:`Erratum` names where the error is, what is printed, what is
right, and has a ``check()`` that returns the numerical evidence: a
:class:`~slamlib.checks.JacobianComparison` of the printed formula against
finite differences (it must fail), and of the library's formula (it must pass).

Four tables:

- :data:`ERRATA`: the numerical errors, each exposed by a failing check (seven
  errors in seven entries; the sign error of ``dbeta/dy_B`` is printed twice, in
  the first and the third entry);
- :data:`SCOPE_NOTES`: formulas right within the scope the report declares
  (V.B: "this section will only focus on a single feature"), which the course
  generalises to a state that already holds landmarks; their checks pass in
  that scope, and the library's general form passes against finite differences;
- :data:`CORRECT_AS_PRINTED`: formulas checked and found right;
- :data:`TEXT_ERRATA`: errors of notation that no number can exercise, and one
  claim about the results.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..checks import JacobianComparison, compare_jacobians, numerical_jacobian
from ..models import (
    inverse_observation_jacobians,
    inverse_observe,
    motion_jacobians,
    motion_model,
    observation_jacobians,
    observe,
    wrap_angle,
)

__all__ = [
    "printed_A", "printed_W", "printed_H_pose", "printed_H_landmark", "printed_H_pose_slam",
    "printed_J1", "printed_J2", "printed_innovation", "printed_mahalanobis2",
    "printed_g", "printed_covariance_update", "REPORT_SCOPE",
    "Erratum", "ErratumEvidence", "ERRATA", "SCOPE_NOTES", "CORRECT_AS_PRINTED", "TextErratum",
    "TEXT_ERRATA",
    "CHECK_POSE", "CHECK_LANDMARK", "CHECK_Z", "CHECK_NEW_LANDMARK",
]

#: The point at which the errata are checked: a generic pose and landmark (no
#: symmetry that could hide an error, e.g. dx != dy, theta not a multiple of pi/4).
CHECK_POSE = np.array([1.3, -0.4, 0.7])
CHECK_LANDMARK = np.array([3.1, 0.9])
CHECK_Z = observe(CHECK_POSE, CHECK_LANDMARK)
#: A second marker, added to a state that already holds CHECK_LANDMARK (the errata of g and G1).
CHECK_NEW_LANDMARK = np.array([2.2, -1.7])


# --------------------------------------------------------------------------- section III.C
def printed_A(x, u, dt, b):
    """Report III.C, A_k as printed (correct, but labelled d f / d x_k)."""
    v = 0.5 * (u[0] + u[1])
    th = x[2]
    return np.array([[1, 0, -v * np.sin(th) * dt], [0, 1, v * np.cos(th) * dt], [0, 0, 1.0]])


def printed_W(x, u, dt, b):
    """Report III.C, W_k as printed, columns [V_R noise, V_L noise] (correct)."""
    c, s = np.cos(x[2]), np.sin(x[2])
    return np.array([[0.5 * c * dt, 0.5 * c * dt], [0.5 * s * dt, 0.5 * s * dt],
                     [-dt / b, dt / b]])


# --------------------------------------------------------------------------- section V.A
def _d(pose, lm):
    dx, dy = lm[0] - pose[0], lm[1] - pose[1]
    q = dx * dx + dy * dy
    return dx, dy, q, np.sqrt(q)


def printed_H_pose(pose, lm):
    """Report V.A, first H = dh/dx_B as printed: entry [1,1] is +dx/q (sign error)."""
    dx, dy, q, r = _d(pose, lm)
    return np.array([[-dx / r, -dy / r, 0.0], [dy / q, dx / q, -1.0]])


def printed_H_landmark(pose, lm):
    """Report V.A, dh/dx_marker as printed: entry [1,0] is +dy/q (sign error)."""
    dx, dy, q, r = _d(pose, lm)
    return np.array([[dx / r, dy / r], [dy / q, dx / q]])


def printed_H_pose_slam(pose, lm):
    """Report V.A ('for slam'), dh/dx_B printed a second time: [1,0] is dy/sqrt(q)
    (typo) and [1,1] is +dx/q (the same sign error)."""
    dx, dy, q, r = _d(pose, lm)
    return np.array([[-dx / r, -dy / r, 0.0], [dy / r, dx / q, -1.0]])


# --------------------------------------------------------------------------- section V.B
def printed_J1(pose, z):
    """Report V.B, J1 as printed: entry [1,2] has the robot's ^N x where ^B x belongs (typo)."""
    bx, by = z[0] * np.cos(z[1]), z[0] * np.sin(z[1])
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.array([[1.0, 0.0, -bx * s - by * c], [0.0, 1.0, pose[0] * c - by * s]])


def printed_J2(pose, z):
    """Report V.B, J2 = [d/d rho  d/d ^B theta]^T as printed (^B theta: the bearing beta):
    the transpose puts the derivatives in rows instead of columns."""
    rho, a = z[0], z[1] + pose[2]
    d_rho = np.array([np.cos(a), np.sin(a)])
    sb, cb, sn, cn = np.sin(z[1]), np.cos(z[1]), np.sin(pose[2]), np.cos(pose[2])
    d_theta = np.array([-rho * np.sin(a), -rho * sb * sn + rho * cb * cn])
    return np.column_stack([d_rho, d_theta]).T


#: The sentence of section V.B that declares its scope (quoted from the report).
REPORT_SCOPE = "It is important to note that this section will only focus on a single feature."


def printed_g(x, z):
    """Report V.B, the state after adding a landmark as printed: ``[x_B; x_B (+) z_f]``.

    Right for the report's declared scope (:data:`REPORT_SCOPE`: the state is the
    robot's pose ``x_B`` alone). Given a state ``[x_B, x_F1, ...]`` that already holds
    landmarks, the formula as printed keeps only ``x_B`` and appends the new landmark.
    """
    x = np.asarray(x, float)
    return np.concatenate([x[:3], inverse_observe(x[:3], z)])


# --------------------------------------------------------------------------- section V.C
def printed_innovation(z, z_pred):
    """Report V.C eq. (1), y = z - h(x), without wrapping the bearing."""
    return np.asarray(z, float) - np.asarray(z_pred, float)


def printed_covariance_update(P, H, R):
    """Report V.C eq. (5), ``P_k = (I - K_k H_k) P_{k|k-1}`` with ``K = P H^T S^-1``."""
    P, H = np.asarray(P, float), np.asarray(H, float)
    S = H @ P @ H.T + np.asarray(R, float)
    K = P @ H.T @ np.linalg.inv(S)
    return (np.eye(P.shape[0]) - K @ H) @ P


def printed_mahalanobis2(y, z_pred, S):
    """Report V.C eq. (6) squared as printed: (y - h)^T S^-1 (y - h), though y is
    already the innovation z - h, so h is subtracted twice."""
    e = np.asarray(y, float) - np.asarray(z_pred, float)
    return float(e @ np.linalg.solve(S, e))


# --------------------------------------------------------------------------- the errata
@dataclass
class ErratumEvidence:
    """What a check found: the printed formula and the library's, each against a reference."""

    printed: JacobianComparison
    library: JacobianComparison

    @property
    def exposed(self) -> bool:
        """True when the printed formula fails and the library's passes."""
        return (not self.printed.ok) and self.library.ok


@dataclass(frozen=True)
class Erratum:
    """One error of the report.

    ``chapter`` is the chapter that shows it where it happens (``"03"``...), or
    ``"A"`` for an error shown only in the errata appendix.
    """

    key: str
    section: str
    chapter: str
    kind: str
    printed: str
    corrected: str
    check: Callable[[], ErratumEvidence]


def _fd_pose(f, pose, lm, angle_outputs=(1,)):
    return numerical_jacobian(lambda p: f(p, lm), pose, angle_outputs=angle_outputs)


def _check_H_pose(printed):
    def check():
        fd = _fd_pose(observe, CHECK_POSE, CHECK_LANDMARK)
        return ErratumEvidence(
            compare_jacobians("printed H_pose", printed(CHECK_POSE, CHECK_LANDMARK), fd),
            compare_jacobians("H_pose", observation_jacobians(CHECK_POSE, CHECK_LANDMARK)[0], fd))
    return check


def _check_H_landmark():
    fd = numerical_jacobian(lambda m: observe(CHECK_POSE, m), CHECK_LANDMARK, angle_outputs=[1])
    return ErratumEvidence(
        compare_jacobians("printed H_landmark", printed_H_landmark(CHECK_POSE, CHECK_LANDMARK), fd),
        compare_jacobians("H_landmark", observation_jacobians(CHECK_POSE, CHECK_LANDMARK)[1], fd))


def _check_J1():
    fd = numerical_jacobian(lambda p: inverse_observe(p, CHECK_Z), CHECK_POSE)
    return ErratumEvidence(
        compare_jacobians("printed J1", printed_J1(CHECK_POSE, CHECK_Z), fd),
        compare_jacobians("J1", inverse_observation_jacobians(CHECK_POSE, CHECK_Z)[0], fd))


def _check_J2():
    fd = numerical_jacobian(lambda q: inverse_observe(CHECK_POSE, q), CHECK_Z)
    return ErratumEvidence(
        compare_jacobians("printed J2", printed_J2(CHECK_POSE, CHECK_Z), fd),
        compare_jacobians("J2", inverse_observation_jacobians(CHECK_POSE, CHECK_Z)[1], fd))


_S_CHECK = np.diag([0.05**2, np.radians(3.0) ** 2])


def _check_mahalanobis():
    # A perfect reading (z equal to the prediction) must have distance 0.
    z_pred = CHECK_Z
    y = z_pred - z_pred
    got = np.array([[printed_mahalanobis2(y, z_pred, _S_CHECK)]])
    ours = np.array([[float(y @ np.linalg.solve(_S_CHECK, y))]])
    return ErratumEvidence(compare_jacobians("printed D^2 of a perfect reading", got, [[0.0]]),
                           compare_jacobians("D^2 of a perfect reading", ours, [[0.0]]))


def _check_wrap():
    # Prediction and reading 0.02 rad apart across the +-pi seam: the distance must be small.
    z_pred = np.array([2.0, np.pi - 0.01])
    z = np.array([2.0, -np.pi + 0.01])
    y_printed = printed_innovation(z, z_pred)
    y = np.array([z[0] - z_pred[0], wrap_angle(z[1] - z_pred[1])])
    expected = np.array([[0.0, 0.02]])
    return ErratumEvidence(compare_jacobians("printed innovation", y_printed[None, :], expected),
                           compare_jacobians("wrapped innovation", y[None, :], expected))


def _check_J2_column(j):
    # One column of the printed J2 (a row of the printed matrix, i.e. once un-transposed).
    def check():
        fd = numerical_jacobian(lambda q: inverse_observe(CHECK_POSE, q), CHECK_Z)[:, [j]]
        what = ("d rho", "d theta")[j]
        return ErratumEvidence(
            compare_jacobians(f"printed dg/{what}", printed_J2(CHECK_POSE, CHECK_Z)[[j]].T, fd),
            compare_jacobians(f"J2[:, {j}]",
                              inverse_observation_jacobians(CHECK_POSE, CHECK_Z)[1][:, [j]], fd))
    return check


def _slam_with_two_landmarks():
    """The library's EKFSLAM at CHECK_POSE: add CHECK_LANDMARK, then CHECK_NEW_LANDMARK.

    Returns the state and covariance before and after the second landmark, and its reading.
    """
    from ..ekf import EKFSLAM

    P0 = np.diag([0.01, 0.02, 0.003])
    R = np.diag([0.05**2, np.radians(3.0) ** 2])
    f = EKFSLAM(CHECK_POSE, P0, np.eye(2) * 1e-4, R, gate=None)
    f.update([1], [CHECK_Z])
    x0, P_before = f.x, f.P
    z_new = observe(CHECK_POSE, CHECK_NEW_LANDMARK)
    f.update([2], [z_new])
    return x0, P_before, f.x, f.P, z_new, R


def _true_g(x, z):
    """The augmentation: the whole state, then the new landmark from the pose and reading."""
    x = np.asarray(x, float)
    return np.concatenate([x, inverse_observe(x[:3], z)])


def _check_g():
    # In the report's scope (the state is the pose alone) the printed g is the augmentation;
    # the library's general form (landmarks already in the state are kept) is EKFSLAM's.
    x0, _, x1, _, z_new, _ = _slam_with_two_landmarks()
    pose = x0[:3]
    return ErratumEvidence(
        compare_jacobians("printed g(x_B, z), robot-only state", printed_g(pose, z_new)[None, :],
                          _true_g(pose, z_new)[None, :]),
        compare_jacobians("EKFSLAM state after adding a second landmark", x1[None, :],
                          _true_g(x0, z_new)[None, :]))


def _check_G1():
    # [I; J1] (J1 without its typo, its own erratum) is dg/dx for a robot-only state: 5 x 3.
    # With n landmarks the course's G1 is (5+2n) x (3+2n); EKFSLAM's covariance after the
    # augmentation equals G1 P G1^T + G2 R G2^T with both Jacobians from finite differences.
    x0, P, _, P1, z_new, R = _slam_with_two_landmarks()
    pose = x0[:3]
    G1_scope = numerical_jacobian(lambda p: _true_g(p, z_new), pose)            # (5, 3)
    J1 = inverse_observation_jacobians(pose, z_new)[0]
    G1 = numerical_jacobian(lambda x: _true_g(x, z_new), x0)                    # (7, 5)
    G2 = numerical_jacobian(lambda q: _true_g(x0, q), z_new)                    # (7, 2)
    ref = G1 @ P @ G1.T + G2 @ R @ G2.T
    return ErratumEvidence(
        compare_jacobians("[I; J1], robot-only state", np.vstack([np.eye(3), J1]), G1_scope),
        compare_jacobians("EKFSLAM covariance after the update", P1, ref, atol=1e-9))


def _check_covariance_update():
    # Eq. (5) against the Joseph form (I-KH) P (I-KH)^T + K R K^T, which equals it in exact
    # arithmetic; and the library's map-based EKF after one update from the same prior.
    from ..ekf import EKFLocalization

    P0 = np.array([[0.02, 0.004, -0.001], [0.004, 0.03, 0.002], [-0.001, 0.002, 0.004]])
    R = np.diag([0.05**2, np.radians(3.0) ** 2])
    H = observation_jacobians(CHECK_POSE, CHECK_LANDMARK)[0]
    S = H @ P0 @ H.T + R
    K = P0 @ H.T @ np.linalg.inv(S)
    IKH = np.eye(3) - K @ H
    joseph = IKH @ P0 @ IKH.T + K @ R @ K.T
    f = EKFLocalization(CHECK_POSE, P0, np.eye(2) * 1e-4, R, {1: CHECK_LANDMARK}, gate=None)
    f.update([1], [CHECK_Z])
    return ErratumEvidence(
        compare_jacobians("printed (I - K H) P", printed_covariance_update(P0, H, R), joseph,
                          atol=1e-12),
        compare_jacobians("EKFLocalization's P after the update", f.P, joseph, atol=1e-12))


def _check_A():
    x, u, dt, b = CHECK_POSE, np.array([0.3, 0.2]), 0.1, 0.23
    fd = numerical_jacobian(lambda s: motion_model(s, u, dt, b), x, angle_outputs=[2])
    return ErratumEvidence(compare_jacobians("printed A_k", printed_A(x, u, dt, b), fd),
                           compare_jacobians("A", motion_jacobians(x, u, dt, b)[0], fd))


def _check_W():
    x, u, dt, b = CHECK_POSE, np.array([0.3, 0.2]), 0.1, 0.23
    fd = numerical_jacobian(lambda n: motion_model(x, u + n, dt, b), np.zeros(2),
                            angle_outputs=[2])
    return ErratumEvidence(compare_jacobians("printed W_k", printed_W(x, u, dt, b), fd),
                           compare_jacobians("W", motion_jacobians(x, u, dt, b)[1], fd))


ERRATA: tuple[Erratum, ...] = (
    Erratum("H_pose sign", "V.A", "03", "sign error",
            "dh/dx_B[1,1] = +dx/(dx^2+dy^2)", "dh/dx_B[1,1] = -dx/(dx^2+dy^2)",
            _check_H_pose(printed_H_pose)),
    Erratum("H_landmark sign", "V.A", "03", "sign error",
            "dh/dx_marker[1,0] = +dy/(dx^2+dy^2)", "dh/dx_marker[1,0] = -dy/(dx^2+dy^2)",
            _check_H_landmark),
    Erratum("H_pose (SLAM) sign and typo", "V.A", "03", "sign error and typo",
            "second dh/dx_B: [1,0] = dy/sqrt(dx^2+dy^2), [1,1] = +dx/(dx^2+dy^2)",
            "[1,0] = dy/(dx^2+dy^2), [1,1] = -dx/(dx^2+dy^2)",
            _check_H_pose(printed_H_pose_slam)),
    Erratum("J1 typo", "V.B", "04", "typo",
            "J1[1,2] = ^N x cos(theta) - ^B y sin(theta)",
            "J1[1,2] = ^B x cos(theta) - ^B y sin(theta)", _check_J1),
    Erratum("J2 transposed", "V.B", "04", "layout",
            "J2 = [d/d rho, d/d ^B theta]^T (derivatives as rows; ^B theta is the bearing beta)",
            "J2 = [d/d rho, d/d beta] (derivatives as columns)", _check_J2),
    Erratum("Mahalanobis distance", "V.C eq. (6)", "05", "formula",
            "D^2 = (y - h)^T S^-1 (y - h) with y = z - h already",
            "D^2 = y^T S^-1 y", _check_mahalanobis),
    Erratum("unwrapped innovation", "V.C eq. (1)", "05", "omission",
            "y = z - h(x) for the bearing too",
            "the bearing component of y wrapped to [-pi, pi)", _check_wrap),
)

#: Right in the scope the report declares (:data:`REPORT_SCOPE`), generalised by the course:
#: a state that already holds landmarks. Not errors: both checks pass.
SCOPE_NOTES: tuple[Erratum, ...] = (
    Erratum("g for a robot-only state", "V.B", "A", "scope",
            "x^+ = g(x, z, v) = [x_B; x_B (+) (z_f + v)]",
            "with landmarks already in the state: x^+ = [x; x_B (+) z_f], the whole state "
            "(robot AND landmarks), then the new landmark", _check_g),
    Erratum("G1 for a robot-only state", "V.B", "A", "scope",
            "G1 = dg/dx = [I; J1] (I 3x3: 5x3)",
            "with n landmarks in the state, G1 = [[I_(3+2n)], [J1, 0]] of size (5+2n) x (3+2n), "
            "and P^+ = G1 P G1^T + G2 R G2^T with G2 = [0; J2]", _check_G1),
)

#: Checked and found right (shown in the appendix for completeness).
CORRECT_AS_PRINTED: tuple[Erratum, ...] = (
    Erratum("A_k", "III.C", "01", "correct", "A_k", "A_k (derivative w.r.t. x_{k-1})", _check_A),
    Erratum("W_k", "III.C", "01", "correct", "W_k", "W_k", _check_W),
    Erratum("dg/d rho", "V.B", "04", "correct", "d(x_B (+) z_f)/d rho",
            "the first column of J2", _check_J2_column(0)),
    Erratum("dg/d theta", "V.B", "04", "correct",
            "d(x_B (+) z_f)/d theta (printed as a column: right once J2 is un-transposed)",
            "the second column of J2", _check_J2_column(1)),
    Erratum("covariance update", "V.C eq. (5)", "05", "correct",
            "P_k = (I - K_k H_k) P_{k|k-1}",
            "right: in exact arithmetic it equals the Joseph form; in floating point "
            "(I - K H) P is not exactly symmetric, so the library computes P - K S K^T in a "
            "form that is symmetric by construction (chapter 05)", _check_covariance_update),
)


@dataclass(frozen=True)
class TextErratum:
    """An error of notation that no number can exercise (a symbol, a label, a form)."""

    section: str
    chapter: str
    printed: str
    corrected: str


TEXT_ERRATA: tuple[TextErratum, ...] = (
    TextErratum("III.B", "01", "w = (V_L - V_R) / h",
                "w = (V_L - V_R) / b: h is not defined; b is the wheel base"),
    TextErratum("III.C", "01", "A_k = d f / d x_k",
                "A_k = d f / d x_{k-1}: the derivative is taken at the previous pose"),
    TextErratum("V.A", "03", "'z_k is defined as the vector [rho theta]^T, where rho, theta, "
                "and phi are the range, bearing, and elevation angle'; the feature "
                "[x_f y_f]^T with 'x_f, y_f, and z_f ... the feature's position'",
                "the observation and the feature are planar: z = [rho, beta], x_F = [x_F, y_F]; "
                "no elevation phi, no z_f"),
    TextErratum("V.B", "04", "x_B (+) p = [x_B, y_B, 1]^T + R [x, y, 1]^T",
                "in homogeneous form x_B (+) p = T [x, y, 1]^T with T = [[R, t], [0, 1]]; "
                "the sum as printed gives 2 in the third component"),
    TextErratum("V.B", "04", "x_B (+) (z_f + v_k), z_f 'the feature position in the robot "
                "frame' (cartesian) and v_k 'the measurement noise', with G2 = dg/dv_k "
                "computed as J2 = d/d(rho, theta)",
                "v is the noise of the polar reading (range, bearing): x_B (+) p(z + v), p the "
                "polar-to-cartesian map, as the report's own J2 = d/d(rho, theta) has it"),
    TextErratum("II.A-C", "00", "x ~ N(x, P): one symbol for the random state and its mean",
                "x ~ N(x_hat, P): the estimate x_hat is the mean of the distribution of the "
                "true state x"),
    TextErratum("V.A, V.B", "03, 04", "theta for the robot's heading (^N theta_B) and for the "
                "reading's bearing (^B theta), both written theta in J1 and J2",
                "two symbols, e.g. theta for the heading and beta for the bearing: the landmark "
                "direction in N is theta + beta"),
    TextErratum("V.C", "05", "accept when D^2 < X^2_ij, the threshold left unspecified",
                "D^2 is chi-square with 2 degrees of freedom (one range-bearing reading): accept "
                "when D^2 < chi2_2(p) = -2 ln(1 - p) for a chosen probability p, e.g. 5.99 for "
                "p = 0.95"),
    TextErratum("VI.A, Figs. 6 and 8", "05, 06",
                "'the difference between the estimated pose and the ground truth remains "
                "within the bounds of 2 sigma. This indicates that the SLAM implementation "
                "effectively estimates the robot's position' (Fig. 8; Fig. 6 likewise), from "
                "one run",
                "one run cannot back it: within one run the errors are strongly correlated in "
                "time, so the fraction of the run inside the band says little (the course's "
                "recorded SLAM run has y outside it about a third of the time); whether the "
                "2-sigma band is right is tested by the NEES averaged over Monte-Carlo runs "
                "against its chi-square band (chapters 05 and 06)"),
)
