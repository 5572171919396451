"""Recorded runs: the files, their loader's errors, and the helpers the filters use."""

import json
import math
import shutil

import numpy as np
import pytest

from slamlib.models import wheel_speeds_from_ticks
from slamlib.runs import RUNS_DIR, PredictEvent, RunFormatError, UpdateEvent, load_run, save_run
from slamlib.sensors import AnalyticMarkerSensor
from slamlib.sim import SCENARIOS, KobukiParams, WaypointController, scenario, simulate
from slamlib.worlds import report_arena

RECORDED = sorted(SCENARIOS)


def runs_equal(a, b):
    same = (a.name == b.name and a.meta == b.meta
            and all(np.array_equal(getattr(a, k), getattr(b, k))
                    for k in ("truth_t", "truth", "enc_t", "ticks_R", "ticks_L")))
    return same and all(np.array_equal(getattr(a.camera, k), getattr(b.camera, k),
                                       equal_nan=True) for k in vars(a.camera))


# ----------------------------------------------------------------- the recorded runs
@pytest.mark.parametrize("name", RECORDED)
def test_recorded_run_regenerates_bit_for_bit(name, tmp_path):
    stored = load_run(name)
    fresh = scenario(name)
    assert runs_equal(stored, fresh)
    save_run(fresh, tmp_path / name)
    for f in sorted((RUNS_DIR / name).iterdir()):
        assert (tmp_path / name / f.name).read_bytes() == f.read_bytes(), f.name


def test_recorded_runs_are_small_and_complete():
    total = sum(f.stat().st_size for f in RUNS_DIR.rglob("*") if f.is_file())
    assert total < 700_000
    for name in ("arena_loop", "arena_loop_misreads", "random_loop"):
        run = load_run(name)
        assert run.world().name == run.meta["world"]
        assert 40 < run.enc_t[-1] < 120
    a, m = load_run("arena_loop"), load_run("arena_loop_misreads")
    assert np.array_equal(a.truth, m.truth) and np.array_equal(a.camera.rho, m.camera.rho)
    mis = a.camera.id != m.camera.id
    assert 0.02 < mis.mean() < 0.09
    assert np.array_equal(a.camera.id, a.camera.true_id)


def test_save_load_roundtrip(tmp_path):
    sensor = AnalyticMarkerSensor(p_outlier=0.2, latency=0.15)
    run = simulate(report_arena(), WaypointController([[3.0, 0.5], [2.5, 1.5]]), sensor=sensor,
                   seed=4)
    save_run(run, tmp_path / "r")
    back = load_run(tmp_path / "r")
    assert runs_equal(run, back)
    assert np.any(back.camera.true_id == -1) and np.isnan(back.camera.true_rho).any()
    save_run(back, tmp_path / "again")
    for f in (tmp_path / "r").iterdir():
        assert (tmp_path / "again" / f.name).read_bytes() == f.read_bytes()
    assert back.sensor() == sensor


# ----------------------------------------------------------------- helpers
def test_controls_undo_the_wrap_and_match_the_wheels():
    run = load_run("arena_loop")
    u, dt = run.controls()
    assert u.shape == (run.enc_t.size - 1, 2) and np.allclose(dt, 0.02)
    assert np.any(np.diff(run.ticks_R) < -30000)          # it wrapped ...
    assert np.abs(u).max() < 0.5                           # ... and no jump survives
    k = int(np.flatnonzero(np.diff(run.ticks_R) < -30000)[0])
    dR = int(run.ticks_R[k + 1]) + 65536 - int(run.ticks_R[k])
    assert u[k, 0] == pytest.approx(wheel_speeds_from_ticks(dR, 0, dt[k])[0])
    # integrating the wheels' speeds gives the distance driven (within slip noise)
    dist = np.sum(0.5 * (u[:, 0] + u[:, 1]) * dt)
    path = np.sum(np.hypot(*np.diff(run.truth[:, :2], axis=0).T))
    assert dist == pytest.approx(path, rel=0.02)


def test_truth_at_encoders_and_interpolation():
    run = load_run("arena_loop")
    assert np.array_equal(run.truth_at_encoders(), run.truth)
    mid = 0.5 * (run.truth_t[10] + run.truth_t[11])
    p = run.truth_at(mid)
    assert np.allclose(p[:2], 0.5 * (run.truth[10, :2] + run.truth[11, :2]))


