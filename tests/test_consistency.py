"""The filters on the simulator: consistent (NEES), protected by the gate, equal to the textbook.

- Monte-Carlo NEES: 20 runs of the standard scenario (``arena_loop``: the
  report's arena, one loop with loop closure) with independent seeds
  (:func:`slamlib.studies.monte_carlo`, shared with chapter 06); the pose NEES
  averaged over the runs must lie in the 95 % chi-square band.
- Misread ids (``arena_loop_misreads``): with the gate the trajectory error
  stays small; without it, it grows by an order of magnitude.
- The recorded runs of ``data/runs``: the filters equal the dense
  textbook one written in tests/dense_ekf.py to 1e-9 over the whole run, and P stays symmetric and
  positive definite.

Everything is seeded; the whole file takes about half a minute on 2 cores.
"""

import numpy as np
import pytest
from dense_ekf import DenseEKF

from slamlib import runner, studies
from slamlib.ekf import EKFSLAM, EKFLocalization
from slamlib.metrics import chi2_band
from slamlib.runs import load_run
from slamlib.sim import scenario

N_RUNS = 20
SEEDS = range(1000, 1000 + N_RUNS)
STEP = 0.5           # sample the NEES every 0.5 s (25 encoder periods)


@pytest.fixture(scope="module")
def monte_carlo():
    """Pose NEES on a 0.5 s grid, for both filters over N_RUNS seeded runs (slamlib.studies)."""
    return studies.monte_carlo("arena_loop", ("localization", "slam"), SEEDS, step=STEP)


@pytest.mark.parametrize("which", ["localization", "slam"])
def test_average_nees_is_inside_the_95_percent_band(monte_carlo, which):
    study = monte_carlo[which]
    assert study.n_runs == N_RUNS
    assert study.t[-1] > 50.0            # the grid runs to the end of the shortest run
    avg = study.average()
    lo, hi = chi2_band(3, N_RUNS, 0.95)  # about [2.02, 4.16] for 20 runs
    inside = np.mean((avg > lo) & (avg < hi))
    print(f"{which}: mean of the average NEES {avg.mean():.2f} (band [{lo:.2f}, {hi:.2f}]), "
          f"{100 * inside:.0f} % of {avg.size} instants inside, max {avg.max():.2f}")
    assert lo < avg.mean() < hi
    # 95 % of the instants for a perfect filter; neighbouring instants are strongly
    # correlated (a single excursion spans many of them), so allow a margin
    assert inside > 0.75
    assert avg.max() < 2 * hi               # no excursion of gross overconfidence


def _trace_pair(run, fn):
    gated, open_ = fn(run, gate=0.95), fn(run, gate=None)
    return runner.ate(gated.x, gated.truth), runner.ate(open_.x, open_.truth), gated, open_


@pytest.fixture(scope="module")
def misread_runs():
    return [scenario("arena_loop_misreads", seed=s) for s in (11, 12, 13)]


def test_gate_keeps_slam_on_track_with_misread_ids(misread_runs):
    gated_ate, open_ate = [], []
    for run in misread_runs:
        a, b, gated, open_ = _trace_pair(run, runner.slam)
        counts_g, counts_o = gated.counts(), open_.counts()
        assert counts_g.get("rejected", 0) > 0 and counts_o.get("rejected", 0) == 0
        gated_ate.append(a.position)
        open_ate.append(b.position)
    print(f"SLAM ATE with the gate {np.round(gated_ate, 3)} m, without {np.round(open_ate, 3)} m")
    assert max(gated_ate) < 0.3
    assert min(open_ate) > 0.8
    assert np.mean(open_ate) > 5 * np.mean(gated_ate)


def test_gate_keeps_localization_on_track_with_misread_ids(misread_runs):
    gated_ate, open_ate = [], []
    for run in misread_runs:
        a, b, _, _ = _trace_pair(run, runner.localization)
        gated_ate.append(a.position)
        open_ate.append(b.position)
    print(f"localisation ATE with the gate {np.round(gated_ate, 4)} m, "
          f"without {np.round(open_ate, 4)} m")
    assert max(gated_ate) < 0.03
    assert np.mean(open_ate) > 3 * np.mean(gated_ate)


# --------------------------------------------------------------------------- recorded runs
def _drive_pair(run, fast, dense):
    """Both filters through the run's events; they must agree after every event."""
    sensor = run.sensor()
    n_updates = 0
    worst = 0.0
    for ev in run.events():
        if ev.kind == "predict":
            fast.predict(ev.u, ev.dt)
            dense.predict(ev.u, ev.dt)
            continue
        obs = ev.obs
        if len(obs) == 0:
            continue
        R = np.stack([sensor.R(r) for r in obs.z[:, 0]])
        a, b = fast.update(obs.ids, obs.z, R), dense.update(obs.ids, obs.z, R)
        assert a.status == tuple(b["status"])
        np.testing.assert_allclose(a.d2, b["d2"], rtol=1e-9, atol=1e-9, equal_nan=True)
        P = fast.P
        assert np.array_equal(P, P.T)
        worst = max(worst, float(np.max(np.abs(P - dense.P))),
                    float(np.max(np.abs(fast.x - dense.x))))
        assert worst < 1e-9
        n_updates += 1
    assert np.min(np.linalg.eigvalsh(fast.P)) > 0.0
    return n_updates, worst


@pytest.mark.parametrize("name", ["arena_loop_misreads", "random_loop"])
def test_recorded_run_slam_equals_dense(name):
    run = load_run(name)
    args = (run.start_pose, runner.DEFAULT_P0, run.Q(), run.sensor().R(2.0))
    fast = EKFSLAM(*args, wheel_base=run.wheel_base)
    dense = DenseEKF(*args, wheel_base=run.wheel_base)
    n, worst = _drive_pair(run, fast, dense)
    assert n > 300 and fast.n_landmarks >= 8
    assert fast.landmark_ids == dense.landmark_ids
    print(f"{name}: {n} updates, {fast.n_landmarks} landmarks, largest difference {worst:.1e}")


def test_recorded_run_localization_equals_dense():
    run = load_run("arena_loop_misreads")
    lm = run.world().landmarks()
    args = (run.start_pose, runner.DEFAULT_P0, run.Q(), run.sensor().R(2.0), lm)
    n, _ = _drive_pair(run, EKFLocalization(*args, wheel_base=run.wheel_base),
                      DenseEKF(*args, wheel_base=run.wheel_base))
    assert n > 300
