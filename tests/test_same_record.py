"""The comparison of recomputed study records: it must fail on what a code change changes."""

import pytest
from same_record import assert_same_record


def test_rounding_in_the_last_bits_passes():
    a = {"n": 3, "x": [0.1 + 0.2, 1e-300], "s": "closed", "ok": True}
    b = {"n": 3, "x": [0.3, 0.0], "s": "closed", "ok": True}
    assert_same_record(a, b)


@pytest.mark.parametrize("fresh", [
    {"n": 4, "x": [0.3], "s": "closed", "ok": True},            # a count
    {"n": 3, "x": [0.3 * (1 + 1e-5)], "s": "closed", "ok": True},  # a float beyond rel
    {"n": 3, "x": [0.3], "s": "rejected", "ok": True},          # a decision
    {"n": 3, "x": [0.3], "s": "closed", "ok": 1},               # a bool that became an int
    {"n": 3, "x": [0.3, 0.3], "s": "closed", "ok": True},       # a length
    {"n": 3, "x": [0.3], "s": "closed"},                        # a key
    {"n": 3, "x": [float("nan")], "s": "closed", "ok": True},   # a nan
])
def test_a_changed_decision_or_float_fails(fresh):
    with pytest.raises(AssertionError):
        assert_same_record(fresh, {"n": 3, "x": [0.3], "s": "closed", "ok": True})


def test_a_closed_loop_study_may_move_a_count_by_its_fraction():
    stored = {"inside": [9500, 3], "x": 1.0}
    assert_same_record({"inside": [9505, 3], "x": 1.0 + 1e-4}, stored, rel=1e-3, count_rel=1e-3)
    with pytest.raises(AssertionError):
        assert_same_record({"inside": [9515, 3], "x": 1.0}, stored, rel=1e-3, count_rel=1e-3)
    with pytest.raises(AssertionError):
        assert_same_record({"inside": [9500, 4], "x": 1.0}, stored, rel=1e-3, count_rel=1e-3)
    with pytest.raises(AssertionError):                      # not without count_rel
        assert_same_record({"inside": [9501, 3], "x": 1.0}, stored, rel=1e-3)
