"""Predict, then measure: the student commits to an expectation, then the cell measures it.

:func:`check_prediction` takes the student's answer (a number or one of a few
choices, written into a variable *before* anything is measured), the
measurement (a function, run only once an answer is given, so that a stub
reveals nothing) and the range of answers a good argument leads to. It
prints what was measured, whether the answer was in the accepted range, and
the argument in either case. The harness is that of :mod:`slamlib.course.harness`:
``None`` is "not written yet".
"""

from __future__ import annotations

import numbers
from collections.abc import Callable, Sequence

import numpy as np

from .harness import printer

__all__ = ["check_prediction"]


def check_prediction(answer, measure: Callable[[], tuple[object, str]], accept, why: str, *,
                     name: str = "your prediction", choices: Sequence[str] | None = None,
                     unit: str = "", verbose: bool = True) -> bool:
    """Compare a student's prediction with a measurement and explain (chapters 01, 04, 08).

    Parameters
    ----------
    answer : float, str or None
        The student's prediction: a number, or one of ``choices``. ``None``: not
        written yet (nothing is measured).
    measure : callable
        ``measure() -> (value, text)``: the measured value (a number, or one of
        ``choices``) and a line saying how it was measured (seeds, runs).
    accept : (float, float) or collection of str
        The range of numbers (inclusive) or the choices a justified
        prediction falls in.
    why : str
        The argument that leads to the accepted range (printed in any case).
    name, unit : str
        What the prediction is called and its unit, for the printout.
    choices : sequence of str, optional
        The allowed answers for a multiple-choice prediction.

    Returns
    -------
    bool
        True if the answer lies in the accepted range. The verdict is printed.
    """
    say = printer(verbose)
    if answer is None:
        say(f"{name}: not written yet (it is None). Write your prediction into the variable "
            "first; this cell then measures it.")
        return False
    if choices is not None:
        if not isinstance(answer, str) or answer not in choices:
            say(f"{name}: expected one of {', '.join(repr(c) for c in choices)}, got {answer!r}.")
            return False
        ok = answer in set(accept)
        shown = repr(answer)
        wanted = " or ".join(repr(a) for a in accept)
    else:
        if isinstance(answer, bool) or not isinstance(answer, (numbers.Real, np.floating,
                                                                np.integer)):
            say(f"{name}: expected a number{f' (in {unit})' if unit else ''}, got {answer!r}.")
            return False
        lo, hi = (float(v) for v in accept)
        ok = lo <= float(answer) <= hi
        shown = f"{float(answer):g}{f' {unit}' if unit else ''}"
        wanted = f"{lo:g} to {hi:g}{f' {unit}' if unit else ''}"
    value, how = measure()
    if choices is not None:
        measured = repr(value)
    else:
        measured = f"{float(value):.4g}" + (f" {unit}" if unit else "")
    say(f"{name}: you predicted {shown}; measured {measured} ({how}).")
    if ok:
        say(f"  Right: a justified prediction is {wanted}. {why}")
    else:
        say(f"  Not quite: a justified prediction is {wanted}. {why}")
    return ok
