"""`make student`: the solutions are emptied and every student notebook still runs from the top."""

import os
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


@pytest.fixture(scope="module")
def student_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("student")
    subprocess.run([sys.executable, str(ROOT / "tools" / "make_student.py"),
                    str(ROOT / "notebooks"), str(out)], check=True, capture_output=True)
    return out


def solution_cells(nb):
    return [c for c in nb.cells if "solution" in c.metadata.get("tags", [])]


def test_every_chapter_has_a_hidden_solution():
    for p in NOTEBOOKS:
        sols = solution_cells(nbformat.read(p, as_version=4))
        assert sols, f"{p.name}: no cell tagged 'solution'"
        for c in sols:
            assert c.metadata.get("jupyter", {}).get("source_hidden"), f"{p.name}: not collapsed"


def test_the_students_own_cell_is_checked_before_any_solution():
    # The checker must run in the student's cell: a solution cell placed between the
    # student's answer and the checker would overwrite the answer on "Run All".
    for p in NOTEBOOKS:
        cells = nbformat.read(p, as_version=4).cells
        for i, c in enumerate(cells):
            if "solution" in c.metadata.get("tags", []):
                student = cells[i - 1]
                assert "check_" in student.source and "solution" not in student.metadata.get(
                    "tags", []), f"{p.name}: cell {i - 1} (the student's) does not call a checker"
                out = "".join(o.get("text", "") for o in student.get("outputs", []))
                assert "not written yet" in out, f"{p.name}: the stub's checker output is {out!r}"


def test_student_edition_runs_from_the_top(student_dir):
    # Each student notebook is executed top to bottom (nbval's lax mode: every cell must run
    # without error; outputs are not compared). The checker cells print "not written yet",
    # which test_the_students_own_cell_is_checked_before_any_solution asserts on the
    # student's cell that the student edition keeps unchanged.
    for p in NOTEBOOKS:
        nb = nbformat.read(student_dir / p.name, as_version=4)
        original = nbformat.read(p, as_version=4)
        assert len(nb.cells) == len(original.cells)
        for c in solution_cells(nb):
            assert "Solution removed" in c.source and not c.outputs
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    res = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                          "--nbval-lax", "--nbval-current-env", "--nbval-cell-timeout=300",
                          "--rootdir", str(student_dir), str(student_dir)],
                         capture_output=True, text=True, env=env, timeout=3000)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    assert " passed" in res.stdout and "failed" not in res.stdout, res.stdout[-2000:]
