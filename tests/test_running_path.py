"""The code the chapters print is the code that runs (issue 23, point 2).

Every Python function called during a run of the course's filters is traced
(``sys.setprofile``, with NUMBA_DISABLE_JIT=1 so that the functions numba compiles run as
the Python they are compiled from); the functions the chapters print must be among them,
and no second implementation of a step may exist beside them.
"""

from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys

import pytest

import slamlib
from slamlib import association, ekf, models
from slamlib.confirmation import ConfirmedSLAM

#: What each chapter prints (inspect.getsource), by chapter.
PRINTED = {
    "03": [models.observe_landmarks, models.range_bearing, ekf.innovation,
           ekf.stacked_jacobian, ekf.innovation_covariance, ekf.gate, association.individual_d2,
           ekf.joint_update],
    "04": [models.inverse_observe, models.inverse_observation_jacobians, ekf.augment,
           ekf.landmark_covariance, ekf.predict],
    "05": [ekf.EKFSLAM.predict, ekf.EKFSLAM._update_ids, ekf.EKFSLAM._gate_ids, ekf.EKFSLAM._fuse,
           ConfirmedSLAM.update, ConfirmedSLAM._admit],
    "06": [ekf.LinearisedEKFSLAM.jacobians, ekf.LinearisedEKFSLAM._observation],
    "09": [association.jcbb, association.solve_lower, association.nearest_neighbour],
}


#: A run of every filter the chapters use; run below with NUMBA_DISABLE_JIT=1, where the
#: compiled functions (slamlib.compiled) run as the Python they are compiled from.
_DRIVE = """
import json, sys
from slamlib import ekf, runner, sim
from slamlib.confirmation import ConfirmedSLAM
from slamlib.course.association_study import make_filter, run_without_ids

run = sim.scenario("arena_loop_misreads", seed=2)
truth = {"truth": runner.truth_function(run), "landmarks": run.world().landmarks(),
         "t0": float(run.enc_t[0])}
seen = set()

def profile(frame, event, arg):
    if event == "call":
        code = frame.f_code
        seen.add((code.co_filename, code.co_firstlineno, code.co_name))

sys.setprofile(profile)
runner.slam(run, max_time=25.0)
runner.localization(run)
runner.run_filter(run, runner.make_filter(ekf.FEJEKFSLAM, run), max_time=10.0)
f = runner.make_filter(ekf.LinearisedEKFSLAM, run, motion="truth", **truth)
runner.run_filter(run, f, max_time=10.0)
runner.run_filter(run, runner.make_filter(ConfirmedSLAM, run), max_time=10.0)
for method in ("nn", "jcbb"):
    run_without_ids(run, make_filter(run, method), max_time=10.0)
sys.setprofile(None)
print(json.dumps(sorted(seen)))
"""


def _key(fn) -> tuple:
    """The printed function's code (a compiled one's: the Python it is compiled from)."""
    code = getattr(fn, "py_func", fn).__code__
    return code.co_filename, code.co_firstlineno, code.co_name


@pytest.fixture(scope="module")
def called() -> set:
    """Every Python function called while the filters run, as (file, first line, name)."""
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
    out = subprocess.run([sys.executable, "-c", _DRIVE], env=env, capture_output=True,
                         text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    return {tuple(c) for c in json.loads(out.stdout.strip().splitlines()[-1])}


@pytest.mark.parametrize("chapter", sorted(PRINTED))
def test_what_the_chapter_prints_runs(called, chapter):
    for fn in PRINTED[chapter]:
        assert _key(fn) in called, f"chapter {chapter}: {fn.__qualname__} is not on the path"
        source = inspect.getsource(fn).lstrip()
        assert source.startswith(("def ", "@compiled\ndef ")), source[:80]


def test_compiled_functions_are_the_printed_ones():
    """numba compiles the function a chapter prints (its ``py_func``), not a second copy, and
    the filters call the compiled one."""
    import numba

    for fn in (ekf.predict, ekf.innovation, ekf.stacked_jacobian, ekf.innovation_covariance,
               ekf.gate, models.observe_landmarks, models.range_bearing,
               association.individual_d2):
        assert isinstance(fn, numba.core.dispatcher.Dispatcher), fn
        assert fn.py_func.__module__ == fn.__module__ and fn.py_func.__name__ == fn.__name__
        assert inspect.getsource(fn) == inspect.getsource(fn.py_func)


def test_the_library_has_one_ekf_module():
    """The filter family is ekf.py alone (no kernel module, no second, faster copy)."""
    from pathlib import Path

    files = sorted(p.name for p in Path(slamlib.__file__).parent.glob("*.py"))
    assert not [f for f in files if f.startswith("ekf") and f != "ekf.py"], files
    assert "kernels.py" not in files
    lines = len((Path(slamlib.__file__).parent / "ekf.py").read_text().splitlines())
    assert lines <= 1000, lines