def test_events_are_in_time_order_predict_first():
    run = load_run("arena_loop")
    ev = list(run.events())
    assert sum(isinstance(e, PredictEvent) for e in ev) == run.enc_t.size - 1
    assert sum(isinstance(e, UpdateEvent) for e in ev) == len(run.frames())
    t = np.array([e.t for e in ev])
    assert np.all(np.diff(t) >= 0)
    for a, b in zip(ev, ev[1:]):
        if a.t == b.t:
            assert not (a.kind == "update" and b.kind == "predict")
    # a frame captured at an encoder time comes right after that prediction
    first_update = next(i for i, e in enumerate(ev) if e.kind == "update" and e.t > 0)
    assert ev[first_update - 1].kind == "predict" and ev[first_update - 1].t == ev[first_update].t


def test_events_by_arrival_time_are_late():
    sensor = AnalyticMarkerSensor(latency=0.25)
    run = simulate(report_arena(), WaypointController([[3.0, 1.0]]), sensor=sensor, seed=1)
    cap = [e for e in run.events("capture") if e.kind == "update"]
    arr = [e for e in run.events("arrival") if e.kind == "update"]
    assert len(cap) == len(arr) > 5
    for c, a in zip(cap, arr):
        assert a.t == pytest.approx(c.t + 0.25) and a.obs.t == c.obs.t
    with pytest.raises(ValueError, match="by"):
        next(run.events("sometime"))


def test_Q_is_sigma_wheel_squared_plus_quantisation():
    run = load_run("arena_loop")
    q = run.Q(quantisation=False)
    assert np.allclose(q, run.sigma_wheel ** 2 * np.eye(2))
    step = 2 * math.pi * 0.035 / run.ticks_per_rev / 0.02
    assert np.allclose(run.Q(), q + step ** 2 / 6 * np.eye(2))
    quiet = simulate(report_arena(), WaypointController([[3.0, 1.0]]), seed=0,
                     params=KobukiParams(sigma_wheel=0.0))
    assert quiet.sigma_wheel == 0.0


# ----------------------------------------------------------------- malformed files
@pytest.fixture
def run_copy(tmp_path):
    dst = tmp_path / "arena_loop"
    shutil.copytree(RUNS_DIR / "arena_loop", dst)
    return dst


def edit_line(path, lineno, new):
    lines = path.read_text().split("\n")
    lines[lineno - 1] = new
    path.write_text("\n".join(lines))


@pytest.mark.parametrize("file, line, text, reason", [
    ("truth.csv", 5, "0.08,3.0,-0.77", "3 columns"),
    ("truth.csv", 7, "0.12,3.0,abc,1.5", "column y: expected a number"),
    ("truth.csv", 9, "0.16,3.0,nan,1.5", "column y: expected a finite number"),
    ("truth.csv", 9, "0.16,inf,0.0,1.5", "column x: expected a finite number"),
    ("truth.csv", 12, "0.01,3.0,0.0,1.5", "times not strictly increasing"),
    ("encoders.csv", 4, "0.06,12.5,100", "column ticks_R: expected an integer"),
    ("encoders.csv", 6, "0.08,70000,100", "column ticks_R: expected a counter"),
    ("encoders.csv", 1, "t,ticks_L,ticks_R", "header"),
    ("camera.csv", 3, "0,0,21,-1.0,0.1,21,1,0.1", "column rho: expected a range >= 0"),
    ("camera.csv", 3, "0,-0.5,21,1.0,0.1,21,1,0.1", "arrives before its capture"),
    ("camera.csv", 4, "0,0,21,1.0,nan,21,1,0.1", "column bearing: expected a finite number"),
])
def test_loader_names_file_line_and_reason(run_copy, file, line, text, reason):
    edit_line(run_copy / file, line, text)
    with pytest.raises(RunFormatError) as exc:
        load_run(run_copy)
    msg = str(exc.value)
    assert file in msg and f"line {line}" in msg and reason in msg


def test_loader_rejects_bad_meta(run_copy):
    meta = json.loads((run_copy / "meta.json").read_text())
    for key, value, reason in [("world", "atlantis", "unknown world 'atlantis'"),
                               ("format", "pickle", "format"),
                               ("motion", {"sigma_wheel": -1}, "sigma_wheel")]:
        bad = {**meta, key: value}
        (run_copy / "meta.json").write_text(json.dumps(bad))
        with pytest.raises(RunFormatError, match=reason) as exc:
            load_run(run_copy)
        assert "meta.json" in str(exc.value)
    (run_copy / "meta.json").write_text("{not json")
    with pytest.raises(RunFormatError, match="meta.json: line 1"):
        load_run(run_copy)
    (run_copy / "meta.json").unlink()
    with pytest.raises(RunFormatError, match="missing file"):
        load_run(run_copy)


def test_loader_rejects_missing_csv(run_copy):
    (run_copy / "camera.csv").unlink()
    with pytest.raises(RunFormatError, match="camera.csv: missing file"):
        load_run(run_copy)
