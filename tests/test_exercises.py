"""Tests of the exercise checkers (slamlib.course.checkers_*): each accepts a right answer and
rejects wrong ones with a message that names the problem."""

import numpy as np
import pytest


# --------------------------------------------------------------------------- chapter 04
def test_inverse_observation_checker_accepts_the_library(capsys):
    from slamlib.course.checkers_ch04 import check_inverse_observation_jacobians
    from slamlib.models import inverse_observation_jacobians

    assert check_inverse_observation_jacobians(inverse_observation_jacobians) is True
    assert "correct" in capsys.readouterr().out


def test_inverse_observation_checker_accepts_an_independent_answer(capsys):
    # written out from the closed form, not from the library
    from slamlib.course.checkers_ch04 import check_inverse_observation_jacobians

    def mine(pose, z):
        rho, b = z
        th = pose[2]
        bx, by = rho * np.cos(b), rho * np.sin(b)
        c, s = np.cos(th), np.sin(th)
        J1 = np.array([[1, 0, -bx * s - by * c], [0, 1, bx * c - by * s]])
        J2 = np.array([[np.cos(th + b), -rho * np.sin(th + b)],
                       [np.sin(th + b), rho * np.cos(th + b)]])
        return J1, J2

    assert check_inverse_observation_jacobians(mine)


def test_inverse_observation_checker_rejects_printed_J1_naming_entry_1_2(capsys):
    from slamlib.course.checkers_ch04 import check_inverse_observation_jacobians
    from slamlib.course.errata import printed_J1
    from slamlib.models import inverse_observation_jacobians

    def report_J1(pose, z):
        return printed_J1(pose, z), inverse_observation_jacobians(pose, z)[1]

    assert check_inverse_observation_jacobians(report_J1) is False
    out = capsys.readouterr().out
    assert "J1[1,2]" in out
    assert "J1[0," not in out and "J2[" not in out


def test_inverse_observation_checker_rejects_printed_J2_as_transposed(capsys):
    from slamlib.course.checkers_ch04 import check_inverse_observation_jacobians
    from slamlib.course.errata import printed_J2
    from slamlib.models import inverse_observation_jacobians

    def report_J2(pose, z):
        return inverse_observation_jacobians(pose, z)[0], printed_J2(pose, z)

    assert check_inverse_observation_jacobians(report_J2) is False
    out = capsys.readouterr().out
    assert "J2[0,1]" in out and "J2[1,0]" in out
    assert "transposed" in out


def test_inverse_observation_checker_wrong_J2_is_not_called_transposed(capsys):
    from slamlib.course.checkers_ch04 import check_inverse_observation_jacobians
    from slamlib.models import inverse_observation_jacobians

    def flipped(pose, z):
        J1, J2 = inverse_observation_jacobians(pose, z)
        return J1, -J2

    assert check_inverse_observation_jacobians(flipped) is False
    out = capsys.readouterr().out
    assert "sign flipped" in out and "transposed" not in out


def test_inverse_observation_checker_names_a_J2_entry_with_the_wrong_sign(capsys):
    # written by hand with the sign of d x_F / d beta slipped
    from slamlib.course.checkers_ch04 import check_inverse_observation_jacobians

    def mine(pose, z):
        rho, a = z[0], pose[2] + z[1]
        J1 = np.array([[1.0, 0.0, -rho * np.sin(a)], [0.0, 1.0, rho * np.cos(a)]])
        J2 = np.array([[np.cos(a), rho * np.sin(a)], [np.sin(a), rho * np.cos(a)]])
        return J1, J2

    assert check_inverse_observation_jacobians(mine) is False
    out = capsys.readouterr().out
    assert "J2[0,1] = d x_F / d beta = -rho sin(theta + beta) (yours has the opposite sign)" in out
    assert "transposed" not in out


@pytest.mark.parametrize("kind", ["none", "raise"])
def test_inverse_observation_checker_stub_is_not_written_yet(capsys, kind):
    from slamlib.course.checkers_ch04 import check_inverse_observation_jacobians

    def my_inverse_observation_jacobians(pose, z):
        if kind == "raise":
            raise NotImplementedError
        return None

    assert check_inverse_observation_jacobians(my_inverse_observation_jacobians) is False
    assert "not written yet" in capsys.readouterr().out


def test_inverse_observation_checker_never_raises(capsys):
    from slamlib.course.checkers_ch04 import check_inverse_observation_jacobians

    def broken(pose, z):
        return 1 / 0

    assert check_inverse_observation_jacobians(broken) is False
    assert "ZeroDivisionError" in capsys.readouterr().out
    assert check_inverse_observation_jacobians(lambda p, z: "J1") is False
    assert check_inverse_observation_jacobians(lambda p, z: (np.zeros((3, 2)), np.eye(2))) is False
    assert "transposed" in capsys.readouterr().out


# --------------------------------------------------------------------------- chapter 03
def test_observation_checker_accepts_the_library(capsys):
    from slamlib.course.checkers_ch03 import check_observation_jacobians
    from slamlib.models import observation_jacobians

    assert check_observation_jacobians(observation_jacobians) is True
    assert "correct" in capsys.readouterr().out


def test_observation_checker_accepts_an_independent_answer():
    # written out from the derivative of atan2, not from the library
    from slamlib.course.checkers_ch03 import check_observation_jacobians

    def mine(pose, landmark):
        dx, dy = landmark[0] - pose[0], landmark[1] - pose[1]
        r = np.hypot(dx, dy)
        Hl = np.array([[dx / r, dy / r], [-dy / r**2, dx / r**2]])
        return np.hstack([-Hl, [[0.0], [-1.0]]]), Hl

    assert check_observation_jacobians(mine) is True


