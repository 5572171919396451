"""Ids are what they say, numbers are numbers (issue 24, point 3), through the public API.

An id beyond int64, a float that is not an integer, a negative id (``report.matched`` uses
-1 for "rejected"), a bool or a string is refused with a ValueError naming ``ids``; strings
and bools are refused where a number is expected (``dt``, ``x``, ``gate``...), not converted.
Every refusal leaves the filter's state as it was, byte for byte.
"""

from __future__ import annotations

import numpy as np
import pytest

from slamlib import models
from slamlib.ekf import EKFSLAM, FEJEKFSLAM, EKFLocalization

R = np.diag([0.01, 0.001])


def slam(cls=EKFSLAM):
    f = cls(np.zeros(3), np.eye(3) * 1e-4, np.eye(2) * 1e-4, R)
    f.update([7], [[1.0, 0.1]])                      # one landmark mapped already
    return f


def snapshot(f):
    return f.x.tobytes(), f.P.tobytes(), list(getattr(f, "landmark_ids", []))


BAD_IDS = [
    ([2**63], "int64"),                          # became INT64_MIN
    ([1e19, 2e19], "int64"),                     # both INT64_MIN, the second gated on the first
    ([2**64 - 1], "int64"),                      # fused into landmark -1
    (np.array([2**63], dtype=np.uint64), "int64"),
    ([2**70], "int64"),
    ([float(2**53 + 2)], "2**53"),               # a float that large may not be the id meant
    ([-3], "negative"),
    ([7, -1], "negative"),
    ([1.5], "integer"),
    (["4"], "integer"),
    ([b"4"], "integer"),
    ([True], "bool"),
    ([True, 7], "bool"),                         # numpy turns [True, 7] into [1, 7]
    ([np.bool_(True)], "bool"),
    ([7, "8"], "integer"),
]


@pytest.mark.parametrize("cls", [EKFSLAM, FEJEKFSLAM])
@pytest.mark.parametrize("ids, reason", BAD_IDS)
def test_bad_ids_are_refused_and_nothing_changes(cls, ids, reason):
    f = slam(cls)
    before = snapshot(f)
    z = np.tile([1.0, 0.1], (len(ids), 1))
    with pytest.raises(ValueError, match="ids") as exc:
        f.update(ids, z)
    assert reason in str(exc.value), str(exc.value)
    assert snapshot(f) == before


@pytest.mark.parametrize("ids, reason", BAD_IDS)
def test_localization_refuses_the_same_ids(ids, reason):
    f = EKFLocalization(np.zeros(3), np.eye(3) * 1e-4, np.eye(2) * 1e-4, R, {7: [1.0, 0.1]})
    before = snapshot(f)
    with pytest.raises(ValueError, match="ids"):
        f.update(ids, np.tile([1.0, 0.1], (len(ids), 1)))
    assert snapshot(f) == before


@pytest.mark.parametrize("key", [-1, 2**63, True, "3"])
def test_a_map_with_an_id_out_of_range_is_refused(key):
    with pytest.raises(ValueError, match="landmarks"):
        EKFLocalization(np.zeros(3), np.eye(3), np.eye(2), R, {key: [1.0, 0.0]})


@pytest.mark.parametrize("ids", [[0], [2**63 - 1], [3.0], np.array([5], dtype=np.uint8),
                                 np.array([2**53], dtype=float), [np.int32(9)]])
def test_good_ids_still_work(ids):
    f = slam()
    rep = f.update(ids, [[2.0, -0.3]])
    assert rep.new.tolist() == [True]
    assert f.landmark_ids[-1] == int(np.asarray(ids)[0])


@pytest.mark.parametrize("dt", ["0.1", True, np.bool_(True), np.str_("0.1"), b"0.1",
                                np.array("0.1"), [0.1]])
def test_predict_refuses_a_dt_that_is_not_a_number(dt):
    f = slam()
    before = snapshot(f)
    with pytest.raises(ValueError, match="dt"):
        f.predict([0.1, 0.1], dt)
    assert snapshot(f) == before


@pytest.mark.parametrize("u", [["0.1", "0.1"], [True, 0.1], np.array(["0.1", "0.1"]),
                               [0.1, np.bool_(False)]])
