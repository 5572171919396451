"""Chapter 01's checkers: the motion model and its Jacobians A and W, and the two
predict-then-measure questions about the heading's uncertainty.

The verdicts follow :mod:`slamlib.course.harness`; the predictions follow
:mod:`slamlib.course.predictions` (the answer and its argument are printed only once the
student has written a prediction).
"""

from __future__ import annotations

import numpy as np

from ..checks import compare_jacobians, numerical_jacobian
from ..models import KOBUKI_WHEEL_BASE, motion_model, motion_model_batch, wrap_angle
from .harness import attempt, name_of, printer, vector_answer
from .predictions import check_prediction

__all__ = ["check_motion_jacobians", "check_halved_Q_prediction", "check_bound_ratio_prediction"]

_TURN_RATE = ("the turn rate is omega = (V_L - V_R)/b in the z-down frame (a faster left wheel "
              "turns the robot clockwise seen from above); (V_R - V_L)/b is the z-up ROS formula")


def _random_motion_points(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        x = np.array([rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-np.pi, np.pi)])
        u = rng.uniform(-0.5, 0.5, size=2)
        while abs(u[0] - u[1]) < 0.05:           # a real turn, so that its sign shows
            u = rng.uniform(-0.5, 0.5, size=2)
        dt = float(rng.uniform(0.01, 0.5))
        yield x, u, dt


def _same_pose(a, b) -> bool:
    """Two poses equal, headings compared modulo 2 pi."""
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    d[2] = wrap_angle(d[2])
    return bool(np.allclose(d, 0.0, atol=1e-9, rtol=0.0))


def _check_model(model, points, wheel_base: float, say) -> str | None:
    """The student's motion model against :func:`slamlib.models.motion_model`.

    Returns ``"right"``, ``"turn sign"`` (it equals the model with omega negated, that is
    with the wheels swapped), ``"wrong"`` (a verdict was printed) or None (not written or
    raised; printed too).
    """
    name = name_of(model)
    verdicts = []
    for x, u, dt in points:
        out = attempt(model, x.copy(), u.copy(), dt, wheel_base, say=say, what="the motion model")
        if out is None:
            return None
        got, problem = vector_answer(out, 3, "a pose [x, y, theta]")
        if problem:
            say(f"{name}: {problem}.")
            return "wrong"
        expected = motion_model(x, u, dt, wheel_base)
        if _same_pose(got, expected):
            verdicts.append("right")
        elif _same_pose(got, motion_model(x, u[::-1], dt, wheel_base)):
            verdicts.append("turn sign")              # omega negated = the wheels swapped
        else:
            say(f"{name}: not right yet at x = [{x[0]:.3f}, {x[1]:.3f}, {x[2]:.3f}], "
                f"u = [{u[0]:.3f}, {u[1]:.3f}], dt = {dt:.3f}: expected "
                f"{np.array2string(expected, precision=5)}, "
                f"got {np.array2string(got, precision=5)}.")
            say("  Hint: one Euler step with the heading at the START of the step, "
                "V = (V_R + V_L)/2, and " + _TURN_RATE + ".")
            return "wrong"
    if len(set(verdicts)) > 1:
        say(f"{name}: right at some test points and turning the wrong way at others. "
            "Hint: " + _TURN_RATE + ".")
        return "wrong"
    return verdicts[0]