def test_observation_checker_rejects_the_printed_jacobians_naming_the_entries(capsys):
    from slamlib.course.checkers_ch03 import check_observation_jacobians
    from slamlib.course.errata import printed_H_landmark, printed_H_pose

    def report(pose, landmark):
        return printed_H_pose(pose, landmark), printed_H_landmark(pose, landmark)

    assert check_observation_jacobians(report) is False
    out = capsys.readouterr().out
    assert "H_pose[1,1]" in out and "H_landmark[1,0]" in out
    assert "sign flipped" in out
    # only the two wrong entries are named
    assert "H_pose[0," not in out and "H_pose[1,0]" not in out and "H_landmark[1,1]" not in out


def test_observation_checker_names_the_sqrt_typo(capsys):
    from slamlib.course.checkers_ch03 import check_observation_jacobians
    from slamlib.course.errata import printed_H_pose_slam
    from slamlib.models import observation_jacobians

    def report(pose, landmark):
        return printed_H_pose_slam(pose, landmark), observation_jacobians(pose, landmark)[1]

    assert check_observation_jacobians(report) is False
    out = capsys.readouterr().out
    assert "H_pose[1,0]" in out and "H_pose[1,1]" in out and "sqrt(q)" in out


def test_observation_checker_catches_an_unwrapped_difference_at_the_seam(capsys):
    # a finite-difference answer that does not wrap the bearing passes the generic points
    # and fails only at the point whose bearing is near pi
    from slamlib.course.checkers_ch03 import check_observation_jacobians
    from slamlib.models import observe

    def unwrapped(pose, landmark, eps=1e-6):
        cols_p = [(observe(pose + e, landmark) - observe(pose - e, landmark)) / (2 * eps)
                  for e in np.eye(3) * eps]
        cols_l = [(observe(pose, landmark + e) - observe(pose, landmark - e)) / (2 * eps)
                  for e in np.eye(2) * eps]
        return np.column_stack(cols_p), np.column_stack(cols_l)

    assert check_observation_jacobians(unwrapped) is False
    out = capsys.readouterr().out
    assert "bearing near +-pi" in out and "wrap" in out


@pytest.mark.parametrize("kind", ["none", "raise"])
def test_observation_checker_stub_is_not_written_yet(capsys, kind):
    from slamlib.course.checkers_ch03 import check_observation_jacobians

    def my_observation_jacobians(pose, landmark):
        if kind == "raise":
            raise NotImplementedError
        return None

    assert check_observation_jacobians(my_observation_jacobians) is False
    assert "not written yet" in capsys.readouterr().out


def test_observation_checker_never_raises(capsys):
    from slamlib.course.checkers_ch03 import check_observation_jacobians
    from slamlib.models import observation_jacobians

    assert check_observation_jacobians(lambda p, m: 1 / 0) is False
    assert "ZeroDivisionError" in capsys.readouterr().out
    assert check_observation_jacobians(lambda p, m: "H") is False
    assert check_observation_jacobians(lambda p, m: (np.zeros((2, 3)), "x")) is False

    def transposed(p, m):
        Hp, Hl = observation_jacobians(p, m)
        return Hp.T, Hl

    assert check_observation_jacobians(transposed) is False
    assert "transposed" in capsys.readouterr().out


def test_observation_checker_names_a_transposed_H_landmark(capsys):
    from slamlib.course.checkers_ch03 import check_observation_jacobians
    from slamlib.models import observation_jacobians

    def transposed_landmark(pose, landmark):
        Hp, Hl = observation_jacobians(pose, landmark)
        return Hp, Hl.T

    assert check_observation_jacobians(transposed_landmark) is False
    out = capsys.readouterr().out
    assert "H_landmark is transposed" in out
    assert "sqrt(q)" not in out


def test_observation_checker_hints_dbearing_dtheta(capsys):
    from slamlib.course.checkers_ch03 import check_observation_jacobians
    from slamlib.models import observation_jacobians

    def plus_one(pose, landmark):
        Hp, Hl = observation_jacobians(pose, landmark)
        Hp[1, 2] = 1.0
        return Hp, Hl

    assert check_observation_jacobians(plus_one) is False
    out = capsys.readouterr().out
    assert "H_pose[1,2]" in out and "d bearing / d theta = -1" in out
    assert "sqrt(q)" not in out


def _written_out(sign_bx=1.0, sign_dy_q=1.0, range_den="r", sign_dby=1.0):
    """A student's H_pose, H_landmark written out by hand, with one knob per slip."""
    def mine(pose, landmark):
        dx, dy = landmark[0] - pose[0], landmark[1] - pose[1]
        q = dx * dx + dy * dy
        den = np.sqrt(q) if range_den == "r" else q
        Hp = np.array([[sign_bx * -dx / den, -dy / den, 0.0],
                       [sign_dy_q * dy / q, -dx / q, -1.0]])
        Hl = np.array([[dx / den, dy / den], [-dy / q, sign_dby * dx / q]])
        return Hp, Hl
    return mine


