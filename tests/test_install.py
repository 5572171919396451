"""A non-editable ``pip install .`` works outside the source tree (issue 24, point 6).

The wheel is built from a copy of the sources (nothing is written into the checkout) with
this environment's setuptools, offline, and installed by pip into a fresh venv made
without pip; that venv borrows this venv's site-packages for numpy & co. through a .pth
file added after the install (so pip never sees, let alone touches, this environment).
From a folder outside the sources it then runs what failed when the library looked for
its data in ``site-packages/data``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

SCRIPT = r"""
import sys
from pathlib import Path

import numpy as np

import slamlib
from slamlib.worlds import DATA_DIR

site = Path(sys.argv[1]).resolve()
assert site in Path(slamlib.__file__).resolve().parents, slamlib.__file__
assert site in DATA_DIR.resolve().parents, DATA_DIR

from slamlib.datasets import mrclam
from slamlib.runs import load_run
from slamlib.sim import scenario
from slamlib.studies import monte_carlo_nees
from slamlib.vision import load_camera

run = load_run("arena_loop")
sim = scenario("arena_loop")
assert np.array_equal(run.truth, sim.truth) and np.array_equal(run.ticks_R, sim.ticks_R)
study = monte_carlo_nees("arena_loop", "localization", seeds=[1], step=10.0)
assert study.nees.shape == (1, 5) and np.isfinite(study.nees).all()
cam = load_camera()
assert cam.width == 640
log = mrclam.load()
assert log.enc_t.size > 0
from slamlib.course import studies_ch06                # a stored study, read by the course
assert studies_ch06.load_ch06_studies()
print("installed slamlib works from", Path.cwd())
"""


def _copy_sources(dst: Path) -> Path:
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
    dst.mkdir()
    shutil.copy(ROOT / "pyproject.toml", dst)
    for name in ("slamlib", "data"):
        shutil.copytree(ROOT / name, dst / name, ignore=ignore)
    return dst


def test_the_packages_list_names_every_subpackage():
    # the list is explicit (data/ is mapped into the package), so a new subpackage must be added
    tomllib = pytest.importorskip("tomllib")
    conf = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(conf["packages"])
    found = {".".join(p.parent.relative_to(ROOT).parts)
             for p in (ROOT / "slamlib").rglob("__init__.py")}
    assert found <= listed, sorted(found - listed)
    assert conf["package-dir"]["slamlib.data"] == "data"


@pytest.mark.skipif(sys.platform == "win32", reason="venv layout of POSIX")
def test_a_non_editable_install_works_outside_the_source_tree(tmp_path):
    before = sorted(p.name for p in ROOT.iterdir())
    src = _copy_sources(tmp_path / "src")
    wheels = tmp_path / "wheels"
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PIP_REQUIRE_VIRTUALENV", "MPLBACKEND")}
    env.update(PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1", PYTHONNOUSERSITE="1")
    res = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                          "--no-build-isolation", "-w", str(wheels), str(src)],
                         capture_output=True, text=True, env=env, timeout=900)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-3000:]
    (wheel,) = wheels.glob("slamlib-*.whl")

    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True,
                   timeout=300)
    py = venv / "bin" / "python"
    res = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install",
                          "--no-deps", str(wheel)], capture_output=True, text=True, env=env,
                         timeout=900)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-3000:]
    site = Path(subprocess.run([str(py), "-c", "import sysconfig; "
                                "print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())
    assert (site / "slamlib" / "data" / "worlds" / "report_arena.json").is_file()
    # the dependencies, from this environment (appended after the venv's own site-packages)
    (site / "zz_course_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    res = subprocess.run([str(py), "-c", SCRIPT, str(site)], capture_output=True, text=True,
                         cwd=elsewhere, env=env, timeout=1800)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-4000:]
    assert "installed slamlib works" in res.stdout
    assert sorted(p.name for p in ROOT.iterdir()) == before        # nothing written here
