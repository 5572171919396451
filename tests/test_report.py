"""Each erratum of the report is exposed by its check; the library's formula passes it."""

import numpy as np
import pytest

from slamlib import report
from slamlib.checks import numerical_jacobian
from slamlib.models import observe


@pytest.mark.parametrize("erratum", report.ERRATA, ids=lambda e: e.key)
def test_each_erratum_is_exposed(erratum):
    ev = erratum.check()
    assert not ev.printed.ok, f"{erratum.key}: the printed formula passed its check"
    assert ev.library.ok, ev.library.message
    assert ev.exposed


@pytest.mark.parametrize("ok", report.CORRECT_AS_PRINTED, ids=lambda e: e.key)
def test_formulas_the_report_got_right(ok):
    ev = ok.check()
    assert ev.printed.ok and ev.library.ok


def test_sign_errors_are_in_the_entries_the_errata_name():
    ev = report.ERRATA[0].check()
    assert [(i, j) for i, j, *_ in ev.printed.wrong] == [(1, 1)]
    assert "sign flipped" in ev.printed.message
    ev = report.ERRATA[1].check()
    assert [(i, j) for i, j, *_ in ev.printed.wrong] == [(1, 0)]


def test_printed_H_errors_hold_at_random_points_not_just_one():
    rng = np.random.default_rng(3)
    for _ in range(50):
        pose = np.r_[rng.uniform(-5, 5, 2), rng.uniform(-np.pi, np.pi)]
        lm = rng.uniform(-5, 5, 2)
        if np.hypot(*(lm - pose[:2])) < 0.1 or min(abs(lm - pose[:2])) < 1e-2:
            continue
        fd = numerical_jacobian(lambda p, lm=lm: observe(p, lm), pose, angle_outputs=[1])
        assert not np.isclose(report.printed_H_pose(pose, lm)[1, 1], fd[1, 1])
        assert np.isclose(report.printed_H_pose(pose, lm)[1, 1], -fd[1, 1], rtol=1e-5)