@pytest.mark.parametrize("slip, words", [
    ({"sign_dy_q": -1.0}, "H_pose[1,0] = d bearing / d x = dy/q (yours has the opposite sign)"),
    ({"sign_dby": -1.0}, "H_landmark[1,1] = d bearing / d y_F = dx/q (yours has the opposite"),
    ({"sign_bx": -1.0}, "H_pose[0,0] = d range / d x = -dx/sqrt(q)"),
    ({"range_den": "q"}, "the range row is [dx/sqrt(q), dy/sqrt(q)]"),
])
def test_observation_checker_names_the_entry_and_its_formula(slip, words, capsys):
    # a single slip that none of the report's errors explains gets the entry's own formula,
    # not the generic hint
    from slamlib.course.checkers_ch03 import check_observation_jacobians

    assert check_observation_jacobians(_written_out()) is True
    capsys.readouterr()
    assert check_observation_jacobians(_written_out(**slip)) is False
    out = capsys.readouterr().out
    assert words in out, out
    assert "H_landmark is minus the first two columns" not in out


def test_observation_checker_zero_entry_gets_its_reason(capsys):
    from slamlib.course.checkers_ch03 import check_observation_jacobians
    from slamlib.models import observation_jacobians

    def range_turns(pose, landmark):
        Hp, Hl = observation_jacobians(pose, landmark)
        Hp[0, 2] = np.hypot(*(np.asarray(landmark) - pose[:2]))   # "range times dtheta"
        return Hp, Hl

    assert check_observation_jacobians(range_turns) is False
    out = capsys.readouterr().out
    assert "H_pose[0,2] = d range / d theta = 0: turning in place" in out, out


def test_inverse_observation_checker_report_hint_only_for_the_report_typo(capsys):
    # a wrong J1[1,2] that is not the report's ^N x typo gets the theta-column hint,
    # not the report's
    from slamlib.course.checkers_ch04 import check_inverse_observation_jacobians
    from slamlib.models import inverse_observation_jacobians

    def wrong_theta(pose, z):
        J1, J2 = inverse_observation_jacobians(pose, z)
        J1[1, 2] = -J1[1, 2]
        return J1, J2

    assert check_inverse_observation_jacobians(wrong_theta) is False
    out = capsys.readouterr().out
    assert "J1[1,2]" in out and "theta column" in out
    assert "^N x" not in out and "robot's position in N" not in out

    from slamlib.course.errata import printed_J1

    def report_J1(pose, z):
        return printed_J1(pose, z), inverse_observation_jacobians(pose, z)[1]

    assert check_inverse_observation_jacobians(report_J1) is False
    out = capsys.readouterr().out
    assert "robot's position in N" in out and "theta column" not in out


# --------------------------------------------------------------------------- chapter 05
def _gate_answer(z, z_pred, S, prob, *, wrap=True, inverse=True, dof=2):
    """An answer written out independently of the checker, with switchable mistakes."""
    from scipy.stats import chi2

    y = np.asarray(z, float) - np.asarray(z_pred, float)
    if wrap:
        y[1] = np.arctan2(np.sin(y[1]), np.cos(y[1]))
    M = np.linalg.inv(S) if inverse else np.asarray(S)
    d2 = float(y @ M @ y)
    return d2, d2 < chi2.ppf(prob, dof)


def test_gate_checker_accepts_a_right_answer(capsys):
    from slamlib.course.checkers_ch05 import check_gate

    assert check_gate(lambda z, zp, S, p: _gate_answer(z, zp, S, p)) is True
    assert "correct" in capsys.readouterr().out


def test_gate_checker_accepts_the_closed_form_threshold(capsys):
    from slamlib.course.checkers_ch05 import check_gate

    def mine(z, z_pred, S, prob):
        d2, _ = _gate_answer(z, z_pred, S, prob)
        return np.float64(d2), np.bool_(d2 < -2.0 * np.log(1.0 - prob))

    assert check_gate(mine) is True


def test_gate_checker_agrees_with_the_library_filter_gate():
    # the library's EKF decides the same way: its gate_threshold and wrap_angle
    from slamlib.course.checkers_ch05 import check_gate
    from slamlib.ekf import gate_threshold
    from slamlib.models import wrap_angle

    def library(z, z_pred, S, prob):
        y = np.array([z[0] - z_pred[0], wrap_angle(z[1] - z_pred[1])])
        d2 = float(y @ np.linalg.solve(S, y))
        return d2, d2 < gate_threshold(prob)

    assert check_gate(library, verbose=False) is True


@pytest.mark.parametrize("stub", [lambda *a: None, "raise"])
def test_gate_checker_says_not_written_yet(capsys, stub):
    from slamlib.course.checkers_ch05 import check_gate

    def raising(*a):
        raise NotImplementedError

    assert check_gate(raising if stub == "raise" else stub) is False
    assert "not written yet" in capsys.readouterr().out


@pytest.mark.parametrize("mistake, words", [
    ({"wrap": False}, "not wrapped"),
    ({"inverse": False}, "uses S where S^-1 belongs"),
    ({"dof": 1}, "chi2.ppf(prob, 1)"),
])
def test_gate_checker_names_the_mistake(capsys, mistake, words):
    from slamlib.course.checkers_ch05 import check_gate

    assert check_gate(lambda z, zp, S, p: _gate_answer(z, zp, S, p, **mistake)) is False
    out = capsys.readouterr().out
    assert words in out


def test_gate_checker_finds_the_report_eq6(capsys):
    from slamlib.course.checkers_ch05 import check_gate
    from slamlib.course.errata import printed_mahalanobis2

    def report(z, z_pred, S, prob):
        y = np.array([z[0] - z_pred[0], np.arctan2(np.sin(z[1] - z_pred[1]),
                                                   np.cos(z[1] - z_pred[1]))])
        d2 = printed_mahalanobis2(y, z_pred, S)
        return d2, d2 < 5.991

    assert check_gate(report) is False
    assert "eq. (6)" in capsys.readouterr().out


