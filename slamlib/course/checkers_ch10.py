"""Chapter 10's exercise checker: logged commands (v, w_up) into wheel speeds [V_R, V_L].

:func:`check_wheel_speeds_from_commands` checks a student's conversion of a
logged command ``(v, w_up)`` (forward speed, z-up yaw rate) into the wheel
speeds ``[V_R, V_L]`` the course's filters take (z-down: ``w = (V_L - V_R)/b``).
"""

from __future__ import annotations

import numpy as np

from .harness import attempt, name_of, printer, vector_answer

__all__ = ["check_wheel_speeds_from_commands"]


def _reference(v: float, w_up: float, b: float) -> np.ndarray:
    # solve  (V_R + V_L)/2 = v  and  (V_L - V_R)/b = -w_up  as a linear system
    A = np.array([[0.5, 0.5], [-1.0 / b, 1.0 / b]])
    return np.linalg.solve(A, np.array([v, -w_up]))

def check_wheel_speeds_from_commands(fn, n_points: int = 12, seed: int = 10,
                                     verbose: bool = True) -> bool:
    """Check ``fn(v, w_up, b) -> [V_R, V_L]`` at ``n_points`` seeded commands (chapter 10).

    The reference solves ``(V_R + V_L)/2 = v``, ``(V_L - V_R)/b = -w_up`` as a
    2x2 linear system. Known mistakes are named: the z-up formula (the yaw
    rate not negated, equivalently the wheels swapped), ``b w`` instead of
    ``b w / 2`` (or ``w / b``), the pair returned as ``[V_L, V_R]``.
    """
    say = printer(verbose)
    name = name_of(fn)
    rng = np.random.default_rng(seed)
    cases = [(float(rng.uniform(-0.1, 0.3)), float(rng.uniform(-1.0, 1.0)),
              float(rng.choice([0.23, 0.26, 0.35]))) for _ in range(n_points)]
    for v, w, b in cases:
        out = attempt(fn, v, w, b, say=say)
        if out is None:
            return False
        got, problem = vector_answer(out, 2, "a pair [V_R, V_L]")
        if problem:
            say(f"{name}: {problem}")
            return False
        ref = _reference(v, w, b)
        if np.allclose(got, ref, atol=1e-12, rtol=1e-9):
            continue
        where = f"at v = {v:.3f} m/s, w_up = {w:.3f} rad/s, b = {b} m"
        hints = {
            "the yaw rate is not negated: that is the z-up formula w = (V_R - V_L)/b. "
            "In the course's z-down frame w_down = -w_up = (V_L - V_R)/b": ref[::-1],
            "the difference of the wheel speeds is b w, so each wheel differs from v by "
            "b w / 2, not b w": v + (ref - v) * 2.0,
            "each wheel differs from v by b w / 2 (a speed), not w / (2 b)":
                v + (ref - v) / (b * b),
        }
        for hint, val in hints.items():
            if np.allclose(got, val, atol=1e-12, rtol=1e-9):
                say(f"{name}: wrong {where}: got [{got[0]:.4f}, {got[1]:.4f}], expected "
                    f"[{ref[0]:.4f}, {ref[1]:.4f}]. Hint: {hint}.")
                return False
        say(f"{name}: wrong {where}: got [{got[0]:.4f}, {got[1]:.4f}], expected "
            f"[V_R, V_L] = [{ref[0]:.4f}, {ref[1]:.4f}] (their mean is v, their difference "
            f"V_L - V_R is -b w_up).")
        return False
    say(f"{name}: correct. [V_R, V_L] match at {n_points} commands (wheel bases 0.23 to "
        f"0.35 m), and the filter's motion model gives back v and -w_up.")
    return True
