"""The appendix's checker judges finite-difference Jacobians correctly.

The checker calls the student's function with eps = 1e-3 and allows an error
of 5e-7: a central difference passes (about 1e-7), a one-sided one fails
(about 1e-3), and each known mistake gets its own hint.
"""

import numpy as np

from slamlib.checks import numerical_jacobian
from slamlib.course.checkers_appendix_a import check_numerical_jacobian


def forward_difference(f, x, eps=1e-6):
    return np.stack([(f(x + eps * e) - f(x)) / eps for e in np.eye(len(x))], axis=1)


def backward_difference(f, x, eps=1e-6):
    return np.stack([(f(x) - f(x - eps * e)) / eps for e in np.eye(len(x))], axis=1)


def central_over_eps(f, x, eps=1e-6):
    return np.stack([(f(x + eps * e) - f(x - eps * e)) / eps for e in np.eye(len(x))], axis=1)


def test_accepts_central_differences(capsys):
    assert check_numerical_jacobian(numerical_jacobian)
    assert "correct" in capsys.readouterr().out


def test_uses_the_eps_it_passes():
    # a central difference with a large step is not accurate enough: the eps is really used
    seen = []

    def spy(f, x, eps=1e-6, angle_outputs=()):
        seen.append(eps)
        return numerical_jacobian(f, x, eps=eps, angle_outputs=angle_outputs)

    assert check_numerical_jacobian(spy, verbose=False)
    assert set(seen) == {1e-3}
    assert not check_numerical_jacobian(lambda f, x, eps=1e-6: numerical_jacobian(f, x, eps=0.05),
                                        verbose=False)


def test_rejects_one_sided_differences_with_a_hint(capsys):
    for fd in (forward_difference, backward_difference):
        assert not check_numerical_jacobian(fd)
        out = capsys.readouterr().out
        assert "one-sided" in out and "central difference" in out


def test_a_one_sided_difference_that_ignores_eps_fails_too(capsys):
    # eps = 1e-6 hard-coded: error about 1e-6, still above the tolerance
    assert not check_numerical_jacobian(lambda f, x, eps=1e-6: forward_difference(f, x, 1e-6))
    assert "too large" in capsys.readouterr().out


def test_dividing_by_eps_gets_its_own_hint(capsys):
    assert not check_numerical_jacobian(central_over_eps)
    out = capsys.readouterr().out
    assert "divide by 2 eps" in out.lower()
    assert "one-sided" not in out


def test_rejects_transposed_and_stub(capsys):
    assert not check_numerical_jacobian(lambda f, x, eps=1e-6: numerical_jacobian(f, x, eps).T)
    assert "transposed" in capsys.readouterr().out
    assert not check_numerical_jacobian(lambda f, x, eps=1e-6: None)
    assert "not written yet" in capsys.readouterr().out


def test_a_function_without_eps_is_told_the_signature(capsys):
    assert not check_numerical_jacobian(lambda f, x: numerical_jacobian(f, x))
    out = capsys.readouterr().out
    assert "eps=1e-6" in out and "TypeError" in out


def test_a_student_error_is_reported_not_raised(capsys):
    def broken(f, x, eps=1e-6):
        raise KeyError("oops")
    assert not check_numerical_jacobian(broken)
    assert "KeyError" in capsys.readouterr().out


def central_without_wrap(f, x, eps=1e-6, angle_outputs=()):
    return np.stack([(f(x + eps * e) - f(x - eps * e)) / (2 * eps) for e in np.eye(len(x))],
                    axis=1)


def test_an_unwrapped_angle_difference_fails_at_the_seam_with_a_hint(capsys):
    # right on the three smooth cases, wrong across the +-pi seam: the hint names the wrap
    assert not check_numerical_jacobian(central_without_wrap)
    out = capsys.readouterr().out
    assert "seam" in out and "2 pi" in out and "Wrap" in out


def test_a_function_without_angle_outputs_is_told_the_signature(capsys):
    assert not check_numerical_jacobian(lambda f, x, eps=1e-6: numerical_jacobian(f, x, eps))
    out = capsys.readouterr().out
    assert "angle_outputs=()" in out and "TypeError" in out


def test_the_seam_case_really_crosses_the_seam():
    # the bearing of the seam point at x - eps and x + eps differs by almost 2 pi unwrapped
    p, eps = np.array([-1.5, 2e-4]), 1e-3
    b = [np.arctan2(q[1], q[0]) for q in (p - eps * np.eye(2)[1], p + eps * np.eye(2)[1])]
    assert abs(b[1] - b[0]) > 6.0
