"""runner.run_filter(until=t): stop before a camera frame and hand it back (chapter 05)."""

import numpy as np
import pytest

from slamlib import runner
from slamlib.ekf import EKFSLAM
from slamlib.runs import load_run


@pytest.fixture(scope="module")
def run():
    return load_run("arena_loop")


def _by_hand(run, t_stop):
    """The loop written out: predict every encoder event, update every frame before t_stop."""
    sensor = run.sensor()
    f = EKFSLAM(run.start_pose, runner.DEFAULT_P0, run.Q(), sensor.R(2.0),
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
    tr = runner.slam(run, until=t_stop)
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
    full = runner.slam(run)
    tr = runner.slam(run, until=20.0)
    rep = tr.filter.update(tr.pending.obs.ids, tr.pending.obs.z, R=tr.pending.R)
    t_full, rep_full = next((t, r) for t, r in full.reports if t >= 20.0 - 1e-9)
    assert t_full == tr.pending.t
    assert rep.status == rep_full.status
    np.testing.assert_array_equal(rep.d2, rep_full.d2)


def test_without_until_or_past_the_end_nothing_is_pending(run):
    assert runner.slam(run, max_time=5.0).pending is None
    tr = runner.slam(run, until=1e6)
    assert tr.pending is None and len(tr.reports) == len(runner.slam(run).reports)


def test_a_q_per_step_is_the_textbook_prediction_with_that_steps_q():
    # a noise density gives each step its own Q (Q_c / dt_k, chapter 10)
    from slamlib.models import motion_jacobians

    rng = np.random.default_rng(5)
    f = EKFSLAM(rng.normal(0, 1, 3), np.diag([1e-3, 2e-3, 1e-3]), np.diag([4e-4, 9e-4]),
                np.diag([0.01, 1e-4]))
    z = np.column_stack([rng.uniform(0.5, 3.0, 3), rng.uniform(-1, 1, 3)])
    f.update(np.arange(3), z)
    u, dt = rng.normal(0.2, 0.1, (29, 2)), rng.uniform(0.001, 0.5, 29)
    Qc = np.array([[2e-4, 1e-4], [1e-4, 3e-4]])
    for k in range(29):
        P, Qk = f.P, Qc / dt[k]
        A, W = motion_jacobians(f.pose, u[k], float(dt[k]), f.wheel_base)
        F = np.eye(P.shape[0])
        F[:3, :3] = A
        f.predict(u[k], float(dt[k]), Qk)
        # the textbook formula F P F' + F_w Q_k F_w' with this step's Q, A and W
        want = F @ P @ F.T
        want[:3, :3] += W @ Qk @ W.T
        np.testing.assert_allclose(f.P, want, rtol=1e-12, atol=1e-15)
    x, P = f.x, f.P
    with pytest.raises(ValueError, match="Q: expected a symmetric"):
        f.predict(u[0], 0.1, [[1.0, 0.5], [0.0, 1.0]])
    np.testing.assert_array_equal(f.x, x)
    np.testing.assert_array_equal(f.P, P)


def test_the_runners_give_each_step_the_runs_own_q(run, monkeypatch):
    # Run.Q_steps (a real log's Q_c / dt_k) reaches every prediction of run_filter and
    # dead_reckoning, one prediction at a time; Q given overrides it
    Qc = np.array([[2e-4, 1e-4], [1e-4, 3e-4]])
    monkeypatch.setattr(type(run), "Q_steps", lambda self, dt: Qc[None] / dt[:, None, None])
    tr = runner.slam(run, max_time=12.0)
    sensor = run.sensor()
    f = EKFSLAM(run.start_pose, runner.DEFAULT_P0, run.Q(), sensor.R(2.0),
                wheel_base=run.wheel_base, gate=0.95)
    d = runner.make_filter(runner.EKFLocalization, run, R=runner.default_R(run, needed=False),
                           landmarks={})
    for ev in run.events():
        if ev.t > 12.0:
            break
        if ev.kind == "predict":
            f.predict(ev.u, ev.dt, Qc / ev.dt)
            d.predict(ev.u, ev.dt, Qc / ev.dt)
        elif len(ev.obs):
            f.update(ev.obs.ids, ev.obs.z, R=np.stack([sensor.R(r) for r in ev.obs.z[:, 0]]))
    np.testing.assert_array_equal(tr.filter.x, f.x)
    np.testing.assert_array_equal(tr.filter.P, f.P)
    dr = runner.dead_reckoning(run, max_time=12.0)
    np.testing.assert_array_equal(dr.filter.P, d.P)
    same_Q = runner.slam(run, max_time=12.0, Q=run.Q())
    assert not np.array_equal(same_Q.filter.P, f.P)


def test_the_trace_holds_every_events_pose_as_the_filter_had_it(run):
    # the recorder writes into arrays that double when full (1024, 2048, 4096 rows here):
    # every row must be the pose and covariance the filter had right after that event
    sensor = run.sensor()
    f = EKFSLAM(run.start_pose, runner.DEFAULT_P0, run.Q(), sensor.R(2.0),
                wheel_base=run.wheel_base, gate=0.95)
    rec = runner.TraceRecorder(run.enc_t[0], f, capacity=1024)
    seen = [(float(run.enc_t[0]), f.pose, f.pose_cov)]
    for ev in run.events():
        if ev.kind == "predict":
            f.predict(ev.u, ev.dt)
            rec.record(ev.t, "predict", f)
        elif len(ev.obs):
            rec.record(ev.t, "update", f, f.update(ev.obs.ids, ev.obs.z))
        else:
            continue
        seen.append((ev.t, f.pose, f.pose_cov))
    tr = rec.trace(run, f)
    assert len(seen) > 2048 and tr.x.shape == (len(seen), 3) and tr.P.shape == (len(seen), 3, 3)
    assert tr.t.tolist() == [t for t, _, _ in seen]
    np.testing.assert_array_equal(tr.x, [x for _, x, _ in seen])
    np.testing.assert_array_equal(tr.P, [P for _, _, P in seen])
    assert tr.kind[0] == "start" and len(tr.reports) == int(np.sum(tr.kind == "update"))
