"""The checkers of slamlib.course.filter_checkers: each named mistake gets its hint, a right
answer passes, a stub is "not written yet".

Every wrong function below is a mistake a student makes, written out as a student would write it
(not derived from the checker's own list), so a hint that stops matching its mistake fails here.
"""

import numpy as np
import pytest

from slamlib import metrics
from slamlib.course import filter_checkers as fc
from slamlib.models import inverse_observation_jacobians, inverse_observe, wrap_angle

NOTEBOOK_Q = np.diag([0.02, 0.02]) ** 2        # the wheel-speed noise a notebook defines as Q
NOTEBOOK_R = np.diag([0.05, 0.03]) ** 2


def verdict(check, fn, capsys):
    ok = check(fn)
    return ok, capsys.readouterr().out


def from_notebook(src: str, name: str):
    """A student's function defined in a notebook whose globals hold Q and R."""
    g = {"np": np, "Q": NOTEBOOK_Q, "R": NOTEBOOK_R, "wrap_angle": wrap_angle,
         "inverse_observe": inverse_observe,
         "inverse_observation_jacobians": inverse_observation_jacobians}
    exec(src, g)  # noqa: S102 - a test stands in for a notebook cell
    return g[name]


def stub(*args):
    return None


# --------------------------------------------------------------------------- prediction
def pred_right(P, A, W, Q):
    P = P.copy()
    P[:3, :3] = A @ P[:3, :3] @ A.T + W @ Q @ W.T
    P[:3, 3:] = A @ P[:3, 3:]
    P[3:, :3] = P[:3, 3:].T
    return P


def pred_no_cross(P, A, W, Q):
    P = P.copy()
    P[:3, :3] = A @ P[:3, :3] @ A.T + W @ Q @ W.T
    return P


def pred_zero_cross(P, A, W, Q):
    P = pred_right(P, A, W, Q)
    P[:3, 3:] = 0.0
    P[3:, :3] = 0.0
    return P


def pred_old_mirror(P, A, W, Q):
    out = pred_right(P, A, W, Q)
    out[3:, :3] = P[3:, :3]
    return out


def pred_no_noise(P, A, W, Q):
    out = pred_right(P, A, W, Q)
    out[:3, :3] = A @ P[:3, :3] @ A.T
    return out


def pred_A_transposed(P, A, W, Q):
    return pred_right(P, A.T, W, Q)


PRED_R_SRC = """
def pred_with_R(P, A, W, Q_arg):
    P = P.copy()
    P[:3, :3] = A @ P[:3, :3] @ A.T + W @ R @ W.T
    P[:3, 3:] = A @ P[:3, 3:]
    P[3:, :3] = P[:3, 3:].T
    return P
"""


def pred_map_moves(P, A, W, Q):
    out = pred_right(P, A, W, Q)
    out[3:, 3:] *= 1.01
    return out


@pytest.mark.parametrize("fn, words", [
    (pred_no_cross, "forgot to propagate the cross-covariance"),
    (pred_zero_cross, "the robot-map strip is zero"),
    (pred_old_mirror, "its mirror P_mr still has the old value"),
    (pred_no_noise, "W Q W^T is missing"),
    (pred_A_transposed, "A is transposed"),
    (from_notebook(PRED_R_SRC, "pred_with_R"), "notebook's R in place of the argument Q"),
    (pred_map_moves, "the landmarks do not move"),
])
def test_prediction_mistakes_are_named(fn, words, capsys):
    ok, out = verdict(fc.check_predict_covariance, fn, capsys)
    assert not ok and words in out, out


def test_prediction_right_answers_pass(capsys):
    for fn in (pred_right, fc._predict_covariance):     # the library's own step passes
        ok, out = verdict(fc.check_predict_covariance, fn, capsys)
        assert ok and "correct" in out, out
    ok, out = verdict(fc.check_predict_covariance, stub, capsys)
    assert not ok and "not written yet" in out


# --------------------------------------------------------------------------- stacked H
def H_right(n, slots, Hp, Hl):
    H = np.zeros((2 * len(slots), n))
    for j, s in enumerate(slots):
        H[2 * j:2 * j + 2, :3] = Hp[j]
        if s >= 0:
            H[2 * j:2 * j + 2, s:s + 2] = Hl[j]
    return H


