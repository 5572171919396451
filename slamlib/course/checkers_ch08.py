"""Chapter 08's exercise checker: where a late frame goes in the filter's history.

The verdicts follow :mod:`slamlib.course.harness`.
"""

from __future__ import annotations

import operator

import numpy as np

from .harness import attempt, matching_mistakes, name_of, printer
from .predictions import check_prediction

__all__ = ["check_history_index", "check_doubled_latency", "DOUBLED_LATENCY_ACCEPT",
           "WHY_DOUBLED_LATENCY"]

#: The answers a good argument leads to (degrees): kept here, not in the notebook, so that
#: the question does not show its answer above the cell that asks for it.
DOUBLED_LATENCY_ACCEPT = (25.0, 33.0)
#: The argument, printed once the student has committed to a number.
WHY_DOUBLED_LATENCY = (
    "To first order the error is (omega - v sin(beta)/rho) * delay: linear in the delay, so "
    "twice the delay gives about twice the error, 2 x 15.8 = 31.6 deg. It comes out somewhat "
    "less because the fastest turn does not last the whole 0.6 s: averaged over a longer window "
    "the turn rate is lower (the second-order terms of section 1).")


def check_doubled_latency(prediction, measure, verbose: bool = True) -> bool:
    """Chapter 08's predict-then-measure: the largest bearing error of a frame 0.6 s late.

    ``prediction`` is the student's number (degrees) or None; ``measure() -> (value, text)``
    re-simulates the drive (run only once a prediction is written). The accepted range is
    :data:`DOUBLED_LATENCY_ACCEPT`; the argument :data:`WHY_DOUBLED_LATENCY` is printed in
    any case (:func:`slamlib.course.predictions.check_prediction`).
    """
    return check_prediction(prediction, measure, DOUBLED_LATENCY_ACCEPT, WHY_DOUBLED_LATENCY,
                            name="largest bearing error at 0.6 s", unit="deg", verbose=verbose)


def _history_cases(seed: int):
    """Event logs (non-decreasing times, some repeated) and capture times to place in them."""
    rng = np.random.default_rng(seed)
    cases = [([], 0.3), ([0.5], 0.5), ([0.5], 0.4), ([0.5], 0.6)]
    for _ in range(12):
        n = int(rng.integers(3, 25))
        times = np.round(np.cumsum(rng.choice([0.0, 0.02, 0.02, 0.04], size=n)) + 10.0, 6)
        pick = rng.integers(0, 4)
        if pick == 0:
            tc = float(rng.choice(times))                       # exactly an event's time
        elif pick == 1:
            tc = float(rng.uniform(times[0], times[-1] + 1e-9))  # somewhere inside
        elif pick == 2:
            tc = float(times[0] - rng.uniform(0.01, 1.0))       # before the whole log
        else:
            tc = float(times[-1] + rng.uniform(0.0, 0.1))       # at or after the newest event
        cases.append((list(times), tc))
    times = [1.0, 1.02, 1.04, 1.04, 1.04, 1.06]                  # a tie at the capture time
    cases += [(times, 1.04), (np.array(times), 1.04), (times, 1.0), (times, 1.06)]
    return cases


def check_history_index(fn, seed: int = 8, verbose: bool = True) -> bool:
    """Check a student's ``fn(times, t_capture) -> int`` (chapter 08).

    ``times`` are the times of the events in the filter's history (non-decreasing,
    possibly repeated); the answer is where a frame captured at ``t_capture``
    goes: after every event at a time ``<= t_capture``, i.e. the number of such
    events (a prediction at the very instant of the capture comes first, as in
    :meth:`slamlib.runs.Run.events`). The reference is that count, computed here
    by a plain loop. Wrong answers that match ``<`` instead of ``<=``
    (``bisect_left``), an index one too small (the last event's index instead
    of the place after it) or a count from the newest end are named.
    """
    say = printer(verbose)

    name = name_of(fn)
    cases = _history_cases(seed)
    got = []
    for times, tc in cases:
        out = attempt(fn, list(times) if isinstance(times, list) else times.copy(), tc, say=say)
        if out is None:
            return False
        a = np.asarray(out)
        if (a.size != 1 or not np.issubdtype(a.dtype, np.number)
                or not float(a.reshape(-1)[0]).is_integer()):
            say(f"{name}: expected one integer (an index), got {out!r}.")
            return False
        got.append(int(a.reshape(-1)[0]))
    want = [sum(1 for t in times if t <= tc) for times, tc in cases]
    wrong = [i for i in range(len(cases)) if got[i] != want[i]]
    if wrong:
        times, tc = cases[wrong[0]]
        shown = ", ".join(f"{t:g}" for t in times[:8]) + (", ..." if len(times) > 8 else "")
        say(f"{name}: wrong place for t_capture = {tc:g} in times = [{shown}] "
            f"({len(times)} events): got {got[wrong[0]]}, expected {want[wrong[0]]}.")
        rules = {
            "an event at exactly the capture time (the prediction that reached it) happened "
            "BEFORE the frame: count times <= t_capture, not < (bisect_right, not bisect_left)":
                lambda times, tc: sum(1 for t in times if t < tc),
            "that is the index of the last event before the frame; the frame goes AFTER it, "
            "so the answer is one more (the number of such events)":
                lambda times, tc: sum(1 for t in times if t <= tc) - 1,
            "that counts the events AFTER the capture time (the ones to re-apply); the index "
            "is the number of events at or before it":
                lambda times, tc: sum(1 for t in times if t > tc),
        }
        fits = matching_mistakes(rules, got, cases, operator.eq)
        for why in fits or ["the answer is the number of events with a time <= t_capture "
                            "(0 if the frame is older than all of them, len(times) if newer)"]:
            say(f"  Hint: {why}.")
        return False
    say(f"{name}: correct. Right place at {len(cases)} capture times,")
    say("  with ties, an empty history and frames older or newer than every event.")
    return True
