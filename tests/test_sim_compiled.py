"""The compiled functions (slamlib.compiled, numba): the simulator's loop and the EKF's steps
(``ekf.predict``, ``gate``, ...), one implementation each, whether numba compiles them, runs
them as Python (NUMBA_DISABLE_JIT=1) or cannot cache them (a read-only package folder and
HOME); and the runner's loop (issue 23). Each run below simulates and filters with EKF SLAM."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from libm_rounding import NUMPY_ROUNDS_AS_LIBM, WHY

from slamlib import ekf, models, runner, sim
from slamlib.ekf import EKFSLAM

ROOT = Path(__file__).resolve().parents[1]


class _PythonLoopController(sim.WaypointController):
    """The waypoint controller under another type: KobukiSim.drive then runs its Python loop."""


@pytest.mark.parametrize("faults", [{}, {"p_misread": 0.1, "p_outlier": 0.3}])
def test_compiled_drive_equals_the_python_loop_bit_for_bit(faults):
    from slamlib.sensors import AnalyticMarkerSensor
    from slamlib.worlds import load_world

    world = load_world("report_arena")
    ctl = sim.WaypointController(sim.arena_loop_waypoints())
    slow = _PythonLoopController(sim.arena_loop_waypoints())
    a = sim.simulate(world, ctl, sensor=AnalyticMarkerSensor(**faults), seed=21)
    b = sim.simulate(world, slow, sensor=AnalyticMarkerSensor(**faults), seed=21)
    for name in ("truth_t", "truth", "enc_t", "ticks_R", "ticks_L"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    for name in ("t_capture", "t_arrival", "id", "rho", "bearing", "true_id"):
        assert np.array_equal(getattr(a.camera, name), getattr(b.camera, name)), name
    assert a.meta["finished"] and b.meta["finished"]
    # no camera at all: the same motion
    c = sim.simulate(world, ctl, seed=21)
    assert np.array_equal(c.truth, a.truth) and len(c.camera) == 0


def test_a_step_with_a_non_finite_wheel_speed_is_refused():
    from slamlib.worlds import load_world

    s = sim.KobukiSim(load_world("report_arena"), seed=1)
    with pytest.raises(ValueError, match="wheel speeds"):
        s.step(0.1, float("nan"))
    assert s.k == 0 and not s._slip          # nothing drawn, nothing moved



_RUN = """
import json, numpy as np
from slamlib import runner, sim
run = sim.scenario("arena_loop", seed=3)
tr = runner.slam(run)
print(json.dumps({"ids": run.camera.id.tolist(), "truth": run.truth[-1].tolist(),
                  "ticks": run.ticks_R[-5:].tolist(), "status": tr.counts(),
                  "landmarks": tr.filter.landmark_ids, "x": tr.filter.x.tolist(),
                  "decisions": [list(rep.status) for _, rep in tr.reports]}))
"""


def _run_in(env_extra: dict, cwd=None, path=None) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR",
                                                              "NUMBA_DISABLE_JIT")}
    env.update(env_extra)
    if path is not None:
        env["PYTHONPATH"] = str(path)
    out = subprocess.run([sys.executable, "-c", _RUN], env=env, cwd=cwd, capture_output=True,
                         text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def compiled_result():
    return _run_in({})


def test_the_python_of_the_compiled_loop_gives_the_same_run_and_decisions(compiled_result):
    """NUMBA_DISABLE_JIT=1 runs the same functions as Python: the same readings, the same
    filter decisions, the same numbers to rounding."""
    plain = _run_in({"NUMBA_DISABLE_JIT": "1"})
    for key in ("ids", "ticks", "status", "landmarks", "decisions"):    # every reading's fate
        assert plain[key] == compiled_result[key], key
    np.testing.assert_allclose(plain["truth"], compiled_result["truth"], rtol=0, atol=1e-12)
    # the estimates to rounding: the joint update's Cholesky factors differ in the last bit
    # (numba's LAPACK call factors an upper triangle, numpy's a lower one; bench/README.md)
    np.testing.assert_allclose(plain["x"], compiled_result["x"], rtol=1e-9, atol=1e-12)


_OVERFLOW = """
import warnings, numpy as np
from slamlib.ekf import EKFSLAM
warnings.simplefilter("error")                       # any warning fails
f = EKFSLAM(np.zeros(3), np.eye(3), np.eye(2), np.eye(2))
try:
    f.predict(np.array([1e200, 1e200]), 1e200)
