"""Appendix A's exercise checker: a finite-difference Jacobian.

The verdicts follow :mod:`slamlib.course.harness`.
"""

from __future__ import annotations

import numpy as np

from ..checks import compare_jacobians
from .harness import call, name_of, not_ready, printer
from .predictions import check_prediction

__all__ = ["check_numerical_jacobian", "check_best_step", "BEST_STEP_ACCEPT", "WHY_BEST_STEP"]

#: The steps a good argument leads to: kept here, not in the notebook, so that the question
#: does not show its answer above the cell that asks for it.
BEST_STEP_ACCEPT = (1e-6, 1e-4)
#: The argument, printed once the student has committed to a number.
WHY_BEST_STEP = (
    "The truncation error of a central difference is about |f'''| eps^2 / 6, the rounding "
    "error about u |f| / eps (u = 2.2e-16, the spacing of doubles near 1). Their sum is "
    "smallest where both are equal, at eps ~ (3u)^(1/3), about 1e-5 for quantities of order 1, "
    "with an error of about u^(2/3) ~ 1e-11. A one-sided difference would do best near "
    "sqrt(u) ~ 1e-8, with an error of about 1e-8.")


def check_best_step(prediction, measure, verbose: bool = True) -> bool:
    """Appendix A's predict-then-measure: the finite-difference step with the smallest error.

    ``prediction`` is the student's step or None; ``measure() -> (value, text)`` tries the
    steps (run only once a prediction is written). The accepted range is
    :data:`BEST_STEP_ACCEPT`; the argument :data:`WHY_BEST_STEP` is printed in any case
    (:func:`slamlib.course.predictions.check_prediction`).
    """
    return check_prediction(prediction, measure, BEST_STEP_ACCEPT, WHY_BEST_STEP,
                            name="best finite-difference step", verbose=verbose)


def check_numerical_jacobian(fn, verbose: bool = True, eps: float = 1e-3,
                             tol: float = 5e-7) -> bool:
    """Check a student's ``fn(f, x, eps=1e-6, angle_outputs=()) -> J`` (appendix A).

    It is called with ``eps=1e-3`` on functions whose Jacobians are known in
    closed form: a linear map (3 -> 2), a nonlinear one (3 -> 3), the
    range-bearing of a point, and the same for a point just across the
    +-pi seam of the bearing with ``angle_outputs=[1]`` (the difference of an
    angle output must be wrapped). The answer must have shape (outputs,
    inputs) and be within ``tol`` = 5e-7 of the exact Jacobian: a central
    difference is (error of order eps^2, about 1e-7 here), a one-sided one is
    not (order eps, about 1e-3). Named mistakes: a one-sided difference,
    dividing by eps instead of 2 eps, the transpose, an angle difference not
    wrapped, an ``eps`` or ``angle_outputs`` argument that is not accepted.
    """
    say = printer(verbose)

    name = name_of(fn)
    M = np.array([[1.0, -2.0, 0.5], [0.0, 3.0, -1.0]])

    def range_bearing(p):
        return np.array([np.hypot(*p), np.arctan2(p[1], p[0])])

    def range_bearing_jacobian(p):
        return np.array([[p[0], p[1]] / np.hypot(*p), [-p[1] / (p @ p), p[0] / (p @ p)]])

    cases = [
        ("a linear map", lambda x: M @ x, np.array([0.3, -1.2, 2.0]), lambda x: M),
        ("a nonlinear map", lambda x: np.array([x[0] * x[1], np.sin(x[2]), x[0] ** 2 * x[2]]),
         np.array([0.7, -0.4, 1.1]),
         lambda x: np.array([[x[1], x[0], 0.0], [0.0, 0.0, np.cos(x[2])],
                             [2 * x[0] * x[2], 0.0, x[0] ** 2]])),
        ("range and bearing of a point", range_bearing, np.array([1.5, -0.8]),
         range_bearing_jacobian),
        # the point behind the origin, 0.0002 from the -x axis: x +- eps crosses the +-pi seam
        ("range and bearing of a point across the +-pi seam", range_bearing,
         np.array([-1.5, 2e-4]), range_bearing_jacobian),
    ]
    seam = len(cases) - 1

    def one_sided(f, x, sign):
        cols = [sign * (f(x + sign * eps * e) - f(x)) / eps for e in np.eye(x.size)]
        return np.stack(cols, axis=1)

    for n_case, (label, f, x, exact) in enumerate(cases):
        if n_case == seam:
            out, problem = call(lambda f_, x_: fn(f_, x_, eps=eps, angle_outputs=[1]), f,
                                x.copy())
        else:
            out, problem = call(lambda f_, x_: fn(f_, x_, eps=eps), f, x.copy())
        if problem:
            if n_case == seam and problem.startswith("it raised TypeError") \
                    and "angle_outputs" in problem:
                say(f"{name}: {problem}. For {label} the checker calls {name}(f, x, eps={eps:g}, "
                    f"angle_outputs=[1]): define it as def {name}(f, x, eps=1e-6, "
                    f"angle_outputs=()) and wrap the differences of those outputs.")
            elif problem.startswith("it raised TypeError") and "eps" in problem:
                say(f"{name}: {problem}. The checker calls {name}(f, x, eps={eps:g}): "
                    f"define it as def {name}(f, x, eps=1e-6) and use eps as the step.")
            else:
                say(not_ready(name, problem, "it"))
            return False
        try:
            J = np.asarray(out, dtype=float)
        except (TypeError, ValueError):
            say(f"{name}: expected a numeric (m, n) array, got {type(out).__name__}.")
            return False
        Je = exact(x)
        if J.shape != Je.shape:
            transposed = J.shape == Je.T.shape
            hint = " (transposed: rows are outputs, columns inputs)" if transposed else ""
            say(f"{name}: for {label} expected shape {Je.shape}, got {J.shape}{hint}.")
            return False
        err = float(np.max(np.abs(J - Je))) if np.all(np.isfinite(J)) else float("inf")
        if err > tol:
            c = compare_jacobians("J", J, Je, atol=tol, rtol=0.0)
            say(f"{name}: wrong for {label} with eps = {eps:g} (largest error {err:.2e}, "
                f"allowed {tol:.0e}). {c.message}.")
            if np.allclose(J, 2.0 * Je, rtol=1e-4, atol=tol):
                say("  Hint: your J is twice the Jacobian: you divide by eps, but the central "
                    "difference f(x + eps) - f(x - eps) spans 2 eps. Divide by 2 eps.")
            elif any(np.allclose(J, one_sided(f, x, sg), rtol=1e-6, atol=1e-9) for sg in (1, -1)):
                say("  Hint: this is a one-sided difference (f(x + eps) - f(x)) / eps, whose "
                    "error is of order eps. Use the central difference "
                    "(f(x + eps) - f(x - eps)) / (2 eps): its error is of order eps^2.")
            elif n_case == seam and abs(abs(J[1, 1] - Je[1, 1]) * 2 * eps - 2 * np.pi) < 0.1:
                say("  Hint: the bearing jumps from about +pi to about -pi between x - eps and "
                    "x + eps, so its difference is off by 2 pi. Wrap the differences of the "
                    "outputs listed in angle_outputs to [-pi, pi) before dividing.")
            elif err < 1e-2:
                say("  Hint: the error is small but too large for a central difference at this "
                    "eps: is it (f(x + eps e_j) - f(x - eps e_j)) / (2 eps), with the eps the "
                    "checker passes?")
            return False
    say(f"{name}: correct on {len(cases)} functions with known Jacobians (eps = {eps:g}, "
        f"error below {tol:.0e}).")
    return True