@pytest.mark.parametrize("threshold, words", [
    (lambda p: p, "probability itself"),
    (lambda p: 5.991, "fixed at 5.99"),
    (lambda p: -2.0 * np.log(p), "1 - prob"),
])
def test_gate_checker_names_a_wrong_threshold(capsys, threshold, words):
    from slamlib.course.checkers_ch05 import check_gate

    def mine(z, z_pred, S, prob):
        d2, _ = _gate_answer(z, z_pred, S, prob)
        return d2, d2 < threshold(prob)

    assert check_gate(mine) is False
    out = capsys.readouterr().out
    assert "wrong decision" in out and words in out


def test_gate_checker_hints_say_what_to_use_not_what_went_wrong(capsys):
    # a hint names the student's threshold as what it LOOKS like, then what to use instead
    from scipy.stats import chi2

    from slamlib.course.checkers_ch05 import check_gate

    for wrong in (lambda p: chi2.ppf(1.0 - p, 2), lambda p: chi2.ppf(p, 1)):
        def mine(z, z_pred, S, prob, wrong=wrong):
            d2, _ = _gate_answer(z, z_pred, S, prob)
            return d2, d2 < wrong(prob)

        assert check_gate(mine) is False
        hint = [line for line in capsys.readouterr().out.splitlines() if "Hint" in line]
        assert len(hint) == 1
        assert "your threshold looks like" in hint[0] and "use chi2.ppf(prob, 2)" in hint[0]
        assert not hint[0].startswith("  Hint: the threshold is")


def test_gate_checker_names_a_reversed_pair(capsys):
    from slamlib.course.checkers_ch05 import check_gate

    def reversed_pair(z, z_pred, S, prob):
        d2, accept = _gate_answer(z, z_pred, S, prob)
        return accept, d2

    assert check_gate(reversed_pair) is False
    out = capsys.readouterr().out
    assert "(accept, d2)" in out and "order (d2, accept)" in out
    assert "d2 is wrong" not in out


def test_gate_checker_rejects_a_wrong_shape_without_raising(capsys):
    from slamlib.course.checkers_ch05 import check_gate

    assert check_gate(lambda *a: 3.0) is False
    assert check_gate(lambda *a: (np.ones(2), True)) is False
    assert "pair (d2, accept)" in capsys.readouterr().out


def test_gate_checker_cases_cross_the_seam_and_straddle_the_gate():
    # the checker must exercise what it claims: wrapping matters, both decisions occur
    from scipy.stats import chi2

    from slamlib.course.checkers_ch05 import _random_gate_cases

    cases = list(_random_gate_cases(20, 5))
    seam = [abs(z[1] - zp[1]) > np.pi for z, zp, _, _ in cases]
    inside = [_gate_answer(z, zp, S, p)[1] for z, zp, S, p in cases]
    assert sum(seam) >= 5
    assert 5 <= sum(inside) <= 15
    assert len({p for *_, p in cases}) >= 4
    assert all(chi2.ppf(p, 2) > 0 for *_, p in cases)


# --------------------------------------------------------------------------- chapter 06
def _band_by_monte_carlo(n, d, p, rng, draws=200_000):
    # independent of scipy: averages of n chi-square(d) draws, their empirical quantiles
    avg = rng.chisquare(d, size=(draws, n)).mean(axis=1)
    return np.quantile(avg, [(1 - p) / 2, (1 + p) / 2])


def test_nees_band_checker_accepts_a_right_answer_and_it_matches_a_simulation(capsys):
    from scipy.stats import chi2

    from slamlib.course.checkers_ch06 import check_average_nees_band

    def mine(n, d, p):
        return chi2.ppf((1 - p) / 2, n * d) / n, chi2.ppf((1 + p) / 2, n * d) / n

    assert check_average_nees_band(mine) is True
    assert "correct" in capsys.readouterr().out
    lo, hi = _band_by_monte_carlo(20, 3, 0.95, np.random.default_rng(0))
    np.testing.assert_allclose(mine(20, 3, 0.95), (lo, hi), rtol=0.01)


@pytest.mark.parametrize("stub", [lambda n, d, p: None, "raise"])
def test_nees_band_checker_says_not_written_yet(capsys, stub):
    from slamlib.course.checkers_ch06 import check_average_nees_band

    def raising(n, d, p):
        raise NotImplementedError

    assert check_average_nees_band(raising if stub == "raise" else stub) is False
    assert "not written yet" in capsys.readouterr().out


@pytest.mark.parametrize("wrong, words", [
    ("one", "ONE sample"),
    ("sum", "SUM"),
    ("dof", "has N*dof"),
    ("onesided", "one-sided"),
    ("normal", "normal approximation"),
    ("swapped", "swapped"),
])
def test_nees_band_checker_names_the_mistake(capsys, wrong, words):
    from scipy.stats import chi2, norm

    from slamlib.course.checkers_ch06 import check_average_nees_band

    def mine(n, d, p):
        a, b = (1 - p) / 2, (1 + p) / 2
        if wrong == "one":
            return chi2.ppf(a, d), chi2.ppf(b, d)
        if wrong == "sum":
            return chi2.ppf(a, n * d), chi2.ppf(b, n * d)
        if wrong == "dof":
            return chi2.ppf(a, d) / n, chi2.ppf(b, d) / n
        if wrong == "onesided":
            return chi2.ppf(1 - p, n * d) / n, chi2.ppf(p, n * d) / n
        if wrong == "normal":
            z = norm.ppf(b)
            return d - z * np.sqrt(2 * d / n), d + z * np.sqrt(2 * d / n)
        return chi2.ppf(b, n * d) / n, chi2.ppf(a, n * d) / n

    assert check_average_nees_band(mine) is False
    out = capsys.readouterr().out
    assert "not right" in out and words in out


