"""The code the chapters print is the code that runs (issue 23, point 2).

Every Python function called during a run of the course's filters is traced
(``sys.setprofile``); the functions the chapters print must be among them, and no
second implementation of a step may exist beside them.
"""

from __future__ import annotations

import inspect
import sys

import pytest

import slamlib
from slamlib import association, ekf, models, runner, sim
from slamlib.confirmation import ConfirmedSLAM
from slamlib.course.association_study import make_filter, run_without_ids

#: What each chapter prints (inspect.getsource), by chapter.
PRINTED = {
    "03": [models.observe_landmarks, models.range_bearing, ekf.innovation,
           ekf.stacked_jacobian, ekf.innovation_covariance, ekf.gate, ekf.joint_update],
    "04": [models.inverse_observe, models.inverse_observation_jacobians, ekf.augment,
           ekf.landmark_covariance, ekf.predict],
    "05": [ekf.EKFSLAM.predict, ekf.EKFSLAM._update_ids, ekf.EKFSLAM._gate_ids,
           ConfirmedSLAM.update, ConfirmedSLAM._admit],
    "06": [ekf.LinearisedEKFSLAM.jacobians, ekf.LinearisedEKFSLAM._observation],
    "09": [association.jcbb, association.solve_lower, association.nearest_neighbour],
}


def _called(fn) -> set:
    """The code objects of every Python function called while ``fn()`` runs."""
    seen = set()

    def profile(frame, event, arg):
        if event == "call":
            seen.add(frame.f_code)

    sys.setprofile(profile)
    try:
        fn()
    finally:
        sys.setprofile(None)
    return seen


@pytest.fixture(scope="module")
def called() -> set:
    run = sim.scenario("arena_loop_misreads", seed=2)
    truth = {"truth": runner.truth_function(run), "landmarks": run.world().landmarks(),
             "t0": float(run.enc_t[0])}

    def drive():
        runner.slam(run, max_time=25.0)
        runner.localization(run)
        f = runner.make_filter(ekf.FEJEKFSLAM, run)
        runner.run_filter(run, f, max_time=10.0)
        f = runner.make_filter(ekf.LinearisedEKFSLAM, run, motion="truth", **truth)
        runner.run_filter(run, f, max_time=10.0)
        runner.run_filter(run, runner.make_filter(ConfirmedSLAM, run), max_time=10.0)
        for method in ("nn", "jcbb"):
            run_without_ids(run, make_filter(run, method), max_time=10.0)

    return _called(drive)


@pytest.mark.parametrize("chapter", sorted(PRINTED))
def test_what_the_chapter_prints_runs(called, chapter):
    for fn in PRINTED[chapter]:
        assert fn.__code__ in called, f"chapter {chapter}: {fn.__qualname__} is not on the path"
        assert inspect.getsource(fn).lstrip().startswith("def ")


def test_the_library_has_one_ekf_module():
    """The filter family is ekf.py alone (no kernel module, no second, faster copy)."""
    from pathlib import Path

    files = sorted(p.name for p in Path(slamlib.__file__).parent.glob("*.py"))
    assert not [f for f in files if f.startswith("ekf") and f != "ekf.py"], files
    assert "kernels.py" not in files
    lines = len((Path(slamlib.__file__).parent / "ekf.py").read_text().splitlines())
    assert lines <= 1000, lines
