"""The predict-then-measure questions of chapter 08 and appendix A: the accepted ranges hold
what a measurement gives, and the notebooks do not show the answer above the question."""

from pathlib import Path

import nbformat
import numpy as np

from slamlib.course.checkers_appendix_a import BEST_STEP_ACCEPT, check_best_step
from slamlib.course.checkers_ch08 import DOUBLED_LATENCY_ACCEPT, check_doubled_latency

ROOT = Path(__file__).resolve().parent.parent


def _measure(value, calls):
    def measure():
        calls.append(1)
        return value, "measured here"
    return measure


def test_nothing_is_measured_before_a_prediction_is_written(capsys):
    calls = []
    assert not check_doubled_latency(None, _measure(29.0, calls))
    assert not check_best_step(None, _measure(1e-5, calls))
    assert calls == []
    assert capsys.readouterr().out.count("not written yet") == 2


def test_a_prediction_in_the_range_passes_and_one_outside_fails(capsys):
    calls = []
    assert check_doubled_latency(31.6, _measure(29.0, calls))
    assert not check_doubled_latency(15.8, _measure(29.0, calls))     # the 0.3 s answer again
    assert check_best_step(1e-5, _measure(1e-5, calls))
    assert not check_best_step(1e-8, _measure(1e-5, calls))         # a one-sided step's optimum
    out = capsys.readouterr().out
    assert "linear in the delay" in out and "(3u)^(1/3)" in out


def test_the_best_step_range_holds_an_independent_measurement():
    # central differences of sin at points of order 1: the step of the smallest error
    steps = 10.0 ** -np.arange(1, 13)
    best = []
    for x in np.linspace(0.3, 1.3, 11):
        err = [abs((np.sin(x + h) - np.sin(x - h)) / (2 * h) - np.cos(x)) for h in steps]
        best.append(steps[int(np.argmin(err))])
    lo, hi = BEST_STEP_ACCEPT
    assert lo <= float(np.median(best)) <= hi
    assert lo <= (3 * np.finfo(float).eps) ** (1 / 3) <= hi
    assert not lo <= np.sqrt(np.finfo(float).eps) <= hi        # the one-sided optimum is outside


def test_the_doubled_latency_range_holds_the_measured_error():
    from slamlib import delay
    from slamlib.models import observe, wrap_angle

    run = delay.delayed_run(0.6)
    lm = run.world().landmarks()
    c = run.camera
    sel = c.true_id >= 0
    pose = run.truth_at(c.t_arrival[sel])
    err = [wrap_angle(b - observe(p, lm[i])[1])
           for b, p, i in zip(c.true_bearing[sel], pose, c.true_id[sel])]
    worst = float(np.degrees(np.max(np.abs(err))))
    lo, hi = DOUBLED_LATENCY_ACCEPT
    assert lo <= worst <= hi
    assert lo <= 2 * 15.8 <= hi                                 # the first-order argument


def _cells_before_question(path, variable):
    cells = nbformat.read(path, as_version=4).cells
    k = next(i for i, c in enumerate(cells)
             if c.cell_type == "code" and c.source.lstrip().startswith(
                 ("from", variable)) and f"{variable} = None" in c.source)
    return cells[:k + 1]


def test_the_questions_do_not_show_their_answers_above_them():
    shown = _cells_before_question(ROOT / "notebooks" / "08_camera_delay.ipynb",
                                   "my_largest_error_at_06")
    text = "\n".join(c.source for c in shown)
    assert "31.6" not in text and "25.0, 33.0" not in text and "linear in the delay" not in text
    shown = _cells_before_question(ROOT / "notebooks" / "A_errata.ipynb", "my_best_step")
    text = "\n".join(c.source for c in shown)
    assert "(3u)" not in text and "1e-6, 1e-4" not in text and "u^(2/3)" not in text