def test_nees_band_checker_rejects_a_wrong_shape_without_raising(capsys):
    from slamlib.course.checkers_ch06 import check_average_nees_band

    assert check_average_nees_band(lambda n, d, p: 3.0) is False
    assert check_average_nees_band(lambda n, d, p: (np.ones(2), 1.0)) is False
    assert "pair (lo, hi)" in capsys.readouterr().out


def test_nees_band_checker_agrees_with_the_library_band():
    from slamlib.course.checkers_ch06 import check_average_nees_band
    from slamlib.metrics import chi2_band

    assert check_average_nees_band(lambda n, d, p: chi2_band(d, n, p), verbose=False) is True


# --------------------------------------------------------------------------- chapter 08
def test_history_index_checker_accepts_the_library_and_a_loop(capsys):
    from slamlib.course.checkers_ch08 import check_history_index
    from slamlib.delay import history_index

    assert check_history_index(history_index) is True
    assert "correct" in capsys.readouterr().out

    def loop(times, t_capture):
        i = 0
        while i < len(times) and times[i] <= t_capture:
            i += 1
        return i

    assert check_history_index(loop, verbose=False) is True
    assert check_history_index(lambda t, tc: np.int64(np.searchsorted(t, tc, side="right")),
                               verbose=False) is True


@pytest.mark.parametrize("wrong, words", [
    (lambda t, tc: int(np.searchsorted(t, tc, side="left")), "bisect_right, not bisect_left"),
    (lambda t, tc: sum(1 for x in t if x <= tc) - 1, "one more"),
    (lambda t, tc: sum(1 for x in t if x > tc), "AFTER the capture time"),
    (lambda t, tc: 0, "number of events with a time <= t_capture"),
])
def test_history_index_checker_names_the_mistake(wrong, words, capsys):
    from slamlib.course.checkers_ch08 import check_history_index

    assert check_history_index(wrong) is False
    out = capsys.readouterr().out
    assert "wrong place" in out and words in out


def test_history_index_checker_stub_and_bad_output_without_raising(capsys):
    from slamlib.course.checkers_ch08 import check_history_index

    assert check_history_index(lambda t, tc: None) is False
    assert "not written yet" in capsys.readouterr().out
    assert check_history_index(lambda t, tc: 1.5) is False
    assert check_history_index(lambda t, tc: [1, 2]) is False
    assert check_history_index(lambda t, tc: "3") is False
    assert capsys.readouterr().out.count("expected one integer") == 3

    def boom(t, tc):
        raise KeyError("x")

    assert check_history_index(boom) is False
    assert "KeyError" in capsys.readouterr().out


# --------------------------------------------------------------------------- chapter 01
def _motion_jacobians_by_hand(x, u, dt, b):
    # written out from the derivation of chapter 01, not from the library
    V = 0.5 * (u[0] + u[1])
    c, s = np.cos(x[2]), np.sin(x[2])
    A = np.array([[1.0, 0.0, -V * s * dt], [0.0, 1.0, V * c * dt], [0.0, 0.0, 1.0]])
    W = np.array([[0.5 * c * dt, 0.5 * c * dt], [0.5 * s * dt, 0.5 * s * dt], [-dt / b, dt / b]])
    return A, W


def test_motion_checker_accepts_a_right_answer(capsys):
    from slamlib.course.checkers_ch01 import check_motion_jacobians

    assert check_motion_jacobians(_motion_jacobians_by_hand) is True
    assert "correct" in capsys.readouterr().out


def _motion_model_by_hand(x, u, dt, b, turn=1.0):
    # one Euler step, written out from chapter 01 (turn=-1: the z-up ROS turn rate)
    V, w = 0.5 * (u[0] + u[1]), turn * (u[1] - u[0]) / b
    return np.array([x[0] + V * np.cos(x[2]) * dt, x[1] + V * np.sin(x[2]) * dt, x[2] + w * dt])


def _ros_model(x, u, dt, b):
    return _motion_model_by_hand(x, u, dt, b, turn=-1.0)


def _swapped_columns(x, u, dt, b):
    A, W = _motion_jacobians_by_hand(x, u, dt, b)
    return A, W[:, ::-1]


def _ros_turn_rate(x, u, dt, b):
    # derived from the ROS model: the last row of W is [dt/b, -dt/b], the same numbers as
    # _swapped_columns, so only the student's model can tell the two mistakes apart
    A, W = _motion_jacobians_by_hand(x, u, dt, b)
    W[2] = [dt / b, -dt / b]
    return A, W


def test_motion_checker_accepts_a_right_model_and_jacobians(capsys):
    from slamlib.course.checkers_ch01 import check_motion_jacobians

    assert check_motion_jacobians(_motion_jacobians_by_hand, model=_motion_model_by_hand) is True
    out = capsys.readouterr().out
    assert "correct" in out and "motion model matches" in out


def test_motion_checker_names_swapped_W_columns(capsys):
    from slamlib.course.checkers_ch01 import check_motion_jacobians

    assert check_motion_jacobians(_swapped_columns, model=_motion_model_by_hand) is False
    out = capsys.readouterr().out
    assert "W columns are swapped" in out and "column 0 is d/dw_R" in out
    assert "turn rate's sign is not the cause" in out


