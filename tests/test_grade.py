"""tools/grade.py (``make grade SUBMISSIONS=dir``): the course's checkers grade students' notebooks.

One grading run over five students who hand in chapter 00 and/or appendix A: the
full notebooks (every point), the student edition (no point), one broken
exercise (exactly its point lost), a cell that hangs and ignores the interrupt
(cut by the timeout, its exercise lost, the other graded), a cell that kills
the kernel (the same). The submitted files are never changed.
"""

from __future__ import annotations

import csv
import hashlib
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))

from grade import exercises, graded_copy  # noqa: E402
from make_student import strip_solutions  # noqa: E402

CH00, APPX = "00_frames_and_state.ipynb", "A_errata.ipynb"
TIMEOUT = 60


def test_every_solution_cell_is_an_exercise_with_the_courses_checker():
    found = exercises(ROOT / "notebooks")
    solutions = 0
    for p in sorted((ROOT / "notebooks").glob("*.ipynb")):
        nb = nbformat.read(p, as_version=4)
        solutions += sum(1 for c in nb.cells
                         if c.cell_type == "code" and "solution" in c.metadata.get("tags", []))
    assert len(found) == solutions > 20
    assert len({e.key for e in found}) == len(found)
    assert all(e.call.startswith("check") and e.points == 1 for e in found)
    keys = {e.key: e for e in found}
    assert keys["00.my_pose_from_zup"].call == "check_pose_from_zup(my_pose_from_zup)"
    assert keys["A.my_numerical_jacobian"].notebook == APPX


def test_the_grader_cell_follows_the_solution_cell_of_the_student_edition():
    nb = nbformat.read(ROOT / "notebooks" / APPX, as_version=4)
    strip_solutions(nb)
    todo = [e for e in exercises(ROOT / "notebooks") if e.notebook == APPX]
    graded = graded_copy(nb, todo, "TOKEN")
    ids = [c.get("id") for c in graded.cells]
    for ex in todo:
        at = ids.index(ex.cell_id)
        assert graded.cells[at + 1].metadata["grader"] == ex.key
        assert ex.call in graded.cells[at + 1].source
    assert all(not c.get("outputs") for c in graded.cells if c.cell_type == "code")


def _solutions(nb) -> list:
    return [c for c in nb.cells if "solution" in c.metadata.get("tags", [])]


def _digest(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.glob("*.ipynb")}


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    subs = tmp_path_factory.mktemp("submissions")
    nbs = ROOT / "notebooks"
    for name in ("full", "student", "broken", "hanging", "crash"):
        (subs / name).mkdir()
    for nb_name in (CH00, APPX):
        shutil.copy2(nbs / nb_name, subs / "full" / nb_name)
        nb = nbformat.read(nbs / nb_name, as_version=4)
        strip_solutions(nb)
        nbformat.write(nb, subs / "student" / nb_name)
    edits = {
        # a wrong answer: every difference shifted by 0.1 (the checker must say so)
        "broken": lambda src: src.replace("columns = []", "columns = []\n    x = x + 0.1"),
        # a loop that ignores the interrupt: the kernel must be restarted
        "hanging": lambda src: ("import signal\nsignal.signal(signal.SIGINT, signal.SIG_IGN)\n"
                                "while True:\n    pass\n" + src),
        # a cell that kills its kernel
        "crash": lambda src: "import os\nos._exit(3)\n",
    }
    for name, edit in edits.items():
        nb = nbformat.read(nbs / APPX, as_version=4)
        first = _solutions(nb)[0]
        first.source = edit(first.source)
        nbformat.write(nb, subs / name / APPX)
    before = {p.name: _digest(p) for p in subs.iterdir()}
    run = subprocess.run([sys.executable, str(ROOT / "tools" / "grade.py"), str(subs),
                          "--timeout", str(TIMEOUT)], capture_output=True, text=True,
                         timeout=1800)
    assert run.returncode == 0, run.stdout + run.stderr
    with open(subs / "grades.csv", newline="", encoding="utf-8") as f:
        rows = {r["student"]: r for r in csv.DictReader(f)}
    return subs, rows, before


def test_grades_csv_has_a_row_per_student_and_a_column_per_exercise(graded):
    subs, rows, _ = graded
    with open(subs / "grades.csv", encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    keys = [e.key for e in exercises(ROOT / "notebooks")]
    assert header == ["student", *keys, "total"]
    assert sorted(rows) == ["broken", "crash", "full", "hanging", "student"]


def test_full_notebooks_get_every_point_and_the_student_edition_none(graded):
    _, rows, _ = graded
    mine = ["00.my_pose_from_zup", "A.my_numerical_jacobian", "A.my_best_step"]
    assert [rows["full"][k] for k in mine] == ["1", "1", "1"]
    assert rows["full"]["total"] == "3"   # the chapters not handed in give nothing
    assert [rows["student"][k] for k in mine] == ["0", "0", "0"]
    assert rows["student"]["total"] == "0"


@pytest.mark.parametrize("student", ["broken", "hanging", "crash"])
def test_a_bad_exercise_loses_exactly_its_points(graded, student):
    _, rows, _ = graded
    assert rows[student]["A.my_numerical_jacobian"] == "0"
    assert rows[student]["A.my_best_step"] == "1"
    assert rows[student]["total"] == "1"


def test_feedback_beside_the_work_says_what_the_checkers_said(graded):
    subs, _, _ = graded
    student = (subs / "student" / "feedback.md").read_text(encoding="utf-8")
    assert "Total: 0 of" in student and "not written yet" in student
    full = (subs / "full" / "feedback.md").read_text(encoding="utf-8")
    assert "Total: 3 of" in full and "Not submitted (no points): 01_dead_reckoning.ipynb" in full
    hanging = (subs / "hanging" / "feedback.md").read_text(encoding="utf-8")
    assert f"the cell ran longer than {TIMEOUT} s" in hanging and "restarted" in hanging
    crash = (subs / "crash" / "feedback.md").read_text(encoding="utf-8")
    assert "kernel died" in crash


def test_submitted_files_are_never_changed(graded):
    subs, _, before = graded
    assert {p.name: _digest(p) for p in subs.iterdir() if p.is_dir()} == before
    assert sorted(p.name for p in (subs / "hanging").iterdir()) == [APPX, "feedback.md"]
