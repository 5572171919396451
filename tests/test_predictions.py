"""slamlib.course.predictions.check_prediction: commit first, then measure, then explain."""

from slamlib.course.predictions import check_prediction


def measured(value, log):
    def measure():
        log.append("measured")
        return value, "3 seeded runs"
    return measure


def test_a_stub_is_not_written_yet_and_measures_nothing(capsys):
    log = []
    assert not check_prediction(None, measured(1.0, log), (0.5, 2.0), "because.")
    out = capsys.readouterr().out
    assert "not written yet" in out and log == [] and "1" not in out.split("(")[0]


def test_a_number_inside_the_range_is_right_and_outside_is_explained(capsys):
    log = []
    assert check_prediction(1.5, measured(1.2, log), (1.0, 2.0), "Sigma scales with sqrt(Q).",
                            unit="deg")
    out = capsys.readouterr().out
    assert "Right" in out and "1.2 deg" in out and "sqrt(Q)" in out and "3 seeded runs" in out
    assert not check_prediction(3.0, measured(1.2, log), (1.0, 2.0), "Sigma scales with sqrt(Q).")
    out = capsys.readouterr().out
    assert "Not quite" in out and "1 to 2" in out and "sqrt(Q)" in out
    assert log == ["measured", "measured"]


def test_choices_are_checked_and_a_wrong_type_is_named(capsys):
    log = []
    opts = ("shrinks", "stays", "grows")
    assert check_prediction("stays", measured("stays", log), {"stays"}, "No new information.",
                            choices=opts)
    assert "Right" in capsys.readouterr().out
    assert not check_prediction("grows", measured("stays", log), {"stays"}, "x", choices=opts)
    assert "Not quite" in capsys.readouterr().out
    assert not check_prediction("maybe", measured("stays", log), {"stays"}, "x", choices=opts)
    assert "expected one of 'shrinks', 'stays', 'grows'" in capsys.readouterr().out
    assert not check_prediction("12", measured(1.0, log), (0, 2), "x")
    assert "expected a number" in capsys.readouterr().out
    assert log == ["measured", "measured"]