def test_motion_checker_names_the_turn_rate_sign_not_the_columns(capsys):
    from slamlib.course.checkers_ch01 import check_motion_jacobians

    assert check_motion_jacobians(_ros_turn_rate, model=_ros_model) is False
    out = capsys.readouterr().out
    assert "turns the wrong way" in out and "The cause is the turn rate's sign" in out
    assert "W columns are swapped" not in out and "(V_L - V_R)/b" in out


def test_motion_checker_without_the_model_names_both_causes(capsys):
    from slamlib.course.checkers_ch01 import check_motion_jacobians

    for wrong in (_swapped_columns, _ros_turn_rate):
        assert check_motion_jacobians(wrong) is False
        out = capsys.readouterr().out
        assert "Two different mistakes" in out and "columns swapped" in out
        assert "turn rate of the wrong sign" in out and "model=my_motion_model" in out


def test_motion_checker_rejects_a_model_that_turns_the_wrong_way_with_right_jacobians(capsys):
    from slamlib.course.checkers_ch01 import check_motion_jacobians

    assert check_motion_jacobians(_motion_jacobians_by_hand, model=_ros_model) is False
    out = capsys.readouterr().out
    assert "turns the wrong way" in out and "fix its turn rate" in out


@pytest.mark.parametrize("model, words", [
    (lambda x, u, dt, b: None, "not written yet"),
    (lambda x, u, dt, b: np.zeros(2), "expected a pose [x, y, theta]"),
    # the heading of the end of the step in the position update: a generic mistake
    (lambda x, u, dt, b: _motion_model_by_hand(
        [x[0], x[1], x[2] + (u[1] - u[0]) / b * dt], u, dt, b) - [0, 0, (u[1] - u[0]) / b * dt],
     "heading at the START of the step"),
])
def test_motion_checker_checks_the_model_first(model, words, capsys):
    from slamlib.course.checkers_ch01 import check_motion_jacobians

    assert check_motion_jacobians(_motion_jacobians_by_hand, model=model) is False
    assert words in capsys.readouterr().out


def test_motion_checker_accepts_a_model_that_does_not_wrap_the_heading(capsys):
    from slamlib.course.checkers_ch01 import check_motion_jacobians

    def unwrapped(x, u, dt, b):
        return _motion_model_by_hand(x, u, dt, b) + [0.0, 0.0, 2 * np.pi]

    assert check_motion_jacobians(_motion_jacobians_by_hand, model=unwrapped) is True


def test_prediction_checkers_say_not_written_yet_without_touching_the_run(capsys):
    from slamlib.course.checkers_ch01 import check_bound_ratio_prediction, check_halved_Q_prediction

    class NoRun:
        def __getattr__(self, name):
            raise AssertionError("a stub must not measure anything")

    for check in (check_halved_Q_prediction, check_bound_ratio_prediction):
        assert check(None, NoRun()) is False
        out = capsys.readouterr().out
        assert "not written yet" in out and "sqrt" not in out and "11.0" not in out


def test_prediction_checkers_measure_what_the_closed_form_says(capsys):
    # the heading variance is linear in Q and in time (A leaves the heading alone), so the
    # measured bounds follow 1/sqrt(2) and sqrt(t) up to the tiny initial variance
    from slamlib.course.checkers_ch01 import check_bound_ratio_prediction, check_halved_Q_prediction
    from slamlib.runner import dead_reckoning
    from slamlib.runs import load_run

    run = load_run("arena_loop")
    full = np.degrees(2 * np.sqrt(dead_reckoning(run).P[-1, 2, 2]))
    assert check_halved_Q_prediction(full / np.sqrt(2), run, n_runs=200) is True
    out = capsys.readouterr().out
    assert "Right" in out and "200 seeded noisy runs" in out
    measured = float(out.split("measured ")[1].split(" deg")[0])
    assert measured == pytest.approx(full / np.sqrt(2), rel=1e-3)
    assert check_halved_Q_prediction(full / 2, run, n_runs=200) is False
    assert "Not quite" in capsys.readouterr().out

    t_end = run.enc_t[-1] - run.enc_t[0]
    assert check_bound_ratio_prediction(np.sqrt(t_end / 15.0), run, n_runs=200) is True
    out = capsys.readouterr().out
    measured = float(out.split("measured ")[1].split(" (")[0])
    assert measured == pytest.approx(np.sqrt(t_end / 15.0), rel=0.01)
    assert check_bound_ratio_prediction(4.0, run, n_runs=200) is False


def test_motion_checker_does_not_call_a_wrong_A_swapped(capsys):
    from slamlib.course.checkers_ch01 import check_motion_jacobians

    def wrong_A(x, u, dt, b):
        A, W = _motion_jacobians_by_hand(x, u, dt, b)
        return A.T, W

    assert check_motion_jacobians(wrong_A, model=_motion_model_by_hand) is False
    out = capsys.readouterr().out
    assert "swapped" not in out and "A[" in out


@pytest.mark.parametrize("answer, words", [
    (lambda x, u, dt, b: (np.eye(3), np.zeros((3, 2)), 0),
     "expected a pair (A, W), got a tuple of 3"),
    (lambda x, u, dt, b: np.eye(3), "expected a pair (A, W), got one numpy array of shape (3, 3)"),
    (lambda x, u, dt, b: [np.eye(3)], "expected a pair (A, W), got a list of 1"),
])
def test_motion_checker_names_a_wrong_number_of_values(answer, words, capsys):
    from slamlib.course.checkers_ch01 import check_motion_jacobians

    assert check_motion_jacobians(answer) is False
    assert words in capsys.readouterr().out


# --------------------------------------------------------------------------- chapter 02
def _range_bearing(q):
    return np.array([np.hypot(q[0], q[1]), np.arctan2(q[1], q[0])])


