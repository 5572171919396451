"""slamlib.course.trace_readings: a trace's readings end to end, by status."""

import numpy as np
import pytest
from test_ekf import P0, X0, Q, R, scripted_sequence

from slamlib import runner
from slamlib.course.trace_readings import trace_readings
from slamlib.ekf import EKFSLAM
from slamlib.sim import scenario


@pytest.fixture(scope="module")
def trace():
    return runner.slam(scenario("arena_loop"), gate=0.5)


def test_every_reading_once_in_the_order_the_filter_got_them(trace):
    rd = trace_readings(trace)
    k = 0
    for f, (t, rep) in enumerate(trace.reports):
        for i in range(len(rep)):
            assert (rd.t[k], rd.frame[k], rd.ids[k], rd.status[k]) == (t, f, rep.ids[i],
                                                                      rep.status[i])
            np.testing.assert_array_equal(rd.z[k], rep.z[i])
            np.testing.assert_array_equal(rd.d2[k], rep.d2[i])
            assert rd.matched[k] == rep.matched[i]
            k += 1
    assert k == len(rd)
    np.testing.assert_array_equal(rd.frame_t, [t for t, _ in trace.reports])


def test_masks_and_counts_agree_with_the_reports(trace):
    rd = trace_readings(trace)
    assert rd.counts() == trace.counts()
    assert set(rd.counts()) == {"accepted", "rejected", "new"}
    acc = np.concatenate([r.accepted for _, r in trace.reports])
    np.testing.assert_array_equal(rd.accepted, acc)
    np.testing.assert_array_equal(rd.new, np.concatenate([r.new for _, r in trace.reports]))
    np.testing.assert_array_equal(rd.gated, rd.accepted | rd.rejected)
    assert rd.ids[rd.new].tolist() == trace.filter.landmark_ids
    assert rd.frames_with("accepted").tolist() == [t for t, r in trace.reports if r.n_accepted]


def test_duplicates_empty_frames_and_a_list_of_reports():
    f = EKFSLAM(X0, P0, Q, R)
    reports = []
    for j, (u, dt, ids, z, Rk) in enumerate(scripted_sequence(seed=0, steps=60)):
        f.predict(u, dt)
        reports.append((0.1 * j, f.update(ids, z, Rk)))
        if j % 10 == 0:
            reports.append((0.1 * j + 0.05, f.update([], np.zeros((0, 2)))))   # nothing seen
    rd = trace_readings(reports)
    c = rd.counts()
    assert list(c) == ["accepted", "rejected", "new", "duplicate"]
    assert sum(c.values()) == len(rd) == sum(len(r) for _, r in reports)
    empty = {f for f, (_, r) in enumerate(reports) if len(r) == 0}
    assert len(empty) == 6 and not empty & set(rd.frame.tolist())     # no reading from them
    assert rd.frame_t.size == len(reports)                             # but their times are kept


def test_no_readings_and_bad_input():
    rd = trace_readings([(0.0, EKFSLAM(X0, P0, Q, R).update([], np.zeros((0, 2))))])
    assert len(rd) == 0 and rd.counts() == {} and rd.frame_t.tolist() == [0.0]
    with pytest.raises(ValueError, match="trace"):
        trace_readings(3)
