"""The report's equations as printed, and the checks that expose its errors.

The course implements the system of one report and corrects it. This module
transcribes the report's Jacobians and formulas *exactly as printed* (errors
included), so that chapters 01, 03, 04 and 05 and the errata appendix can put
them next to finite differences and to the library's corrected versions.

Each :class:`Erratum` names where the error is, what is printed, what is
right, and has a ``check()`` that returns the numerical evidence: a
:class:`~slamlib.checks.JacobianComparison` of the printed formula against
finite differences (it must fail), and of the library's formula (it must pass).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .checks import JacobianComparison, compare_jacobians, numerical_jacobian
from .models import (
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
    "Erratum", "ErratumEvidence", "ERRATA", "CORRECT_AS_PRINTED", "TextErratum", "TEXT_ERRATA",
    "CHECK_POSE", "CHECK_LANDMARK", "CHECK_Z",
]

#: The point at which the errata are checked: a generic pose and landmark (no
#: symmetry that could hide an error, e.g. dx != dy, theta not a multiple of pi/4).
CHECK_POSE = np.array([1.3, -0.4, 0.7])
CHECK_LANDMARK = np.array([3.1, 0.9])
CHECK_Z = observe(CHECK_POSE, CHECK_LANDMARK)


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
    """Report V.B, J2 = [d/d rho  d/d theta]^T as printed: the transpose puts the
    derivatives in rows instead of columns."""
    rho, a = z[0], z[1] + pose[2]
    d_rho = np.array([np.cos(a), np.sin(a)])
    sb, cb, sn, cn = np.sin(z[1]), np.cos(z[1]), np.sin(pose[2]), np.cos(pose[2])
    d_theta = np.array([-rho * np.sin(a), -rho * sb * sn + rho * cb * cn])
    return np.column_stack([d_rho, d_theta]).T


# --------------------------------------------------------------------------- section V.C
def printed_innovation(z, z_pred):
    """Report V.C eq. (1), y = z - h(x), without wrapping the bearing."""
    return np.asarray(z, float) - np.asarray(z_pred, float)


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
    """One error of the report."""

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
            "J2 = [d/d rho, d/d theta]^T (derivatives as rows)",
            "J2 = [d/d rho, d/d theta] (derivatives as columns)", _check_J2),
    Erratum("Mahalanobis distance", "V.C eq. (6)", "05", "formula",
            "D^2 = (y - h)^T S^-1 (y - h) with y = z - h already",
            "D^2 = y^T S^-1 y", _check_mahalanobis),
    Erratum("unwrapped innovation", "V.C eq. (1)", "05", "omission",
            "y = z - h(x) for the bearing too",
            "the bearing component of y wrapped to [-pi, pi)", _check_wrap),
)

#: Checked and found right (shown in the appendix for completeness).
CORRECT_AS_PRINTED: tuple[Erratum, ...] = (
    Erratum("A_k", "III.C", "01", "correct", "A_k", "A_k (derivative w.r.t. x_{k-1})", _check_A),
    Erratum("W_k", "III.C", "01", "correct", "W_k", "W_k", _check_W),
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
    TextErratum("V.A", "03", "z_k = [rho, theta] described with an elevation angle phi and a "
                "feature coordinate z_f",
                "the observation and the feature are planar: z = [rho, beta], x_F = [x_F, y_F]"),
    TextErratum("V.B", "04", "x_B (+) p = [x_B, y_B, 1]^T + R [x, y, 1]^T",
                "in homogeneous form x_B (+) p = T [x, y, 1]^T with T = [[R, t], [0, 1]]; "
                "the sum as printed gives 2 in the third component"),
    TextErratum("V.C eq. (5)", "05", "P_k = (I - K_k H_k) P_{k|k-1}",
                "right in exact arithmetic, but it loses symmetry and positive definiteness "
                "to rounding; the Joseph form (I-KH) P (I-KH)^T + K R K^T, or P - K S K^T "
                "symmetrised, keeps them"),
)