def check_motion_jacobians(fn, n_points: int = 5, seed: int = 1,
                           wheel_base: float = KOBUKI_WHEEL_BASE, verbose: bool = True, *,
                           model=None) -> bool:
    """Check a student's ``fn(x, u, dt, b) -> (A, W)`` against finite differences (chapter 01).

    ``A = df/dx_{k-1}`` (3x3) and ``W = df/dw`` (3x2; w is the noise on ``[V_R, V_L]``,
    so W has the entries of df/du) of :func:`slamlib.models.motion_model` are compared with central
    differences at ``n_points`` random poses, wheel speeds and time steps.

    ``model``: the student's own motion model ``model(x, u, dt, b) -> x_next``, checked
    first. Two different mistakes give the same wrong W (its last row negated): W's
    columns in the wrong order, or a turn rate of the wrong sign. With the model the
    checker tells them apart: a model that turns the wrong way is the cause; a model that
    turns the right way leaves the column order.

    Returns
    -------
    bool
        True if the model (when given) and both Jacobians are right at every point. A
        verdict is printed.
    """
    say = printer(verbose)
    name = name_of(fn)
    points = list(_random_motion_points(n_points, seed))
    model_verdict = None
    if model is not None:
        model_verdict = _check_model(model, points, wheel_base, say)
        if model_verdict is None:
            return False
        if model_verdict == "wrong":
            say("  Fix the motion model first: A and W are its derivatives.")
            return False
        if model_verdict == "turn sign":
            say(f"{name_of(model)}: turns the wrong way: its heading changes by -omega dt at "
                f"every test point. Hint: {_TURN_RATE}.")
    for i, (x, u, dt) in enumerate(points):
        out = attempt(fn, x.copy(), u.copy(), dt, wheel_base, say=say, what="A and W")
        if out is None:
            return False
        if not isinstance(out, (tuple, list)) or len(out) != 2:
            if isinstance(out, (tuple, list)):
                what = f"a {type(out).__name__} of {len(out)}"
            elif isinstance(out, np.ndarray):
                what = f"one numpy array of shape {out.shape}"
            else:
                what = f"a {type(out).__name__}"
            say(f"{name}: expected a pair (A, W), got {what}. Return A, W.")
            return False
        A, W = out
        A_ref = numerical_jacobian(lambda s, u=u, dt=dt: motion_model(s, u, dt, wheel_base), x,
                                   angle_outputs=(2,))
        W_ref = numerical_jacobian(lambda v, x=x, dt=dt: motion_model(x, v, dt, wheel_base), u,
                                   angle_outputs=(2,))
        where = (f"at x = [{x[0]:.3f}, {x[1]:.3f}, {x[2]:.3f}], u = [{u[0]:.3f}, {u[1]:.3f}], "
                 f"dt = {dt:.3f}, b = {wheel_base}")
        bad = [c for c in (compare_jacobians("A", A, A_ref, atol=1e-6, rtol=1e-5),
                           compare_jacobians("W", W, W_ref, atol=1e-6, rtol=1e-5)) if not c.ok]
        if bad:
            say(f"{name}: not right yet (test point {i + 1} of {n_points}, {where}).")
            W_arr = np.asarray(W, dtype=float) if np.shape(W) == (3, 2) else None
            last_row_flipped = (W_arr is not None and np.all(np.isfinite(W_arr))
                                and np.allclose(W_arr[:, ::-1], W_ref, atol=1e-6, rtol=1e-5)
                                and not np.allclose(W_arr, W_ref, atol=1e-6, rtol=1e-5))
            if last_row_flipped and model_verdict == "turn sign":
                say("  The cause is the turn rate's sign, not W's column order: your W is the "
                    "right derivative of your own motion model, and that model turns the wrong "
                    "way. Fix omega in both; W's last row then becomes [-dt/b, dt/b].")
            elif last_row_flipped and model_verdict == "right":
                say("  Your W columns are swapped: column 0 is d/dw_R and column 1 is d/dw_L, "
                    "the noise on V_R and on V_L (u = [V_R, V_L]). Your motion model turns the "
                    "right way, so the turn rate's sign is not the cause.")
            elif last_row_flipped:
                say("  W's last row has the wrong sign. Two different mistakes give exactly this "
                    "W: its columns swapped (column 0 must be d/dw_R, the noise on V_R, as "
                    "u = [V_R, V_L]), or a turn rate of the wrong sign: " + _TURN_RATE + ". "
                    "Pass your motion model too (model=my_motion_model) and the checker tells "
                    "you which.")
            for c in bad:
                say("  " + c.message)
            if not last_row_flipped:
                say("  Hint: A is the derivative with respect to the previous pose x_{k-1}; "
                    "W's columns are d/dw_R and d/dw_L (w the noise on [V_R, V_L]), and "
                    + _TURN_RATE + ".")
            return False
    if model_verdict == "turn sign":
        say(f"{name}: A and W match finite differences of the course's model, but your model "
            "does not: fix its turn rate.")
        return False
    what = ("your motion model matches the course's, and A and W match finite differences"
            if model is not None else "A and W match finite differences")
    say(f"{name}: correct: {what} at {n_points} random points.")
    return True


