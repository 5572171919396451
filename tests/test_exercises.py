"""Tests of the exercise checkers (slamlib.exercises): each accepts a right answer and
rejects wrong ones with a message that names the problem."""

import numpy as np
import pytest


# --------------------------------------------------------------------------- chapter 04
def test_inverse_observation_checker_accepts_the_library(capsys):
    from slamlib.exercises import check_inverse_observation_jacobians
    from slamlib.models import inverse_observation_jacobians

    assert check_inverse_observation_jacobians(inverse_observation_jacobians) is True
    assert "correct" in capsys.readouterr().out


def test_inverse_observation_checker_accepts_an_independent_answer(capsys):
    # written out from the closed form, not from the library
    from slamlib.exercises import check_inverse_observation_jacobians

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
    from slamlib.exercises import check_inverse_observation_jacobians
    from slamlib.models import inverse_observation_jacobians
    from slamlib.report import printed_J1

    def report_J1(pose, z):
        return printed_J1(pose, z), inverse_observation_jacobians(pose, z)[1]

    assert check_inverse_observation_jacobians(report_J1) is False
    out = capsys.readouterr().out
    assert "J1[1,2]" in out
    assert "J1[0," not in out and "J2[" not in out


def test_inverse_observation_checker_rejects_printed_J2_as_transposed(capsys):
    from slamlib.exercises import check_inverse_observation_jacobians
    from slamlib.models import inverse_observation_jacobians
    from slamlib.report import printed_J2

    def report_J2(pose, z):
        return inverse_observation_jacobians(pose, z)[0], printed_J2(pose, z)

    assert check_inverse_observation_jacobians(report_J2) is False
    out = capsys.readouterr().out
    assert "J2[0,1]" in out and "J2[1,0]" in out
    assert "transposed" in out


def test_inverse_observation_checker_wrong_J2_is_not_called_transposed(capsys):
    from slamlib.exercises import check_inverse_observation_jacobians
    from slamlib.models import inverse_observation_jacobians

    def flipped(pose, z):
        J1, J2 = inverse_observation_jacobians(pose, z)
        return J1, -J2

    assert check_inverse_observation_jacobians(flipped) is False
    out = capsys.readouterr().out
    assert "sign flipped" in out and "transposed" not in out


@pytest.mark.parametrize("kind", ["none", "raise"])
def test_inverse_observation_checker_stub_is_not_written_yet(capsys, kind):
    from slamlib.exercises import check_inverse_observation_jacobians

    def my_inverse_observation_jacobians(pose, z):
        if kind == "raise":
            raise NotImplementedError
        return None

    assert check_inverse_observation_jacobians(my_inverse_observation_jacobians) is False
    assert "not written yet" in capsys.readouterr().out


def test_inverse_observation_checker_never_raises(capsys):
    from slamlib.exercises import check_inverse_observation_jacobians

    def broken(pose, z):
        return 1 / 0

    assert check_inverse_observation_jacobians(broken) is False
    assert "ZeroDivisionError" in capsys.readouterr().out
    assert check_inverse_observation_jacobians(lambda p, z: "J1") is False
    assert check_inverse_observation_jacobians(lambda p, z: (np.zeros((3, 2)), np.eye(2))) is False
    assert "transposed" in capsys.readouterr().out


# --------------------------------------------------------------------------- chapter 03
def test_observation_checker_accepts_the_library(capsys):
    from slamlib.exercises import check_observation_jacobians
    from slamlib.models import observation_jacobians

    assert check_observation_jacobians(observation_jacobians) is True
    assert "correct" in capsys.readouterr().out


def test_observation_checker_accepts_an_independent_answer():
    # written out from the derivative of atan2, not from the library
    from slamlib.exercises import check_observation_jacobians

    def mine(pose, landmark):
        dx, dy = landmark[0] - pose[0], landmark[1] - pose[1]
        r = np.hypot(dx, dy)
        Hl = np.array([[dx / r, dy / r], [-dy / r**2, dx / r**2]])
        return np.hstack([-Hl, [[0.0], [-1.0]]]), Hl

    assert check_observation_jacobians(mine) is True


def test_observation_checker_rejects_the_printed_jacobians_naming_the_entries(capsys):
    from slamlib.exercises import check_observation_jacobians
    from slamlib.report import printed_H_landmark, printed_H_pose

    def report(pose, landmark):
        return printed_H_pose(pose, landmark), printed_H_landmark(pose, landmark)

    assert check_observation_jacobians(report) is False
    out = capsys.readouterr().out
    assert "H_pose[1,1]" in out and "H_landmark[1,0]" in out
    assert "sign flipped" in out
    # only the two wrong entries are named
    assert "H_pose[0," not in out and "H_pose[1,0]" not in out and "H_landmark[1,1]" not in out


def test_observation_checker_names_the_sqrt_typo(capsys):
    from slamlib.exercises import check_observation_jacobians
    from slamlib.models import observation_jacobians
    from slamlib.report import printed_H_pose_slam

    def report(pose, landmark):
        return printed_H_pose_slam(pose, landmark), observation_jacobians(pose, landmark)[1]

    assert check_observation_jacobians(report) is False
    out = capsys.readouterr().out
    assert "H_pose[1,0]" in out and "H_pose[1,1]" in out and "sqrt(q)" in out


def test_observation_checker_catches_an_unwrapped_difference_at_the_seam(capsys):
    # a finite-difference answer that does not wrap the bearing passes the generic points
    # and fails only at the point whose bearing is near pi
    from slamlib.exercises import check_observation_jacobians
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
    from slamlib.exercises import check_observation_jacobians

    def my_observation_jacobians(pose, landmark):
        if kind == "raise":
            raise NotImplementedError
        return None

    assert check_observation_jacobians(my_observation_jacobians) is False
    assert "not written yet" in capsys.readouterr().out


def test_observation_checker_never_raises(capsys):
    from slamlib.exercises import check_observation_jacobians
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
