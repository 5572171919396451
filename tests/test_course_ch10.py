"""Chapter 10's checker: right answers pass, each known mistake is named."""

import numpy as np

from slamlib.course.checkers_ch10 import check_wheel_speeds_from_commands
from slamlib.datasets.mrclam import commands_to_wheel_speeds
from slamlib.models import body_velocity


def right(v, w_up, b):
    return [v + 0.5 * b * w_up, v - 0.5 * b * w_up]


def test_a_right_answer_passes_and_agrees_with_the_library_and_the_motion_model(capsys):
    assert check_wheel_speeds_from_commands(right)
    assert "correct" in capsys.readouterr().out
    u = commands_to_wheel_speeds([0.2], [0.5], 0.23)[0]
    np.testing.assert_allclose(u, right(0.2, 0.5, 0.23))
    v, w = body_velocity(u, 0.23)               # the course's z-down convention
    np.testing.assert_allclose([v, w], [0.2, -0.5])


def test_each_known_mistake_gets_its_hint(capsys):
    cases = {
        "not negated": lambda v, w, b: [v - 0.5 * b * w, v + 0.5 * b * w],
        "not b w": lambda v, w, b: [v + b * w, v - b * w],
        "not w / (2 b)": lambda v, w, b: [v + 0.5 * w / b, v - 0.5 * w / b],
        "not written yet": lambda v, w, b: None,
        "expected a pair": lambda v, w, b: [v],
        "their mean is v": lambda v, w, b: [v, v + w],
    }
    for hint, fn in cases.items():
        assert not check_wheel_speeds_from_commands(fn)
        out = capsys.readouterr().out
        assert hint in out, (hint, out)
