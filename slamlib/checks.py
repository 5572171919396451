"""Numerical checks: finite-difference Jacobians and their comparison.

Used by the tests, the exercise checkers and the errata appendix to decide
whether an analytic Jacobian (the library's, the report's or a student's) is
right, and which entry is wrong if not.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .models import wrap_angle

__all__ = ["numerical_jacobian", "JacobianComparison", "compare_jacobians"]


def numerical_jacobian(f: Callable[[np.ndarray], np.ndarray], x, eps: float = 1e-6,
                       angle_outputs: Sequence[int] = ()) -> np.ndarray:
    """Central-difference Jacobian ``df/dx`` at ``x``.

    Parameters
    ----------
    f : callable
        Maps a 1-D array to a 1-D array.
    x : array_like, shape (n,)
        Where to differentiate.
    eps : float
        Step (absolute).
    angle_outputs : sequence of int
        Indices of outputs that are angles: their differences are wrapped to
        [-pi, pi) so that a value on the +-pi seam differentiates correctly.

    Returns
    -------
    numpy.ndarray, shape (m, n)
    """
    x = np.asarray(x, dtype=float)
    cols = []
    for i in range(x.size):
        step = np.zeros_like(x)
        step[i] = eps
        d = np.asarray(f(x + step), dtype=float) - np.asarray(f(x - step), dtype=float)
        for k in angle_outputs:
            d[k] = wrap_angle(d[k])
        cols.append(d / (2.0 * eps))
    return np.stack(cols, axis=-1)


@dataclass
class JacobianComparison:
    """Outcome of comparing an analytic Jacobian with a reference.

    Attributes
    ----------
    name : str
        What was compared (for messages), e.g. ``"A"``.
    ok : bool
        True when every entry agrees within tolerance.
    wrong : list of tuple
        ``(row, col, got, expected)`` for each entry that disagrees.
    message : str
        A sentence a student can act on.
    max_error : float
        The largest ``|got - expected|`` over ALL entries (right ones included),
        so that a passing formula's agreement can be shown too; ``inf`` when
        the shapes differ or ``got`` is not numeric.
    """

    name: str
    ok: bool
    wrong: list
    message: str
    max_error: float = float("inf")

    def __bool__(self) -> bool:
        return self.ok


def compare_jacobians(name: str, got, expected, atol: float = 1e-6, rtol: float = 1e-5
                      ) -> JacobianComparison:
    """Compare ``got`` with ``expected`` entry by entry; say which entries differ."""
    expected = np.asarray(expected, dtype=float)
    try:
        got = np.asarray(got, dtype=float)
    except (TypeError, ValueError):
        return JacobianComparison(name, False, [], f"{name}: not a numeric array: {got!r}")
    if got.shape != expected.shape:
        return JacobianComparison(name, False, [],
                                  f"{name}: shape {got.shape}, expected {expected.shape}")
    diff = np.abs(got - expected)
    max_error = float(np.max(diff)) if diff.size else 0.0
    if not np.all(np.isfinite(diff)):
        max_error = float("inf")
    bad = ~np.isclose(got, expected, atol=atol, rtol=rtol)
    wrong = [(int(i), int(j), float(got[i, j]), float(expected[i, j]))
             for i, j in zip(*np.nonzero(bad))]
    if not wrong:
        return JacobianComparison(name, True, [], f"{name}: correct", max_error)
    parts = []
    for i, j, g, e in wrong:
        hint = " (sign flipped)" if np.isclose(g, -e, atol=atol, rtol=rtol) else ""
        parts.append(f"{name}[{i},{j}] = {g:.6g}, expected {e:.6g}{hint}")
    return JacobianComparison(name, False, wrong, f"{name}: wrong entries: " + "; ".join(parts),
                              max_error)