def H_transposed(n, slots, Hp, Hl):
    return H_right(n, slots, Hp, Hl).T


def H_landmark_block_transposed(n, slots, Hp, Hl):
    return H_right(n, slots, Hp, np.transpose(Hl, (0, 2, 1)))


def H_one_off(n, slots, Hp, Hl):
    H = np.zeros((2 * len(slots), n))
    for j, s in enumerate(slots):
        H[2 * j:2 * j + 2, :3] = Hp[j]
        if s >= 0:
            c = 3 + 2 * ((s - 3) // 2 + 1)          # "3 + 2 * landmark number", counted from 1
            H[2 * j:2 * j + 2, c:c + 2] = Hl[j]
    return H


def H_pose_only(n, slots, Hp, Hl):
    H = np.zeros((2 * len(slots), n))
    for j in range(len(slots)):
        H[2 * j:2 * j + 2, :3] = Hp[j]
    return H


@pytest.mark.parametrize("fn, words", [
    (H_transposed, "your H is transposed"),
    (H_landmark_block_transposed, "the landmark block is transposed"),
    (H_one_off, "one landmark off"),
    (H_pose_only, "the landmark columns are missing"),
])
def test_stacked_jacobian_mistakes_are_named(fn, words, capsys):
    ok, out = verdict(fc.check_stacked_jacobian, fn, capsys)
    assert not ok and words in out, out


def test_stacked_jacobian_right_answers_pass(capsys):
    for fn in (H_right, fc._stacked_jacobian):
        ok, out = verdict(fc.check_stacked_jacobian, fn, capsys)
        assert ok, out
    assert not fc.check_stacked_jacobian(stub, verbose=False)


# --------------------------------------------------------------------------- joint update
def upd_right(x, P, z, z_pred, H, R):
    y = (z - z_pred).reshape(-1)
    y[1::2] = (y[1::2] + np.pi) % (2 * np.pi) - np.pi
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    x = x + K @ y
    x[2] = (x[2] + np.pi) % (2 * np.pi) - np.pi
    I_KH = np.eye(len(x)) - K @ H
    P = I_KH @ P @ I_KH.T + K @ R @ K.T
    return x, (P + P.T) / 2


def upd_short_form(x, P, z, z_pred, H, R):
    y = (z - z_pred).reshape(-1)
    y[1::2] = wrap_angle(y[1::2])
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    x = x + K @ y
    x[2] = wrap_angle(x[2])
    return x, (np.eye(len(x)) - K @ H) @ P


def upd_joseph_unsymmetrised(x, P, z, z_pred, H, R):
    xn, _ = upd_right(x, P, z, z_pred, H, R)
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    I_KH = np.eye(len(x)) - K @ H
    return xn, I_KH @ P @ I_KH.T + K @ R @ K.T


def upd_unwrapped(x, P, z, z_pred, H, R):
    y = (z - z_pred).reshape(-1)
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    x = x + K @ y
    x[2] = wrap_angle(x[2])
    I_KH = np.eye(len(x)) - K @ H
    P = I_KH @ P @ I_KH.T + K @ R @ K.T
    return x, (P + P.T) / 2


def upd_first_bearing_only(x, P, z, z_pred, H, R):
    # my_gate's wrap copied into the joint update: only y[1], the first reading's bearing
    y = (z - z_pred).reshape(-1)
    y[1] = wrap_angle(y[1])
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    x = x + K @ y
    x[2] = wrap_angle(x[2])
    I_KH = np.eye(len(x)) - K @ H
    P = I_KH @ P @ I_KH.T + K @ R @ K.T
    return x, (P + P.T) / 2


def upd_robot_block_only(x, P, z, z_pred, H, R):
    xn, Pn = upd_right(x, P, z, z_pred, H, R)
    Pn[3:, 3:] = P[3:, 3:]
    return xn, Pn


def upd_pose_mean_only(x, P, z, z_pred, H, R):
    xn, Pn = upd_right(x, P, z, z_pred, H, R)
    xn[3:] = x[3:]
    return xn, Pn


def upd_no_KRK(x, P, z, z_pred, H, R):
    xn, _ = upd_right(x, P, z, z_pred, H, R)
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    I_KH = np.eye(len(x)) - K @ H
    Pn = I_KH @ P @ I_KH.T
    return xn, (Pn + Pn.T) / 2


def upd_no_R_in_S(x, P, z, z_pred, H, R):
    y = (z - z_pred).reshape(-1)
    y[1::2] = wrap_angle(y[1::2])
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T)
    x = x + K @ y
    x[2] = wrap_angle(x[2])
    I_KH = np.eye(len(x)) - K @ H
    Pn = I_KH @ P @ I_KH.T + K @ R @ K.T
    return x, (Pn + Pn.T) / 2


