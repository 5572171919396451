"""runner.run_filter(until=t): stop before a camera frame and hand it back (chapter 05)."""

import numpy as np
import pytest

from slamlib import runner as ex
from slamlib.ekf import EKFSLAM
from slamlib.runs import load_run


@pytest.fixture(scope="module")
def run():
    return load_run("arena_loop")


def _by_hand(run, t_stop):
    """The loop written out: predict every encoder event, update every frame before t_stop."""
    sensor = run.sensor()
    f = EKFSLAM(run.start_pose, ex.DEFAULT_P0, run.Q(), sensor.R(2.0),
                wheel_base=run.wheel_base, gate=0.95)
    for ev in run.events():
        if ev.kind == "predict":
            f.predict(ev.u, ev.dt)
        elif len(ev.obs):
            if ev.t >= t_stop - 1e-9:
                return f, ev
            f.update(ev.obs.ids, ev.obs.z, R=np.stack([sensor.R(r) for r in ev.obs.z[:, 0]]))
    raise AssertionError("no frame")


@pytest.mark.parametrize("t_stop", [0.0, 14.7, 20.0, 48.25])
def test_until_stops_before_the_first_frame_at_or_after_t(run, t_stop):
    tr = ex.slam(run, until=t_stop)
    ref, ev = _by_hand(run, t_stop)
    p = tr.pending
    assert p is not None and p.t == ev.t >= t_stop - 1e-9
    np.testing.assert_array_equal(p.obs.ids, ev.obs.ids)
    np.testing.assert_array_equal(p.obs.z, ev.obs.z)
    assert all(t < p.t for t, _ in tr.reports)
    np.testing.assert_array_equal(tr.filter.x, ref.x)
    np.testing.assert_array_equal(tr.filter.P, ref.P)
    np.testing.assert_array_equal(tr.x[-1], ref.pose)


def test_fusing_the_pending_frame_is_the_full_runs_next_update(run):
    full = ex.slam(run)
    tr = ex.slam(run, until=20.0)
    rep = tr.filter.update(tr.pending.obs.ids, tr.pending.obs.z, R=tr.pending.R)
    t_full, rep_full = next((t, r) for t, r in full.reports if t >= 20.0 - 1e-9)
    assert t_full == tr.pending.t
    assert rep.status == rep_full.status
    np.testing.assert_array_equal(rep.d2, rep_full.d2)


def test_without_until_or_past_the_end_nothing_is_pending(run):
    assert ex.slam(run, max_time=5.0).pending is None
    tr = ex.slam(run, until=1e6)
    assert tr.pending is None and len(tr.reports) == len(ex.slam(run).reports)
