"""The harness every exercise checker of the course shares.

A checker takes the student's function, tries it at several test points (a
fixed seed, so the verdict does not flicker), compares each answer with a
reference the checker computes independently, prints a verdict a student can
act on and returns True or False. It never raises on a student's mistake:

- the function returns None or raises ``NotImplementedError``: "not written yet";
- it raises anything else: the exception is reported;
- it returns the wrong shape or wrong numbers: which entry is wrong, what was
  expected, and a hint naming the mistake when the answer matches a known one
  (a flipped sign, a transpose, swapped columns, ...).

The pieces: :func:`call` runs the student's function, :func:`not_ready` words
the verdict for one that is not written yet or raised, :func:`attempt` does both,
:func:`name_of` names it, :func:`printer` prints (or not, ``verbose=False``), :func:`one_number` and
:func:`shape_problem` check an answer's shape, and :func:`matching_mistakes`
names the known mistakes an answer matches.

The checkers, in chapter order: :mod:`~slamlib.course.checkers_ch00` ...
:mod:`~slamlib.course.checkers_ch11`, :mod:`~slamlib.course.checkers_appendix_a`;
those of the filter the student writes (chapters 03-05, 08) in
:mod:`~slamlib.course.filter_checkers`; predictions in :mod:`~slamlib.course.predictions`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping

import numpy as np

__all__ = ["call", "attempt", "printer", "not_ready", "name_of", "one_number", "shape_problem",
           "vector_answer",
           "matching_mistakes"]


def call(fn, *args):
    """Run the student's function; return ``(result, problem message or None)``."""
    try:
        out = fn(*args)
    except NotImplementedError:
        return None, "not written yet (it raises NotImplementedError)"
    except Exception as exc:  # noqa: BLE001 - a student's bug is reported, not raised
        return None, f"it raised {type(exc).__name__}: {exc}"
    if out is None:
        return None, "not written yet (it returns None)"
    return out, None


def attempt(fn, *args, say, what: str = "it"):
    """Run the student's function: its answer, or None after ``say`` printed why there is none.

    The common first step of a checker: ``out = attempt(fn, x, say=say, what="A and W")``,
    then ``if out is None: return False``.
    """
    out, problem = call(fn, *args)
    if problem:
        say(not_ready(name_of(fn), problem, what))
        return None
    return out


def printer(verbose: bool):
    """``print`` if verbose, else a function that prints nothing."""
    return print if verbose else (lambda *args, **kwargs: None)


def not_ready(name: str, problem: str, what: str = "it") -> str:
    """The verdict for a function that is not written yet or raised."""
    todo = f"Write {what}" if problem.startswith("not written") else "Fix it"
    return f"{name}: {problem}. {todo}, then run this cell again."


def name_of(fn) -> str:
    """The student's function's name, for the verdicts."""
    return getattr(fn, "__name__", "your function")


def one_number(value) -> float:
    """``value`` as a float if it holds exactly one number, else a ValueError saying its shape."""
    a = np.asarray(value, dtype=float)
    if a.size != 1:
        raise ValueError(f"expected one number, got shape {a.shape}")
    return float(a.reshape(-1)[0])


def shape_problem(what: str, value, shape: tuple[int, ...]) -> str | None:
    """None if ``value`` is a numeric array of ``shape``, else the sentence that says why not."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return f"{what}: expected a numeric array of shape {shape}, got {type(value).__name__}"
    if arr.shape != shape:
        return f"{what}: expected shape {shape}, got shape {arr.shape}"
    return None


def vector_answer(value, size: int, what: str) -> tuple[np.ndarray | None, str | None]:
    """A student's answer as a float vector of ``size`` entries: ``(array, None)``, or
    ``(None, the sentence that says why not)`` (``what`` names the expected answer)."""
    try:
        got = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        return None, f"expected {what}, got {value!r}"
    if got.shape != (size,):
        return None, f"expected {what} of shape ({size},), got {got.size} value(s)"
    return got, None


def matching_mistakes(mistakes: Mapping[str, Callable[..., object]], answers: Iterable,
                      cases: Iterable, same: Callable[[object, object], bool]) -> list[str]:
    """The descriptions of the known mistakes that reproduce every answer.

    ``mistakes`` maps a hint to a wrong rule ``rule(*case)``; a hint is kept
    when ``same(rule(*case), answer)`` holds for every case.
    """
    answers, cases = list(answers), list(cases)
    return [why for why, rule in mistakes.items()
            if all(same(rule(*c), a) for c, a in zip(cases, answers))]