def upd_heading_not_wrapped(x, P, z, z_pred, H, R):
    xn, Pn = upd_right(x, P, z, z_pred, H, R)
    y = (z - z_pred).reshape(-1)
    y[1::2] = wrap_angle(y[1::2])
    xn[2] = x[2] + (P @ H.T @ np.linalg.inv(H @ P @ H.T + R) @ y)[2]
    return xn, Pn


UPD_Q_SRC = """
def upd_with_Q(x, P, z, z_pred, H, R_arg):
    y = (z - z_pred).reshape(-1)
    y[1::2] = wrap_angle(y[1::2])
    S = H @ P @ H.T + Q
    K = P @ H.T @ np.linalg.inv(S)
    x = x + K @ y
    x[2] = wrap_angle(x[2])
    P = (np.eye(len(x)) - K @ H) @ P
    return x, 0.5 * (P + P.T)
"""


def upd_K_wrong_shape(x, P, z, z_pred, H, R):
    K = P @ H @ np.linalg.inv(H @ P @ H.T + R)     # H^T forgotten
    return x + K @ (z - z_pred).reshape(-1), P


def upd_gain_R_inverse(x, P, z, z_pred, H, R):
    y = (z - z_pred).reshape(-1)
    y[1::2] = wrap_angle(y[1::2])
    K = P @ H.T @ np.linalg.inv(R)                  # R^-1 where S^-1 belongs
    x = x + K @ y
    x[2] = wrap_angle(x[2])
    I_KH = np.eye(len(x)) - K @ H
    Pn = I_KH @ P @ I_KH.T + K @ R @ K.T
    return x, (Pn + Pn.T) / 2


def upd_gain_R_inverse_short_form(x, P, z, z_pred, H, R):
    y = (z - z_pred).reshape(-1)
    y[1::2] = wrap_angle(y[1::2])
    K = np.linalg.solve(R, H @ P).T                 # P H^T R^-1, written with solve
    x = x + K @ y
    x[2] = wrap_angle(x[2])
    Pn = (np.eye(len(x)) - K @ H) @ P
    return x, (Pn + Pn.T) / 2


def upd_no_R_in_S_short_form(x, P, z, z_pred, H, R):
    y = (z - z_pred).reshape(-1)
    y[1::2] = wrap_angle(y[1::2])
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T)
    x = x + K @ y
    x[2] = wrap_angle(x[2])
    Pn = (np.eye(len(x)) - K @ H) @ P
    return x, (Pn + Pn.T) / 2


def upd_no_inverse_KSK(x, P, z, z_pred, H, R):
    y = (z - z_pred).reshape(-1)
    y[1::2] = wrap_angle(y[1::2])
    S = H @ P @ H.T + R
    K = P @ H.T @ S                                 # the inverse forgotten
    x = x + K @ y
    x[2] = wrap_angle(x[2])
    Pn = P - K @ S @ K.T
    return x, (Pn + Pn.T) / 2


def upd_library_form(x, P, z, z_pred, H, R):
    # the library's covariance: P - W^T W with the whitened gain W = L^-1 H P, S = L L^T
    y = (z - z_pred).reshape(-1)
    y[1::2] = wrap_angle(y[1::2])
    L = np.linalg.cholesky(H @ P @ H.T + R)
    W = np.linalg.solve(L, H @ P)
    x = x + W.T @ np.linalg.solve(L, y)
    x[2] = wrap_angle(x[2])
    Pn = P - W.T @ W
    return x, (Pn + Pn.T) / 2


