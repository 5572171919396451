"""Chapter 09's checker: right answers pass, each named mistake gets its hint."""

import numpy as np
import pytest

from slamlib.course.checkers_ch09 import check_joint_distance, joint_distance_cases


def _S(H, P, R):
    m = R.shape[0]
    blocks = np.zeros((2 * m, 2 * m))
    for q in range(m):
        blocks[2 * q:2 * q + 2, 2 * q:2 * q + 2] = R[q]
    return H @ P @ H.T + blocks


def right(y, H, P, R):
    yv = y.reshape(-1)
    return float(yv @ np.linalg.solve(_S(H, P, R), yv))


def right_with_inverse(y, H, P, R):
    yv = y.reshape(-1)
    return yv @ np.linalg.inv(_S(H, P, R)) @ yv


def sum_of_individual(y, H, P, R):
    S = _S(H, P, R)
    return sum(float(y[q] @ np.linalg.solve(S[2 * q:2 * q + 2, 2 * q:2 * q + 2], y[q]))
               for q in range(R.shape[0]))


def no_R(y, H, P, R):
    yv = y.reshape(-1)
    return float(yv @ np.linalg.solve(H @ P @ H.T, yv))


def S_not_inverse(y, H, P, R):
    yv = y.reshape(-1)
    return float(yv @ _S(H, P, R) @ yv)


def distance(y, H, P, R):
    return np.sqrt(right(y, H, P, R))


def one_R(y, H, P, R):
    return right(y, H, P, np.broadcast_to(R[0], R.shape))


def ranges_first(y, H, P, R):
    yv = y.T.reshape(-1)
    return float(yv @ np.linalg.solve(_S(H, P, R), yv))


def stub(y, H, P, R):
    return None


def test_right_answers_pass(capsys):
    assert check_joint_distance(right)
    assert check_joint_distance(right_with_inverse)
    assert "correct" in capsys.readouterr().out


@pytest.mark.parametrize("fn, hint", [
    (sum_of_individual, "SUM of the individual distances"),
    (no_R, "R is missing"),
    (S_not_inverse, "S where S^-1 belongs"),
    (distance, "returns D, not D^2"),
    (one_R, "R[0] for every reading"),
    (ranges_first, "ranges..., bearings..."),
])
def test_each_mistake_is_named(fn, hint, capsys):
    assert not check_joint_distance(fn)
    out = capsys.readouterr().out
    assert "wrong" in out and hint in out


def test_stub_and_errors(capsys):
    assert not check_joint_distance(stub)
    assert "not written yet" in capsys.readouterr().out

    def boom(y, H, P, R):
        raise KeyError("x")
    assert not check_joint_distance(boom)
    assert "raised KeyError" in capsys.readouterr().out


def test_the_cases_make_the_cross_terms_matter():
    # the verdict says the sum of the individual distances would fail at every case
    for y, H, P, R in joint_distance_cases():
        assert not np.isclose(sum_of_individual(y, H, P, R), right(y, H, P, R), rtol=1e-3)