def test_predict_refuses_controls_that_are_not_numbers(u):
    f = slam()
    before = snapshot(f)
    with pytest.raises(ValueError, match="u"):
        f.predict(u, 0.1)
    assert snapshot(f) == before


@pytest.mark.parametrize("gate", ["0.95", True, np.str_("0.95")])
def test_gate_refuses_strings_and_bools(gate):
    with pytest.raises(ValueError, match="gate"):
        EKFSLAM(np.zeros(3), np.eye(3), np.eye(2), R, gate=gate)
    f = slam()
    with pytest.raises(ValueError, match="gate"):
        f.gate = gate
    assert f.gate == 0.95


@pytest.mark.parametrize("x0", [["1", "2", "3"], [True, 0.0, 0.0], np.array(["1", "2", "3"]),
                                "123", [[1.0], "2", 3.0]])
def test_initial_state_refuses_strings_and_bools(x0):
    with pytest.raises(ValueError, match="x0"):
        EKFSLAM(x0, np.eye(3), np.eye(2), R)


def test_covariances_refuse_strings_and_bools():
    with pytest.raises(ValueError, match="P0"):
        EKFSLAM(np.zeros(3), np.eye(3).astype(str), np.eye(2), R)
    with pytest.raises(ValueError, match="Q"):
        EKFSLAM(np.zeros(3), np.eye(3), [[True, False], [False, True]], R)
    f = slam()
    before = snapshot(f)
    with pytest.raises(ValueError, match="R"):
        f.update([7], [[1.0, 0.1]], R=[["0.01", "0"], ["0", "0.001"]])
    with pytest.raises(ValueError, match="z"):
        f.update([7], [["1.0", "0.1"]])
    assert snapshot(f) == before


@pytest.mark.parametrize("x", [["1", "2", "3"], [True, 0.0, 0.0]])
def test_models_refuse_strings_and_bools(x):
    with pytest.raises(ValueError, match="x"):
        models.motion_model(x, [0.1, 0.1], 0.1)
    with pytest.raises(ValueError, match="dt"):
        models.motion_model([0.0, 0.0, 0.0], [0.1, 0.1], "0.1")
    with pytest.raises(ValueError, match="pose"):
        models.observe(x, [1.0, 2.0])


def test_numbers_of_every_numeric_kind_still_work():
    f = slam()
    f.predict(np.array([0.1, 0.1], dtype=np.float32), np.float64(0.1))
    f.predict([1, 1], 1)                                   # Python ints
    f.predict((np.int64(0), np.int16(0)), np.float32(0.5))
    f.gate = np.float64(0.99)
    f.gate = None
    g = EKFSLAM([0, 0, 0], np.eye(3, dtype=int), np.eye(2, dtype=np.float32), R, gate=0.9)
    assert g.x.dtype == float


def test_a_2x2_covariance_is_judged_as_the_general_check_judges_it():
    """``as_covariance``'s shortcut for a float 2x2 (a step's Q or R) accepts only what the
    general check (symmetry to 1e-9, Cholesky) accepts, and returns the same bits."""
    from slamlib.validate import as_covariance

    rng = np.random.default_rng(7)
    cases = [np.diag([1e-4, 2e-4]), np.array([[1.0, 1.0], [1.0, 1.0 + 1e-12]]),
             np.array([[1.0, 0.5], [0.5 + 1e-6, 1.0]]), np.array([[1.0, 2.0], [2.0, 1.0]]),
             np.array([[-1.0, 0.0], [0.0, 1.0]]), np.array([[np.nan, 0.0], [0.0, 1.0]]),
             np.array([[1e300, 0.0], [0.0, 1e300]]), np.zeros((2, 2))]
    for _ in range(200):
        A = rng.normal(size=(2, 2)) * 10.0 ** rng.integers(-6, 3)
        cases.append(A @ A.T + rng.choice([0.0, 1e-14, 1e-3]) * np.eye(2))
    for M in cases:
        general = M.astype(float).tolist()          # a list takes the general path
        try:
            want = as_covariance("Q", general, 2)
        except ValueError:
            want = None
        try:
            got = as_covariance("Q", M.astype(float), 2)
        except ValueError:
            got = None
        assert (want is None) == (got is None), M
        if want is not None:
            assert np.array_equal(want, got), M