@pytest.mark.parametrize("fn, words", [
    (upd_short_form, "(I - K H) P is symmetric only in exact arithmetic"),
    (upd_gain_R_inverse, "your gain uses R^-1 where S^-1 belongs"),
    (upd_gain_R_inverse_short_form, "your gain uses R^-1 where S^-1 belongs"),
    (upd_gain_R_inverse_short_form, "(I - K H) P is not the Joseph form either"),
    (upd_no_R_in_S_short_form, "S = H P H^T + R: R is missing; with this gain (I - K H) P is not"),
    (upd_no_inverse_KSK, "the inverse of S is missing; with this gain P - K S K^T is not"),
    (upd_joseph_unsymmetrised, "Return 0.5 * (P + P.T)"),
    (upd_unwrapped, "the bearing of the innovation is not wrapped"),
    (upd_first_bearing_only, "only the first bearing is wrapped"),
    (upd_robot_block_only, "the map block of P is the prior's"),
    (upd_pose_mean_only, "the landmarks' means are the prior's"),
    (upd_no_KRK, "missing K R K^T"),
    (upd_no_R_in_S, "R is missing"),
    (upd_heading_not_wrapped, "not wrapped to [-pi, pi)"),
    (from_notebook(UPD_Q_SRC, "upd_with_Q"), "notebook's Q (the wheel-speed noise) in place"),
    (upd_K_wrong_shape, "H is 2m x n"),
])
def test_joint_update_mistakes_are_named(fn, words, capsys):
    ok, out = verdict(fc.check_joint_update, fn, capsys)
    assert not ok and words in out, out


def test_joint_update_right_answers_pass(capsys):
    for fn in (upd_right, fc._joint_update, upd_library_form):
        ok, out = verdict(fc.check_joint_update, fn, capsys)
        assert ok and "correct" in out, out
    ok, out = verdict(fc.check_joint_update, stub, capsys)
    assert not ok and "not written yet" in out


# --------------------------------------------------------------------------- augmentation
def aug_right(x, P, z, R):
    J1, J2 = inverse_observation_jacobians(x[:3], z)
    m = inverse_observe(x[:3], z)
    PLx = J1 @ P[:3, :]
    PLL = J1 @ P[:3, :3] @ J1.T + J2 @ R @ J2.T
    return np.concatenate([x, m]), np.block([[P, PLx.T], [PLx, PLL]])


def aug_no_cross(x, P, z, R):
    xn, Pn = aug_right(x, P, z, R)
    n = len(x)
    Pn[n:, :n] = 0.0
    Pn[:n, n:] = 0.0
    return xn, Pn


def aug_robot_only(x, P, z, R):
    J1, J2 = inverse_observation_jacobians(x[:3], z)
    n = len(x)
    Pn = np.zeros((n + 2, n + 2))
    Pn[:n, :n] = P
    Pn[n:, :3] = J1 @ P[:3, :3]
    Pn[:3, n:] = Pn[n:, :3].T
    Pn[n:, n:] = J1 @ P[:3, :3] @ J1.T + J2 @ R @ J2.T
    return np.concatenate([x, inverse_observe(x[:3], z)]), Pn


def aug_cartesian_R(x, P, z, R):
    xn, Pn = aug_right(x, P, z, R)
    J1, _ = inverse_observation_jacobians(x[:3], z)
    Pn[-2:, -2:] = J1 @ P[:3, :3] @ J1.T + R
    return xn, Pn


def aug_J2_transposed(x, P, z, R):
    xn, Pn = aug_right(x, P, z, R)
    J1, J2 = inverse_observation_jacobians(x[:3], z)
    Pn[-2:, -2:] = J1 @ P[:3, :3] @ J1.T + J2.T @ R @ J2
    return xn, Pn


def aug_no_pose_uncertainty(x, P, z, R):
    xn, Pn = aug_right(x, P, z, R)
    _, J2 = inverse_observation_jacobians(x[:3], z)
    Pn[-2:, -2:] = J2 @ R @ J2.T
    return xn, Pn


def aug_no_heading(x, P, z, R):
    xn, Pn = aug_right(x, P, z, R)
    xn[-2:] = x[:2] + z[0] * np.array([np.cos(z[1]), np.sin(z[1])])
    return xn, Pn


