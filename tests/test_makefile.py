"""The Makefile installs only into a venv it created, and its recipes never see MPLBACKEND.

Every test runs ``make`` in a throw-away folder with fake interpreters that only record how
they were called (and, for ``-m venv DIR``, create DIR/bin/python as another recorder), so
nothing is installed, downloaded or run for real.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FAKE = """#!/bin/bash
echo "$0|${MPLBACKEND-<unset>}|$*" >> "$FAKE_LOG"
if [ "$1" = "-m" ] && [ "$2" = "venv" ]; then mkdir -p "$3/bin" && cp "$0" "$3/bin/python"; fi
exit 0
"""
#: Targets that run the course's Python (all but venv, clean and lab).
TARGETS = ["figures", "lint", "unit", "nbval", "notebooks", "notebooks-failed",
           "check-notebooks", "book", "student", "runs", "studies", "gate-study",
           "association-study", "evidence", "bench", "graph-study", "graph-mrclam"]

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="needs GNU make")


def fake_python(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(FAKE)
    path.chmod(0o755)
    return path


@pytest.fixture
def checkout(tmp_path):
    """A folder with the Makefile and the files its venv recipe depends on."""
    co = tmp_path / "checkout"
    co.mkdir()
    for name in ("Makefile", "environment.txt", "pyproject.toml"):
        shutil.copy(ROOT / name, co / name)
    return co


def make(checkout: Path, *args: str, **env: str) -> tuple[subprocess.CompletedProcess, list]:
    log = checkout.parent / "calls.log"
    full = {**os.environ, "FAKE_LOG": str(log), **env}
    res = subprocess.run(["make", "--no-print-directory", "-C", str(checkout), *args],
                         capture_output=True, text=True, env=full, timeout=120)
    calls = [ln.split("|", 2) for ln in log.read_text().splitlines()] if log.exists() else []
    return res, calls


def test_a_given_PY_is_used_as_it_is_and_nothing_is_installed(checkout, tmp_path):
    # `make student PY=<the python of another checkout's venv>` reinstalled that venv's
    # editable slamlib, pointing it here.
    other = fake_python(tmp_path / "other" / ".venv" / "bin" / "python")
    maker = fake_python(tmp_path / "python3")
    res, calls = make(checkout, "student", f"PY={other}", f"PYTHON={maker}")
    assert res.returncode == 0, res.stderr
    assert [c[2] for c in calls] == ["tools/make_student.py notebooks student"]
    assert not (checkout / ".venv").exists()


def test_make_venv_creates_its_own_venv_and_installs_only_there(checkout, tmp_path):
    maker = fake_python(tmp_path / "python3")
    res, calls = make(checkout, "venv", f"PYTHON={maker}")
    assert res.returncode == 0, res.stderr
    own = str(checkout / ".venv" / "bin" / "python")
    assert calls[0][0] == str(maker) and calls[0][2] == "-m venv .venv"
    installs = [c for c in calls if "pip install" in c[2]]
    assert installs and all((checkout / c[0]).resolve() == Path(own).resolve() for c in installs)
    assert any(c[2].endswith("--no-deps -e .") for c in installs)
    assert (checkout / ".venv" / ".installed").exists()
    # up to date: nothing again; a changed install list reinstalls into the same venv
    assert make(checkout, "venv", f"PYTHON={maker}")[1] == calls
    os.utime(checkout / "environment.txt")
    (checkout / ".venv" / ".installed").touch()
    (checkout / "environment.txt").write_text("# changed\n")
    res, again = make(checkout, "venv", f"PYTHON={maker}")
    assert res.returncode == 0 and len(again) > len(calls)
    assert all((checkout / c[0]).resolve() == Path(own).resolve()
               for c in again[len(calls):])


def test_a_venv_make_did_not_create_is_never_installed_into_nor_removed(checkout, tmp_path):
    foreign = tmp_path / "somebody"
    fake_python(foreign / "bin" / "python")
    maker = fake_python(tmp_path / "python3")
    for target in ("venv", "figures", "clean"):
        res, calls = make(checkout, target, f"VENV={foreign}", f"PYTHON={maker}")
        assert res.returncode != 0 or target == "clean", (target, res.stdout)
        assert "not created by make" in res.stderr + res.stdout, (target, res.stderr)
        assert calls == [], (target, calls)
        assert (foreign / "bin" / "python").exists()


@pytest.mark.parametrize("target", TARGETS)
def test_recipes_do_not_see_MPLBACKEND(checkout, tmp_path, target):
    # matplotlib refuses an unknown backend at import: `MPLBACKEND=bogus make figures` failed
    py = fake_python(tmp_path / "py" / "bin" / "python")
    res, calls = make(checkout, target, f"PY={py}", MPLBACKEND="bogus")
    assert res.returncode == 0, res.stderr
    assert calls, target
    assert all(c[1] == "<unset>" for c in calls), calls
    assert all(c[0] == str(py) for c in calls), calls          # PY=... is the one used


def test_recipes_compute_with_numpys_avx512_code_off(checkout, tmp_path):
    # The committed notebooks and studies are made on machines without AVX-512. With numpy's
    # AVX-512 code on, arctan2, exp and log round differently in the last bit, and `make test`
    # failed on such a machine (six notebooks would change, four nbval cells differed).
    log = tmp_path / "env.log"
    py = tmp_path / "py" / "bin" / "python"
    py.parent.mkdir(parents=True)
    py.write_text(f'#!/bin/bash\necho "${{NPY_DISABLE_CPU_FEATURES-<unset>}}" >> "{log}"\n')
    py.chmod(0o755)
    for target in ("check-notebooks", "nbval", "studies", "notebooks"):
        res, _ = make(checkout, target, f"PY={py}")
        assert res.returncode == 0, res.stderr
    seen = set(log.read_text().splitlines())
    assert len(seen) == 1 and "<unset>" not in seen, seen
    # ... and that setting gives the C library's numbers, element by element (on a machine
    # without AVX-512 this holds with or without it)
    code = ("import math, numpy as np\n"
            "a = np.random.default_rng(1).uniform(-20, 20, (2, 20000))\n"
            "pairs = [(np.arctan2(*a), [math.atan2(p, q) for p, q in a.T]),\n"
            "         (np.exp(a[0]), [math.exp(p) for p in a[0]]),\n"
            "         (np.log(abs(a[0])), [math.log(abs(p)) for p in a[0]])]\n"
            "print([int(np.count_nonzero(f != np.array(g))) for f, g in pairs])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**os.environ, "NPY_DISABLE_CPU_FEATURES": seen.pop()},
                         timeout=120, check=True).stdout
    assert out.strip() == "[0, 0, 0]", out
