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