except ValueError as exc:
    print("refused:", exc)
"""


@pytest.mark.parametrize("jit", ["0", "1"])
def test_an_overflowing_prediction_is_refused_without_a_warning_compiled_or_not(jit):
    """numba's compiled predict overflows silently; run as Python (NUMBA_DISABLE_JIT=1) it is
    numpy, which would warn: ``compiled`` runs it with numpy's warnings off there."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DISABLE_JIT"}
    env["NUMBA_DISABLE_JIT"] = jit
    out = subprocess.run([sys.executable, "-c", _OVERFLOW], env=env, capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.startswith("refused: u, dt: the step's result is not finite"), out.stdout


@pytest.mark.parametrize("n_landmarks", [10, 30])
def test_compiled_ekf_steps_give_numpys_numbers(n_landmarks):
    """Each compiled step returns, to the last bit, what its Python (``py_func``, numpy)
    returns, on P stored inside larger storage as the filters keep it; the joint update to
    rounding (numba's Cholesky sums in another order; the stored studies were regenerated
    with it, bench/README.md). numba calls scipy's BLAS build and numpy its own: they agree
    here, at the course's sizes."""
    rng = np.random.default_rng(n_landmarks)
    n = 3 + 2 * n_landmarks
    for _ in range(20):
        M = rng.normal(size=(n, n)) * 0.1
        store = np.zeros((n + 8, n + 8))
        store[:n, :n] = M @ M.T + 0.01 * np.eye(n)
        x = rng.normal(size=n + 8)
        u, dt, Q = rng.normal(size=2) * 0.3, 0.02, np.diag([1e-3, 2e-3])
        A, W = models._motion_jacobians(x[:3], u, dt, 0.23)
        runs = []
        for f in (ekf.predict, ekf.predict.py_func):
            xs, Ps = x.copy(), store.copy()
            assert f(xs[:n], Ps[:n, :n], u, dt, 0.23, Q, A, W)
            runs.append((xs, Ps))
        assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])
        P = runs[0][1][:n, :n]
        m = 4                                            # four readings of landmarks 1, 3, 4, 1
        slots = np.array([5, 9, 11, 5])
        h, Hp, Hl = models.observe_landmarks(x[:3], x[slots[:, None] + (0, 1)])
        z = h + rng.normal(size=(m, 2)) * 0.05
        R = np.stack([np.diag([1e-3, 4e-4])] * m)
        for f, args in ((ekf.innovation, (z, h)), (ekf.stacked_jacobian, (slots, Hp, Hl)),
                        (ekf.block_diagonal, (R,))):
            _same(f(*args), f.py_func(*args))
        idx, H = ekf.stacked_jacobian(slots, Hp, Hl)
        _same(ekf.innovation_covariance(P, idx, H, ekf.block_diagonal(R)),
              ekf.innovation_covariance.py_func(P, idx, H, ekf.block_diagonal(R)))
        S = ekf.innovation_covariance(P, idx, H, ekf.block_diagonal(R))[1]
        y = ekf.innovation(z, h)
        _same(ekf.gate(y, S, 5.991), ekf.gate.py_func(y, S, 5.991))
        PHt, S = ekf.innovation_covariance(P, idx, H, ekf.block_diagonal(R))
        done = []                                        # the joint update: to rounding only
        for f in (ekf.joint_update, ekf.joint_update.py_func):
            xs, Ps = x[:n].copy(), P.copy()
            done.append((f(xs, Ps, PHt, S, y.reshape(-1)), xs, Ps))
        for a, b in zip(done[0], done[1]):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15 * np.abs(P).max())
        lm = x[slots[:, None] + (0, 1)]                  # h and H (py_func: numpy around the
        _same(models.observe_landmarks(x[:3], lm),       # compiled range_bearing, tested below)
              models.observe_landmarks.py_func(x[:3], lm))
        lm[1] = x[:2]                                    # a landmark on the robot: NaN rows
        got = models.observe_landmarks(x[:3], lm)
        assert [int(np.isnan(a).sum()) for a in got] == [2, 4, 4]          # h, H_pose, H_l
        for a, b in zip(got, models.observe_landmarks.py_func(x[:3], lm)):
            assert np.array_equal(a, b, equal_nan=True)


