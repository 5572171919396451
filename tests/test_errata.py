"""Each erratum of the report is exposed by its check; the library's formula passes it."""

import numpy as np
import pytest

from slamlib.checks import numerical_jacobian
from slamlib.course import errata
from slamlib.models import observe


@pytest.mark.parametrize("erratum", errata.ERRATA, ids=lambda e: e.key)
def test_each_erratum_is_exposed(erratum):
    ev = erratum.check()
    assert not ev.printed.ok, f"{erratum.key}: the printed formula passed its check"
    assert ev.library.ok, ev.library.message
    assert ev.exposed


@pytest.mark.parametrize("ok", errata.CORRECT_AS_PRINTED, ids=lambda e: e.key)
def test_formulas_the_report_got_right(ok):
    ev = ok.check()
    assert ev.printed.ok and ev.library.ok


def test_sign_errors_are_in_the_entries_the_errata_name():
    ev = errata.ERRATA[0].check()
    assert [(i, j) for i, j, *_ in ev.printed.wrong] == [(1, 1)]
    assert "sign flipped" in ev.printed.message
    ev = errata.ERRATA[1].check()
    assert [(i, j) for i, j, *_ in ev.printed.wrong] == [(1, 0)]


def test_printed_H_errors_hold_at_random_points_not_just_one():
    rng = np.random.default_rng(3)
    for _ in range(50):
        pose = np.r_[rng.uniform(-5, 5, 2), rng.uniform(-np.pi, np.pi)]
        lm = rng.uniform(-5, 5, 2)
        if np.hypot(*(lm - pose[:2])) < 0.1 or min(abs(lm - pose[:2])) < 1e-2:
            continue
        fd = numerical_jacobian(lambda p, lm=lm: observe(p, lm), pose, angle_outputs=[1])
        assert not np.isclose(errata.printed_H_pose(pose, lm)[1, 1], fd[1, 1])
        assert np.isclose(errata.printed_H_pose(pose, lm)[1, 1], -fd[1, 1], rtol=1e-5)


def test_max_error_covers_every_entry_not_only_the_wrong_ones():
    from slamlib.checks import compare_jacobians

    expected = np.array([[1.0, 2.0], [3.0, 4.0]])
    got = expected + np.array([[1e-9, -3e-8], [0.0, 0.0]])        # all within tolerance
    c = compare_jacobians("J", got, expected)
    assert c.ok and c.wrong == []
    assert np.isclose(c.max_error, 3e-8, rtol=1e-6)
    got[1, 0] = -3.0                                             # one sign flipped
    c = compare_jacobians("J", got, expected)
    assert not c.ok and np.isclose(c.max_error, 6.0)
    assert np.isinf(compare_jacobians("J", np.zeros(3), expected).max_error)
    assert np.isinf(compare_jacobians("J", [[np.nan, 2], [3, 4]], expected).max_error)


def _erratum(key, table=errata.ERRATA):
    return next(e for e in table if e.key == key)


def test_the_report_g_drops_the_landmarks_already_in_the_state():
    ev = _erratum("g drops the map").check()
    assert "shape (1, 5), expected (1, 7)" in ev.printed.message
    x = np.r_[errata.CHECK_POSE, errata.CHECK_LANDMARK]
    z = errata.CHECK_Z
    out = errata.printed_g(x, z)
    assert out.shape == (5,)
    np.testing.assert_array_equal(out[:3], x[:3])          # the pose kept, the landmark lost


def test_literal_noise_on_the_cartesian_point_gives_a_rotation_not_J2():
    pose, z = errata.CHECK_POSE, errata.CHECK_Z
    lit = numerical_jacobian(lambda v: errata.printed_g_with_noise(pose, z, v), np.zeros(2))
    c, s = np.cos(pose[2]), np.sin(pose[2])
    np.testing.assert_allclose(lit, [[c, -s], [s, c]], atol=1e-8)
    # the true noise Jacobian, written out: d/d(rho, beta) of x + rho [cos, sin](theta + beta)
    a = pose[2] + z[1]
    J2 = np.array([[np.cos(a), -z[0] * np.sin(a)], [np.sin(a), z[0] * np.cos(a)]])
    ev = _erratum("noise added to z_f").check()
    assert not ev.printed.ok and ev.library.ok
    assert not np.allclose(lit, J2, atol=1e-3)


def test_the_printed_G1_has_the_size_of_a_state_without_landmarks():
    ev = _erratum("G1 size").check()
    assert "shape (5, 3), expected (7, 5)" in ev.printed.message
    assert ev.library.ok


def test_the_report_got_the_columns_of_J2_right():
    keys = {e.key for e in errata.CORRECT_AS_PRINTED}
    assert {"dg/d rho", "dg/d theta"} <= keys
    for k in ("dg/d rho", "dg/d theta"):
        ev = _erratum(k, errata.CORRECT_AS_PRINTED).check()
        assert ev.printed.ok and ev.library.ok
        assert ev.printed.max_error < 1e-8


def test_text_errata_name_the_notation_and_the_unbacked_claim():
    printed = " ".join(t.printed for t in errata.TEXT_ERRATA)
    for words in ("N(x, P)", "bearing", "X^2_ij", "2 sigma"):
        assert words in printed, words
