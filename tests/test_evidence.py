"""The stored 100-seed studies (data/evidence) and the course code that makes them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from same_record import assert_same_record

from slamlib.course import evidence as ev
from slamlib.ekf import EKFLocalization
from slamlib.runner import DEFAULT_P0, reading_covariances, run_filter
from slamlib.runs import load_run


@pytest.mark.parametrize("name, seeds", [("arena_localization", (1, 64)),
                                         ("arena_sign_error", (1, 77)),
                                         ("arena_slam", (1, 37)),
                                         ("arena_slam_misreads", (42,)),
                                         ("arena_camera", (23,)),
                                         ("explore_world5", (5,)),
                                         ("arena_noise", (1, 58))])
def test_stored_study_recomputes_exactly(name, seeds):
    """A sample of the stored seeds, recomputed from scratch, gives the stored numbers bit
    for bit (the file was made by the code under test, not edited)."""
    study = ev.load_study(name)
    assert study["seeds"] == list(ev.SEEDS)
    for seed in seeds:
        fresh = json.loads(json.dumps(ev.STUDIES[name](seed)))
        # the exploration steers on its own estimate: closed loop (tests/same_record.py)
        tol = dict(rel=1e-3, count_rel=1e-3) if name.startswith("explore") else {}
        assert_same_record(fresh, study["runs"][study["seeds"].index(seed)], f"{name} {seed}",
                           **tol)


def test_seed_1_is_the_recorded_run():
    """The studies' seed 1 is data/runs/arena_loop: its stored gate-0.95 numbers are those
    of the library's own localization on the recorded run."""
    from slamlib.runner import localization

    tr = localization(load_run("arena_loop"))
    stored = ev.load_study("arena_localization")["runs"][0]["clean/0.95"]
    e = tr.error[1:]
    assert stored["n"] == e.shape[0]
    assert stored["nees_sum"] == pytest.approx(float(np.sum(tr.nees[1:])), rel=1e-12)
    assert stored["e2_sum"] == pytest.approx(list(np.sum(e ** 2, axis=0)), rel=1e-12)
    assert stored["rejected"] == tr.counts().get("rejected", 0)


def test_model_r_localization_scales_and_models_R():
    """factor f on the std is the library's filter given f^2 R; with no R given, the noise
    model's R(range) is used."""
    run = load_run("arena_loop")
    lm = run.world().landmarks()
    args = (run.start_pose, DEFAULT_P0, run.Q(), run.sensor().R(2.0), lm)
    scaled = ev.ModelRLocalization(*args, wheel_base=run.wheel_base, factor=2.0)
    plain = EKFLocalization(*args, wheel_base=run.wheel_base)
    sensor = run.sensor()
    for ev_ in list(run.events())[:400]:
        if ev_.kind == "predict":
            scaled.predict(ev_.u, ev_.dt)
            plain.predict(ev_.u, ev_.dt)
        elif len(ev_.obs):
            R = reading_covariances(sensor, ev_.obs.z)
            scaled.update(ev_.obs.ids, ev_.obs.z, R=R)
            plain.update(ev_.obs.ids, ev_.obs.z, R=4.0 * R)
    np.testing.assert_array_equal(scaled.x, plain.x)
    np.testing.assert_array_equal(scaled.P, plain.P)
    modelled = ev.ModelRLocalization(*args, wheel_base=run.wheel_base, noise=sensor)
    a = run_filter(run, modelled, use_sensor_R=False, max_time=10.0)
    b = run_filter(run, EKFLocalization(*args, wheel_base=run.wheel_base), max_time=10.0)
    np.testing.assert_array_equal(a.x, b.x)


def test_decimate_keeps_every_kth_capture():
    run = load_run("arena_loop")
    d = ev.decimate(run, 3)
    j = np.round(run.camera.t_capture * 10).astype(int)
    assert len(d.camera) == int(np.sum(j % 3 == 0)) > 0
    np.testing.assert_array_equal(d.camera.rho, run.camera.rho[j % 3 == 0])
    assert ev.decimate(run, 1) is run
    np.testing.assert_array_equal(d.truth, run.truth)