# ----------------------------------------------------------------- predict, then measure
def _heading_2sigma(run, Q, n_runs: int, seed: int, steps) -> np.ndarray:
    """2 sigma (deg) of the heading of ``n_runs`` seeded noisy copies of the run's recorded
    controls (noise ~ N(0, Q) on each wheel speed at each step), after each of ``steps``
    encoder steps, about the dead-reckoned heading."""
    u, dt = run.controls()
    rng = np.random.default_rng(seed)
    L = np.linalg.cholesky(np.asarray(Q, dtype=float))
    X = np.tile(np.asarray(run.start_pose, dtype=float), (n_runs, 1))
    x = np.asarray(run.start_pose, dtype=float)
    out, want = [], set(int(k) for k in steps)
    for k in range(dt.size):
        X = motion_model_batch(X, u[k] + rng.standard_normal((n_runs, 2)) @ L.T, dt[k],
                               run.wheel_base)
        x = motion_model(x, u[k], dt[k], run.wheel_base)
        if k + 1 in want:
            out.append(np.degrees(2.0 * np.std(wrap_angle(X[:, 2] - x[2]))))
    return np.array(out)


WHY_HALVED_Q = ("A leaves the heading alone (its last row is [0, 0, 1]), so each step adds the "
                "heading row of W Q W^T, (dt/b)^2 (Q_RR + Q_LL), to the heading variance: it is "
                "linear in Q. Half the variance is 1/sqrt(2) of the sigma: 15.5 / 1.41 = 11.0 "
                "deg, not half of it (7.7 deg).")

WHY_RATIO = ("Each 0.02 s step adds the same (dt/b)^2 (Q_RR + Q_LL) to the heading variance, "
             "whatever the robot does: the variance grows linearly with time, like a random "
             "walk, so the sigma grows with the square root of time. Four times as long gives "
             "sqrt(4) = 2 times the bound (not 4).")


def check_halved_Q_prediction(answer, run, *, n_runs: int = 2000, seed: int = 2,
                              verbose: bool = True) -> bool:
    """Chapter 01, prediction 1: the 2 sigma heading bound after the loop with Q halved (deg).

    Measured (only once ``answer`` is written) by the prediction-only EKF with ``Q/2``
    (:func:`slamlib.runner.dead_reckoning`) and by ``n_runs`` seeded noisy runs.
    """
    from ..runner import dead_reckoning

    def measure():
        Q_half = run.Q() / 2
        bound = np.degrees(2.0 * np.sqrt(dead_reckoning(run, Q=Q_half).P[-1, 2, 2]))
        n_steps = run.controls()[1].size
        spread = _heading_2sigma(run, Q_half, n_runs, seed, [n_steps])[0]
        return bound, (f"linearised 2σ with Q/2; the heading of {n_runs} seeded noisy runs "
                       f"with Q/2 spreads by 2σ = {spread:.1f} deg")

    return check_prediction(answer, measure, accept=(10.0, 12.0), why=WHY_HALVED_Q,
                            name="2σ heading bound with Q/2", unit="deg", verbose=verbose)


def check_bound_ratio_prediction(answer, run, *, t_early: float = 15.0, n_runs: int = 2000,
                                 seed: int = 3, verbose: bool = True) -> bool:
    """Chapter 01, prediction 2: the 2 sigma heading bound at the end of the loop divided by
    the bound at ``t_early`` s.

    Measured (only once ``answer`` is written) by the prediction-only EKF and by
    ``n_runs`` seeded noisy runs.
    """
    from ..runner import dead_reckoning

    def measure():
        tr = dead_reckoning(run)
        k_early = int(np.argmin(np.abs(tr.t - t_early)))
        ratio = np.sqrt(tr.P[-1, 2, 2] / tr.P[k_early, 2, 2])
        n_steps = run.controls()[1].size
        s_early, s_end = _heading_2sigma(run, run.Q(), n_runs, seed, [k_early, n_steps])
        return ratio, (f"linearised bounds at {tr.t[k_early]:.1f} s and {tr.t[-1]:.1f} s; "
                       f"{n_runs} seeded noisy runs give {s_end / s_early:.2f}")

    return check_prediction(answer, measure, accept=(1.8, 2.2), why=WHY_RATIO,
                            name="ratio of the 2σ heading bounds", verbose=verbose)
