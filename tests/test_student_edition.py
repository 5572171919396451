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


def answer_cells(nb):
    return [c for c in nb.cells if "answer" in c.metadata.get("tags", [])]


def test_more_to_try_answers_are_collapsed_and_follow_their_questions():
    for p in NOTEBOOKS:
        cells = nbformat.read(p, as_version=4).cells
        for i, c in enumerate(cells):
            if "answer" in c.metadata.get("tags", []):
                hidden = c.metadata.get("jupyter", {}).get("source_hidden")
                assert hidden, f"{p.name}: answer cell {i} is not collapsed"
                assert "More to try" in cells[i - 1].source, (
                    f"{p.name}: answer cell {i} does not follow a 'More to try' cell")


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
        assert len(answer_cells(nb)) == len(answer_cells(original))
        for c in answer_cells(nb):
            assert "answer removed" in c.source and not c.get("outputs")
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    res = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                          "--nbval-lax", "--nbval-current-env", "--nbval-cell-timeout=300",
                          "--rootdir", str(student_dir), str(student_dir)],
                         capture_output=True, text=True, env=env, timeout=3000)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    assert " passed" in res.stdout and "failed" not in res.stdout, res.stdout[-2000:]


def test_strip_solutions_empties_solution_and_answer_cells_only():
    sys.path.insert(0, str(ROOT / "tools"))
    from make_student import strip_solutions

    nb = nbformat.v4.new_notebook()
    sol = nbformat.v4.new_code_cell("x = 1", outputs=[nbformat.v4.new_output("stream", text="1")])
    sol.metadata = {"tags": ["solution"]}
    ans = nbformat.v4.new_markdown_cell("**Answers.** 62 degrees")
    ans.metadata = {"tags": ["answer"]}
    ans_code = nbformat.v4.new_code_cell("print(62)", execution_count=3)
    ans_code.metadata = {"tags": ["answer"]}
    plain = nbformat.v4.new_markdown_cell("**More to try.** What is the bound?")
    nb.cells = [plain, ans, sol, ans_code]
    assert strip_solutions(nb) == 3
    assert nb.cells[0].source == "**More to try.** What is the bound?"
    assert "answer removed" in nb.cells[1].source and "62" not in nb.cells[1].source
    assert "Solution removed" in nb.cells[2].source and nb.cells[2].outputs == []
    assert "answer removed" in nb.cells[3].source and nb.cells[3].execution_count is None