AUG_Q_SRC = """
def aug_with_Q(x, P, z, R_arg):
    J1, J2 = inverse_observation_jacobians(x[:3], z)
    PLx = J1 @ P[:3, :]
    PLL = J1 @ P[:3, :3] @ J1.T + J2 @ Q @ J2.T
    return np.concatenate([x, inverse_observe(x[:3], z)]), np.block([[P, PLx.T], [PLx, PLL]])
"""


def aug_only_new_block(x, P, z, R):
    xn, Pn = aug_right(x, P, z, R)
    return xn[-2:], Pn[-2:, -2:]


@pytest.mark.parametrize("fn, words", [
    (aug_no_cross, "the cross-covariances are missing"),
    (aug_robot_only, "the cross-covariance with the old landmarks is missing"),
    (aug_cartesian_R, "R is added as if it were the covariance of a point in N"),
    (aug_J2_transposed, "J2 is transposed"),
    (aug_no_pose_uncertainty, "lacks J1 P_rr J1^T"),
    (aug_no_heading, "ignores the heading"),
    (from_notebook(AUG_Q_SRC, "aug_with_Q"), "notebook's Q (the wheel-speed noise) in place"),
    (aug_only_new_block, "gets 2 more"),
])
def test_augmentation_mistakes_are_named(fn, words, capsys):
    ok, out = verdict(fc.check_augment, fn, capsys)
    assert not ok and words in out, out


def aug_by_hand(j1_sign=(1, 1), j2_sign=(1, 1, 1, 1)):
    """A student's augmentation with J1 and J2 written out by hand (a = theta + beta); the
    signs of J1's theta column and of J2's four entries are knobs for a slip."""
    def my_augment(x, P, z, R):
        rho, a = z[0], x[2] + z[1]
        J1 = np.array([[1.0, 0.0, j1_sign[0] * -rho * np.sin(a)],
                       [0.0, 1.0, j1_sign[1] * rho * np.cos(a)]])
        s = j2_sign
        J2 = np.array([[s[0] * np.cos(a), s[1] * -rho * np.sin(a)],
                       [s[2] * np.sin(a), s[3] * rho * np.cos(a)]])
        PLx = J1 @ P[:3, :]
        PLL = J1 @ P[:3, :3] @ J1.T + J2 @ R @ J2.T
        m = x[:2] + rho * np.array([np.cos(a), np.sin(a)])
        return np.concatenate([x, m]), np.block([[P, PLx.T], [PLx, PLL]])
    return my_augment


@pytest.mark.parametrize("slip, words", [
    ({"j1_sign": (-1, 1)}, "J1[0,2] has the wrong sign: J1[0,2] = d x_F / d theta = "
                           "-rho sin(theta + beta)"),
    ({"j1_sign": (1, -1)}, "J1[1,2] has the wrong sign"),
    ({"j2_sign": (1, -1, 1, 1)}, "one sign in J2's column 1 is wrong (J2[0,1] = d x_F / d beta"),
    ({"j2_sign": (1, 1, -1, 1)}, "one sign in J2's column 0 is wrong"),
])
def test_augmentation_sign_slips_name_the_entry(slip, words, capsys):
    ok, out = verdict(fc.check_augment, aug_by_hand(), capsys)
    assert ok, out
    ok, out = verdict(fc.check_augment, aug_by_hand(**slip), capsys)
    assert not ok and words in out, out
    assert "P_LL (the new landmark's own block)" in out
    if "J1" in words:
        assert "P_Lx[:, :3] (the new landmark with the robot)" in out


def test_augmentation_right_answers_pass(capsys):
    for fn in (aug_right, fc._augment):
        ok, out = verdict(fc.check_augment, fn, capsys)
        assert ok and "correct" in out, out
    ok, out = verdict(fc.check_augment, stub, capsys)
    assert not ok and "not written yet" in out


# --------------------------------------------------------------------------- NEES of a trace
def nees_right(x_est, x_true, P):
    e = x_est - x_true
    e[:, 2] = wrap_angle(e[:, 2])
    return np.array([ei @ np.linalg.inv(Pi) @ ei for ei, Pi in zip(e, P)])


def nees_unwrapped(x_est, x_true, P):
    e = x_est - x_true
    return np.array([ei @ np.linalg.inv(Pi) @ ei for ei, Pi in zip(e, P)])


