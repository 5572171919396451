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
