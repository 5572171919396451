"""The appendix's checker judges finite-difference Jacobians correctly."""

import numpy as np

from slamlib.checks import numerical_jacobian
from slamlib.exercises import check_numerical_jacobian


def forward_difference(f, x, eps=1e-4):
    return np.stack([(f(x + eps * e) - f(x)) / eps for e in np.eye(len(x))], axis=1)


def test_accepts_central_differences():
    assert check_numerical_jacobian(numerical_jacobian, verbose=False)


def test_rejects_one_sided_differences_with_a_hint(capsys):
    assert not check_numerical_jacobian(forward_difference)
    assert "central differences" in capsys.readouterr().out


def test_rejects_transposed_and_stub(capsys):
    assert not check_numerical_jacobian(lambda f, x: numerical_jacobian(f, x).T)
    assert "transposed" in capsys.readouterr().out
    assert not check_numerical_jacobian(lambda f, x: None)
    assert "not written yet" in capsys.readouterr().out


def test_a_student_error_is_reported_not_raised(capsys):
    def broken(f, x):
        raise KeyError("oops")
    assert not check_numerical_jacobian(broken)
    assert "KeyError" in capsys.readouterr().out