def nees_P_not_inverted(x_est, x_true, P):
    e = x_est - x_true
    e[:, 2] = wrap_angle(e[:, 2])
    return np.array([ei @ Pi @ ei for ei, Pi in zip(e, P)])


def nees_sqrt(x_est, x_true, P):
    return np.sqrt(nees_right(x_est, x_true, P))


def nees_per_dof(x_est, x_true, P):
    return nees_right(x_est, x_true, P) / 3


def nees_position_only(x_est, x_true, P):
    e = x_est[:, :2] - x_true[:, :2]
    return np.array([ei @ np.linalg.inv(Pi[:2, :2]) @ ei for ei, Pi in zip(e, P)])


def nees_mean(x_est, x_true, P):
    return float(np.mean(nees_right(x_est, x_true, P)))


@pytest.mark.parametrize("fn, words", [
    (nees_unwrapped, "the heading error is not wrapped"),
    (nees_P_not_inverted, "the INVERSE of P"),
    (nees_sqrt, "the square root"),
    (nees_per_dof, "divided by the 3 degrees of freedom"),
    (nees_position_only, "the position only"),
    (nees_mean, "that is the mean over the trace"),
])
def test_nees_mistakes_are_named(fn, words, capsys):
    ok, out = verdict(fc.check_trace_nees, fn, capsys)
    assert not ok and words in out, out


def test_nees_right_answers_pass(capsys):
    for fn in (nees_right, lambda e, t, P: metrics.nees(metrics.pose_error(e, t), P)):
        ok, out = verdict(fc.check_trace_nees, fn, capsys)
        assert ok and "correct" in out, out
    assert not fc.check_trace_nees(stub, verbose=False)


# --------------------------------------------------------------------------- N runs, one band
def verdict_right(nees_runs, dof, prob):
    from scipy.stats import chi2

    N = nees_runs.shape[0]
    avg = nees_runs.mean(axis=0)
    lo = chi2.ppf((1 - prob) / 2, N * dof) / N
    hi = chi2.ppf((1 + prob) / 2, N * dof) / N
    return float(np.mean((avg >= lo) & (avg <= hi)))


def verdict_one_run_band(nees_runs, dof, prob):
    from scipy.stats import chi2

    avg = nees_runs.mean(axis=0)
    lo, hi = chi2.ppf((1 - prob) / 2, dof), chi2.ppf((1 + prob) / 2, dof)
    return float(np.mean((avg >= lo) & (avg <= hi)))


def verdict_each_run(nees_runs, dof, prob):
    from scipy.stats import chi2

    lo, hi = chi2.ppf((1 - prob) / 2, dof), chi2.ppf((1 + prob) / 2, dof)
    return float(np.mean((nees_runs >= lo) & (nees_runs <= hi)))


def verdict_over_time(nees_runs, dof, prob):
    from scipy.stats import chi2

    N = nees_runs.shape[0]
    avg = nees_runs.mean(axis=1)
    lo = chi2.ppf((1 - prob) / 2, N * dof) / N
    hi = chi2.ppf((1 + prob) / 2, N * dof) / N
    return float(np.mean((avg >= lo) & (avg <= hi)))


def verdict_one_sided(nees_runs, dof, prob):
    from scipy.stats import chi2

    N = nees_runs.shape[0]
    avg = nees_runs.mean(axis=0)
    return float(np.mean((avg >= chi2.ppf(1 - prob, N * dof) / N)
                         & (avg <= chi2.ppf(prob, N * dof) / N)))


@pytest.mark.parametrize("fn, words", [
    (verdict_one_run_band, "the band of ONE run used for the average of N"),
    (verdict_each_run, "every run's own NEES against the one-run band"),
    (verdict_over_time, "averages over time"),
    (verdict_one_sided, "one-sided"),
])
def test_consistency_verdict_mistakes_are_named(fn, words, capsys):
    ok, out = verdict(fc.check_consistency_verdict, fn, capsys)
    assert not ok and words in out, out


def test_consistency_verdict_right_answer_passes(capsys):
    ok, out = verdict(fc.check_consistency_verdict, verdict_right, capsys)
    assert ok and "correct" in out, out
    assert not fc.check_consistency_verdict(stub, verbose=False)