def test_compiled_range_bearing_gives_numpys_numbers():
    """The bearing's arctan2: numba calls the C library's, numpy its own code; they agree to
    the last bit where numpy's AVX-512 code is off (every make target; tests/libm_rounding.py),
    on the filters' 1-D arrays and the sensors' 2-D broadcast alike."""
    if not NUMPY_ROUNDS_AS_LIBM:
        pytest.skip(WHY)
    rng = np.random.default_rng(7)
    for shape, th in (((50,), 0.3), ((7, 9), rng.normal(size=(7, 1)))):
        d = rng.normal(size=(2,) + shape) * 3.0
        _same(models.range_bearing(d[0], d[1], th), models.range_bearing.py_func(d[0], d[1], th))


def _same(a, b) -> None:
    if isinstance(a, tuple):
        assert len(a) == len(b)
        for p, q in zip(a, b):
            _same(p, q)
    else:
        assert a.dtype == b.dtype and np.array_equal(a, b), (a, b)


def test_a_read_only_package_and_home_still_simulate(tmp_path, compiled_result):
    """numba cannot cache beside the source nor in HOME: it compiles in memory instead of
    failing (numba's ``RuntimeError: cannot cache function``). Even as root, a folder that
    is a file cannot be created, so the copy below is unwritable for numba's cache."""
    pkg = tmp_path / "site"
    shutil.copytree(ROOT / "slamlib", pkg / "slamlib",
                    ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    for folder in [pkg / "slamlib", *(p for p in (pkg / "slamlib").rglob("*") if p.is_dir())]:
        (folder / "__pycache__").write_text("not a folder")          # no cache beside a source
    home = tmp_path / "home"
    home.mkdir()
    (home / ".cache").write_text("not a folder")                      # no user-wide cache
    (pkg / "data").symlink_to(ROOT / "data")
    got = _run_in({"HOME": str(home), "XDG_CACHE_HOME": str(home / ".cache")}, cwd=tmp_path,
                  path=pkg)
    assert got["ids"] == compiled_result["ids"] and got["status"] == compiled_result["status"]
    assert got["x"] == compiled_result["x"]


# --------------------------------------------------------------------------- the runner
class _Recorder(EKFSLAM):
    """EKFSLAM that logs the public calls the runner makes."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.calls: list[str] = []

    def predict(self, u, dt):
        self.calls.append("predict")
        super().predict(u, dt)

    def update(self, ids, z, R=None):
        self.calls.append("update")
        return super().update(ids, z, R)


@pytest.mark.parametrize("max_time", [None, 23.456])
def test_the_runner_calls_predict_and_update_once_per_event(max_time):
    run = sim.scenario("arena_loop", seed=11)
    f = runner.make_filter(_Recorder, run)
    tr = runner.run_filter(run, f, max_time=max_time)
    assert f.calls == [str(k) for k in tr.kind[1:]]
    b = runner.run_filter(run, runner.make_filter(EKFSLAM, run), max_time=max_time)
    assert np.array_equal(tr.x, b.x) and np.array_equal(tr.P, b.P)
    if max_time is not None:
        assert tr.t[-1] <= max_time < run.enc_t[-1]