def test_error_correlation_finds_a_known_ar1_correlation():
    """Readings whose range errors follow an AR(1) with coefficient 0.6 (bearing errors
    white): the pooled lag-L correlation is about 0.6^L for range and about 0 for bearing."""
    from dataclasses import replace

    from slamlib.runs import CameraRows
    from slamlib.sensors import AnalyticMarkerSensor

    sensor = AnalyticMarkerSensor()
    rng = np.random.default_rng(5)
    n, phi = 20000, 0.6
    w = rng.standard_normal(n)
    a = np.empty(n)
    a[0] = w[0]
    for k in range(1, n):
        a[k] = phi * a[k - 1] + np.sqrt(1 - phi ** 2) * w[k]
    true_rho = np.full(n, 2.0)
    # rho - true = sigma(rho) a with sigma(rho) = s0 + s1 rho: the error over R at the reading is a
    s0, s1 = sensor.sigma_range0, sensor.sigma_range_per_m
    rho = (true_rho + s0 * a) / (1.0 - s1 * a)
    bearing = sensor.sigma_bearing * rng.standard_normal(n)
    t = np.arange(n) / 10.0
    ids = np.full(n, 7)
    cam = CameraRows(t, t, ids, rho, bearing, ids, true_rho, np.zeros(n))
    run = replace(load_run("arena_loop"), camera=cam)
    parts = [ev.error_correlation(run, sensor, lags=(1, 2, 3))]
    for lag in (1, 2, 3):
        r = ev.pooled_correlation(parts, lag)
        assert r[0] == pytest.approx(phi ** lag, abs=0.03)
        assert abs(r[1]) < 0.03


def test_load_study_errors(tmp_path: Path):
    with pytest.raises(ValueError, match="no stored study"):
        ev.load_study("arena_slam", folder=tmp_path)
    (tmp_path / "arena_slam.json").write_text("{\n  \"format\": 1,\n")
    with pytest.raises(ValueError, match="line"):
        ev.load_study("arena_slam", folder=tmp_path)
    (tmp_path / "arena_slam.json").write_text(json.dumps({"format": "other"}))
    with pytest.raises(ValueError, match="format"):
        ev.load_study("arena_slam", folder=tmp_path)
    with pytest.raises(ValueError, match="name"):
        ev.run_study("nope", seeds=(1,))


def test_rank():
    assert ev.rank([1, 2, 3, 4], 3) == (2, 0.5)

# that the library never imports the course is tested in test_layout.py (every import parsed)


def test_broken_filter_has_the_reports_H_and_the_stored_tracking_run_is_the_library():
    """BrokenReportHLocalization's H_pose is errata.printed_H_pose number for number; the
    sign-error study's library filter started at the truth is arena_localization's
    clean/0.95 filter (the same numbers, computed twice)."""
    from slamlib.course.errata import CHECK_LANDMARK, CHECK_POSE, printed_H_pose

    f = ev.BrokenReportHLocalization(CHECK_POSE, np.eye(3), np.eye(2), np.eye(2),
                                     {0: CHECK_LANDMARK})
    _, Hp, _ = f.reading_model(CHECK_POSE, CHECK_LANDMARK[None, :])
    assert np.array_equal(Hp[0], printed_H_pose(CHECK_POSE, CHECK_LANDMARK))
    a = ev.load_study("arena_sign_error")["runs"][5]["tracking/library"]
    b = ev.load_study("arena_localization")["runs"][5]["clean/0.95"]
    assert a == {k: b[k] for k in a}


def test_the_command_line_checks_a_study_against_its_file(capsys):
    """``--check`` recomputes (here: a stand-in that returns the stored study, or one changed
    number) and compares with the file, without writing it."""
    from slamlib.course import evidence

    stored = evidence.load_study("arena_noise")
    changed = json.loads(json.dumps(stored))
    changed["runs"][0][next(iter(changed["runs"][0]))] = "changed"
    before = (evidence.EVIDENCE_DIR / "arena_noise.json").read_bytes()
    assert evidence.main(["arena_noise", "--check"], {"arena_noise": None},
                         lambda name, workers: stored) == 0
    assert evidence.main(["arena_noise", "--check"], {"arena_noise": None},
                         lambda name, workers: changed) == 1
    assert "unchanged" in capsys.readouterr().out.splitlines()[0]
    assert (evidence.EVIDENCE_DIR / "arena_noise.json").read_bytes() == before