def _camera_answer(p, T):
    # written out independently of slamlib.vision.camera_to_range_bearing
    return _range_bearing(T[:3, :3] @ np.asarray(p) + T[:3, 3])


_COURSE_R = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
_COURSE_t = np.array([0.122, -0.033, 0.082])


def test_camera_checker_accepts_a_right_answer_and_the_library(capsys):
    from slamlib.course.checkers_ch02 import check_camera_to_range_bearing
    from slamlib.vision import camera_to_range_bearing

    assert check_camera_to_range_bearing(_camera_answer) is True
    assert check_camera_to_range_bearing(camera_to_range_bearing) is True
    assert "other mounts" in capsys.readouterr().out


def test_camera_checker_varies_the_mount():
    from slamlib.course.checkers_ch02 import check_camera_to_range_bearing

    seen = []

    def spy(p, T):
        seen.append(np.array(T))
        return _camera_answer(p, T)

    assert check_camera_to_range_bearing(spy, verbose=False)
    assert len(seen) == 8
    np.testing.assert_allclose(seen[0][:3, :3], _COURSE_R)
    assert len({np.round(T, 6).tobytes() for T in seen}) == 8
    for T in seen:                                  # proper rigid transforms
        np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)
        assert np.linalg.det(T[:3, :3]) == pytest.approx(1.0)


@pytest.mark.parametrize("answer, words", [
    (lambda p, T: _range_bearing(_COURSE_R @ p + _COURSE_t), "ignores T_base_cam"),
    (lambda p, T: _camera_answer(p, np.linalg.inv(T)), "^C T_B (the inverse)"),
    (lambda p, T: _range_bearing(T[:3, :3].T @ p + T[:3, 3]), "rotation is transposed"),
    (lambda p, T: _range_bearing(np.asarray(p) + T[:3, 3]), "rotation is forgotten"),
    (lambda p, T: _range_bearing(T[:3, :3] @ p), "measured from the camera"),
    (lambda p, T: _camera_answer(p, T) * [1.0, 180.0 / np.pi], "bearing is in degrees"),
    (lambda p, T: (lambda q: np.array([np.hypot(q[0], q[1]), np.arctan2(q[0], q[1])]))(
        T[:3, :3] @ p + T[:3, 3]), "atan2's arguments are swapped"),
    (lambda p, T: _camera_answer(p, T) * [1.0, -1.0], "sign is flipped"),
    (lambda p, T: (lambda q: np.array([np.linalg.norm(q), np.arctan2(q[1], q[0])]))(
        T[:3, :3] @ p + T[:3, 3]), "includes the height"),
])
def test_camera_checker_names_the_mistake(answer, words, capsys):
    from slamlib.course.checkers_ch02 import check_camera_to_range_bearing

    assert check_camera_to_range_bearing(answer) is False
    out = capsys.readouterr().out
    assert words in out, out


@pytest.mark.parametrize("answer, words", [
    (lambda p, T: None, "not written yet"),
    (lambda p, T: [1.0, 2.0, 3.0], "shape (2,)"),
    (lambda p, T: 1 / 0, "ZeroDivisionError"),
    (lambda p, T: np.full(2, np.nan), "wrong"),
])
def test_camera_checker_stub_and_bad_output_without_raising(answer, words, capsys):
    from slamlib.course.checkers_ch02 import check_camera_to_range_bearing

    assert check_camera_to_range_bearing(answer) is False
    assert words in capsys.readouterr().out


# --------------------------------------------------------------------------- chapter 07
def _view_answer(dx, dy, th, half, rmax, *, wrap=True, sign=-1.0, swap=False, half_scale=1.0,
                 squared=False):
    from slamlib.models import wrap_angle

    a = np.arctan2(dx, dy) if swap else np.arctan2(dy, dx)
    b = a + sign * th
    b = wrap_angle(b) if wrap else b
    d = dx * dx + dy * dy if squared else np.hypot(dx, dy)
    return (d <= rmax) & (np.abs(b) <= half_scale * half)


def _view_fn(**kw):
    def fn(pose, pts, half, rmax):
        pts = np.asarray(pts)
        return _view_answer(pts[:, 0] - pose[0], pts[:, 1] - pose[1], pose[2], half, rmax, **kw)
    return fn


def test_view_checker_accepts_the_library_and_an_independent_answer(capsys):
    import math

    from slamlib.course.checkers_ch07 import check_in_field_of_view
    from slamlib.explore import in_field_of_view

    def loop(pose, pts, half, rmax):
        # the angle to the heading from the dot product: no atan2, no wrap
        out = []
        for x, y in pts:
            dx, dy = x - pose[0], y - pose[1]
            d = math.hypot(dx, dy)
            c = (dx * math.cos(pose[2]) + dy * math.sin(pose[2])) / d
            out.append(d <= rmax and math.acos(max(-1.0, min(1.0, c))) <= half)
        return out

    assert check_in_field_of_view(in_field_of_view) is True
    assert check_in_field_of_view(loop) is True
    assert check_in_field_of_view(_view_fn()) is True
    assert capsys.readouterr().out.count("correct") == 3


@pytest.mark.parametrize("kw, words", [
    ({"wrap": False}, "must be wrapped"),
    ({"sign": 1.0}, "not + theta"),
    ({"swap": True}, "(dy, dx)"),
    ({"half_scale": 2.0}, "HALF the field of view"),
    ({"half_scale": 0.5}, "do not halve it again"),
    ({"squared": True}, "not its square"),
])
def test_view_checker_names_the_mistake(capsys, kw, words):
    from slamlib.course.checkers_ch07 import check_in_field_of_view

    assert check_in_field_of_view(_view_fn(**kw)) is False
    out = capsys.readouterr().out
    assert "not right yet" in out and words in out


