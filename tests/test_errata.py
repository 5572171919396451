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


def test_the_report_counts_seven_numerical_errors():
    """Seven errors, each exposed; the sign error of dbeta/dy_B is the same entry printed twice."""
    assert len(errata.ERRATA) == 7
    first, third = errata.ERRATA[0].check(), errata.ERRATA[2].check()
    assert (1, 1) in [(i, j) for i, j, *_ in first.printed.wrong]
    assert [(i, j) for i, j, *_ in third.printed.wrong] == [(1, 0), (1, 1)]


@pytest.mark.parametrize("note", errata.SCOPE_NOTES, ids=lambda e: e.key)
def test_scope_notes_are_right_in_the_report_scope(note):
    """g and G1 as printed are right for a robot-only state (the report's declared scope),
    and the library's general form passes against finite differences: not errata."""
    ev = note.check()
    assert ev.printed.ok, ev.printed.message
    assert ev.library.ok, ev.library.message
    assert not ev.exposed


def test_g_as_printed_keeps_only_the_pose_of_a_longer_state():
    x = np.r_[errata.CHECK_POSE, errata.CHECK_LANDMARK]
    out = errata.printed_g(x, errata.CHECK_Z)
    assert out.shape == (5,)
    np.testing.assert_array_equal(out[:3], x[:3])
    np.testing.assert_allclose(out[3:], errata.CHECK_POSE[:2]
                               + errata.CHECK_Z[0] * np.array([np.cos(errata.CHECK_POSE[2]
                                                                      + errata.CHECK_Z[1]),
                                                               np.sin(errata.CHECK_POSE[2]
                                                                      + errata.CHECK_Z[1])]))


def test_the_covariance_update_equals_the_joseph_form_at_random_priors():
    rng = np.random.default_rng(5)
    for _ in range(20):
        A = rng.normal(size=(4, 4))
        P = A @ A.T + 0.1 * np.eye(4)
        H = rng.normal(size=(2, 4))
        R = np.diag(rng.uniform(0.01, 0.1, 2))
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        IKH = np.eye(4) - K @ H
        np.testing.assert_allclose(errata.printed_covariance_update(P, H, R),
                                   IKH @ P @ IKH.T + K @ R @ K.T, atol=1e-10)


def test_the_report_got_the_columns_of_J2_right():
    keys = {e.key for e in errata.CORRECT_AS_PRINTED}
    assert {"dg/d rho", "dg/d theta"} <= keys
    for k in ("dg/d rho", "dg/d theta"):
        ev = _erratum(k, errata.CORRECT_AS_PRINTED).check()
        assert ev.printed.ok and ev.library.ok
        assert ev.printed.max_error < 1e-8


def test_text_errata_name_the_notation_and_the_unbacked_claim():
    printed = " ".join(t.printed for t in errata.TEXT_ERRATA)
    for words in ("N(x, P)", "bearing", "X^2_ij", "2 sigma", "effectively estimates",
                  "elevation angle", "z_f + v_k"):
        assert words in printed, words
    assert "so the estimate is consistent" not in printed
    assert "(I - K_k H_k)" not in printed               # eq. (5) is right: CORRECT_AS_PRINTED
