"""`make student`: the solutions are emptied and every student notebook still runs from the top."""

import subprocess
import sys
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

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


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_student_notebook_runs_and_checkers_say_not_written(student_dir, path):
    nb = nbformat.read(student_dir / path.name, as_version=4)
    original = nbformat.read(path, as_version=4)
    for c in solution_cells(nb):
        assert "Solution removed" in c.source and not c.outputs
    assert len(nb.cells) == len(original.cells)
    NotebookClient(nb, timeout=300, kernel_name="python3",
                   resources={"metadata": {"path": str(student_dir)}}).execute()
    text = "\n".join(o.get("text", "") for c in nb.cells if c.cell_type == "code"
                     for o in c.outputs if o.output_type == "stream")
    assert "not written yet" in text, f"{path.name}: no checker reported the missing answer"