def test_view_checker_wrap_to_0_2pi_and_not_written(capsys):
    from slamlib.course.checkers_ch07 import check_in_field_of_view

    def mod(pose, pts, half, rmax):
        d = np.asarray(pts) - pose[:2]
        b = np.mod(np.arctan2(d[:, 1], d[:, 0]) - pose[2], 2 * np.pi)
        return (np.hypot(d[:, 0], d[:, 1]) <= rmax) & (np.abs(b) <= half)

    assert check_in_field_of_view(mod) is False
    assert "not to [0, 2 pi)" in capsys.readouterr().out
    assert check_in_field_of_view(lambda *a: None) is False
    assert "not written yet" in capsys.readouterr().out
    assert check_in_field_of_view(lambda *a: True) is False
    assert "one True/False per point" in capsys.readouterr().out

    def boom(*a):
        raise KeyError("x")

    assert check_in_field_of_view(boom) is False
    assert "raised KeyError" in capsys.readouterr().out


def test_view_checker_cases_need_the_wrap():
    # the unwrapped answer must be wrong somewhere, or the checker would not test the wrap
    from slamlib.course.checkers_ch07 import _random_view_cases
    from slamlib.explore import in_field_of_view

    cases = list(_random_view_cases(12, 7))
    differs = sum(int(np.any(_view_fn(wrap=False)(p, pts, h, r) != in_field_of_view(p, pts, h, r)))
                  for p, pts, h, r in cases)
    inside = sum(int(in_field_of_view(p, pts, h, r).sum()) for p, pts, h, r in cases)
    assert differs >= 2 and 20 <= inside <= 400


def _chapter05_cells():
    import json
    from pathlib import Path

    nb = json.loads((Path(__file__).resolve().parents[1] / "notebooks" / "05_ekf_slam.ipynb")
                    .read_text(encoding="utf-8"))
    return [("".join(c["source"]), c["cell_type"], c["metadata"].get("tags", []))
            for c in nb["cells"]]


def test_chapter05_gate_stub_asks_for_the_pair_its_checker_wants(capsys):
    # the stub's comment and the chapter's exercise text ask for (d2, accept), and a
    # function written from the stub's comment line by line passes check_gate
    from scipy.stats import chi2

    from slamlib.course.checkers_ch05 import check_gate

    cells = _chapter05_cells()
    stub = next(s for s, kind, tags in cells
                if kind == "code" and "def my_gate" in s and "solution" not in tags)
    assert "return the pair (d2, accept)" in stub
    assert "(d2, accept)" in next(s for s, kind, _ in cells
                                  if kind == "markdown" and "my_gate(z, z_pred, S, prob)" in s)

    def from_the_comment(z, z_pred, S, prob):
        y = np.asarray(z, float) - np.asarray(z_pred, float)
        y[1] = (y[1] + np.pi) % (2 * np.pi) - np.pi        # its bearing wrapped
        d2 = float(y @ np.linalg.solve(S, y))              # d2 = y^T S^-1 y
        return d2, d2 < chi2.ppf(prob, 2)                  # accept = d2 < chi2.ppf(prob, 2)

    assert check_gate(from_the_comment) is True
    assert "correct" in capsys.readouterr().out


def test_chapter05_augment_exercise_gives_g_and_its_jacobians():
    # my_augment needs chapter 04's g: the exercise states g, J1 and J2 before the stub, and
    # the stated J1, J2 are the derivatives of the stated g (finite differences)
    cells = _chapter05_cells()
    stub_at = next(i for i, (s, kind, tags) in enumerate(cells)
                   if kind == "code" and "def my_augment" in s and "solution" not in tags)
    text = "".join(s for s, kind, _ in cells[:stub_at] if kind == "markdown")
    for piece in (r"x_B + \rho\cos(\theta+\beta)", r"y_B + \rho\sin(\theta+\beta)",
                  r"J_1 = \partial g/\partial \mathbf x_B", r"J_2 = \partial g/\partial \mathbf z",
                  r"1 & 0 & -\rho\sin(\theta+\beta) \\ 0 & 1 & \rho\cos(\theta+\beta)",
                  r"\cos(\theta+\beta) & -\rho\sin(\theta+\beta) \\ "
                  r"\sin(\theta+\beta) & \rho\cos(\theta+\beta)"):
        assert piece in text, piece

    def g(pose, z):
        return pose[:2] + z[0] * np.array([np.cos(pose[2] + z[1]), np.sin(pose[2] + z[1])])

    rng = np.random.default_rng(3)
    for _ in range(5):
        pose, z = rng.uniform(-2, 2, 3), np.array([rng.uniform(0.5, 3), rng.uniform(-1, 1)])
        a, rho = pose[2] + z[1], z[0]
        J1 = np.array([[1, 0, -rho * np.sin(a)], [0, 1, rho * np.cos(a)]])
        J2 = np.array([[np.cos(a), -rho * np.sin(a)], [np.sin(a), rho * np.cos(a)]])
        eps = 1e-6
        fd1 = np.column_stack([(g(pose + eps * e, z) - g(pose - eps * e, z)) / (2 * eps)
                               for e in np.eye(3)])
        fd2 = np.column_stack([(g(pose, z + eps * e) - g(pose, z - eps * e)) / (2 * eps)
                               for e in np.eye(2)])
        assert np.allclose(J1, fd1, atol=1e-7) and np.allclose(J2, fd2, atol=1e-7)
