"""`make student`: the solutions are emptied and every student notebook still runs from the top."""

import contextlib
import io
import os
import re
import shutil
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
                prev = cells[i - 1]       # its question: a 'More to try' cell or an exercise
                assert "More to try" in prev.source or "solution" in prev.metadata.get(
                    "tags", []), f"{p.name}: answer cell {i} follows no question"


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


# ----------------------------------------------------------------- the tool destroys nothing
def _make_student(*args, cwd=None):
    """tools/make_student.py's main in this process (importing nbformat again costs seconds)."""
    sys.path.insert(0, str(ROOT / "tools"))
    import make_student

    out, err = io.StringIO(), io.StringIO()
    here = os.getcwd()
    try:
        os.chdir(cwd or here)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = make_student.main([str(a) for a in args])
    finally:
        os.chdir(here)
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def _tiny_course(folder: Path, names=("01_a.ipynb", "02_b.ipynb")) -> Path:
    folder.mkdir(parents=True)
    for name in names:
        nb = nbformat.v4.new_notebook()
        stub = nbformat.v4.new_code_cell("def my_f():\n    return None\n\n_ = check_f(my_f)")
        sol = nbformat.v4.new_code_cell("def my_f():\n    return 1\n\n_ = check_f(my_f)",
                                        metadata={"tags": ["solution"]})
        nb.cells = [nbformat.v4.new_markdown_cell("# " + name), stub, sol]
        nbformat.write(nb, folder / name)
    (folder / "images").mkdir()
    (folder / "images" / "fig.png").write_bytes(b"png")
    return folder


def _snapshot(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def test_destination_equal_to_the_source_is_refused_and_nothing_is_deleted(tmp_path):
    src = _tiny_course(tmp_path / "nb")
    before = _snapshot(src)
    res = _make_student(src, src)
    assert res.returncode != 0 and "is the source" in res.stderr, res.stderr
    assert _snapshot(src) == before
    res = _make_student("nb", "./nb/", cwd=tmp_path)          # the same folder, spelled otherwise
    assert res.returncode != 0 and _snapshot(src) == before


@pytest.mark.parametrize("dst", ["nb/student", ".", "..", "nb/.."])
def test_destination_inside_containing_or_above_the_source_is_refused(tmp_path, dst):
    src = _tiny_course(tmp_path / "course" / "nb")
    (tmp_path / "course" / "README.md").write_text("keep me\n")
    before = _snapshot(tmp_path)
    res = _make_student("nb", dst, cwd=tmp_path / "course")
    assert res.returncode != 0, res.stdout
    assert "make_student.py: " in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert _snapshot(tmp_path) == before
    assert src.is_dir()


def test_the_project_root_and_the_current_folder_are_refused(tmp_path):
    # a copy of the tool in a throw-away project, so that a broken tool harms nothing
    proj = tmp_path / "proj"
    (proj / "tools").mkdir(parents=True)
    shutil.copy(ROOT / "tools" / "make_student.py", proj / "tools")
    (proj / "README.md").write_text("keep me\n")
    src = _tiny_course(tmp_path / "nb")
    here = tmp_path / "here"
    here.mkdir()
    (here / "notes.txt").write_text("mine\n")
    before = _snapshot(tmp_path)
    for dst, cwd in ((proj, tmp_path), (here, here), (".", here)):
        res = subprocess.run([sys.executable, str(proj / "tools" / "make_student.py"), str(src),
                              str(dst)], capture_output=True, text=True, cwd=cwd, timeout=600)
        assert res.returncode != 0 and "refusing" in res.stderr, res.stderr
    assert _snapshot(tmp_path) == before


def test_a_missing_source_or_a_broken_notebook_leaves_the_destination_as_it_was(tmp_path):
    src = _tiny_course(tmp_path / "nb")
    dst = tmp_path / "student"
    assert _make_student(src, dst).returncode == 0
    made = _snapshot(dst)
    assert set(made) >= {"01_a.ipynb", "02_b.ipynb", "images/fig.png"}
    res = _make_student(tmp_path / "no_such_folder", dst)
    assert res.returncode != 0 and "no_such_folder" in res.stderr
    assert _snapshot(dst) == made
    (src / "02_b.ipynb").write_text('{"cells": [', encoding="utf-8")
    res = _make_student(src, dst)
    assert res.returncode != 0 and "02_b.ipynb" in res.stderr, res.stderr
    assert _snapshot(dst) == made
    assert not [p for p in tmp_path.iterdir() if p.name not in ("nb", "student")]  # no temp left


def test_a_folder_the_tool_did_not_write_is_not_replaced(tmp_path):
    src = _tiny_course(tmp_path / "nb")
    dst = tmp_path / "Documents"
    dst.mkdir()
    (dst / "thesis.tex").write_text("years of work\n")
    res = _make_student(src, dst)
    assert res.returncode != 0 and "thesis.tex" in res.stderr, res.stderr
    assert (dst / "thesis.tex").read_text() == "years of work\n"
    assert len(list(dst.iterdir())) == 1


def test_the_edition_is_rebuilt_in_place_of_an_older_one(tmp_path):
    src = _tiny_course(tmp_path / "nb")
    dst = tmp_path / "student"
    assert _make_student(src, dst).returncode == 0
    (src / "01_a.ipynb").unlink()
    assert _make_student(src, dst).returncode == 0
    assert sorted(p.name for p in dst.glob("*.ipynb")) == ["02_b.ipynb"]
    assert not [p for p in tmp_path.iterdir() if p.name not in ("nb", "student")]


# ----------------------------------------------------------------- claims the student has not made
def _text(cell) -> str:
    return "".join(o.get("text", "") + str(o.get("data", {}).get("text/plain", ""))
                   for o in cell.get("outputs", []))


def test_student_edition_claims_nothing_the_student_has_not_done(student_dir):
    # Chapter 05's own filter printed "yours (my_predict_covariance, passes
    # check_predict_covariance)" in the student edition before anything was written.
    drives = 0
    for p in NOTEBOOKS:
        original = nbformat.read(p, as_version=4).cells
        cells = nbformat.read(student_dir / p.name, as_version=4).cells
        for i, c in enumerate(cells):
            if c.cell_type != "code":
                continue
            text = _text(c)
            assert "passes check_" not in text and "you predicted" not in text, (p.name, i)
            assert not re.search(r"^\w+: correct\b", text, re.M), (p.name, i, text[:200])
            if "my_joint_update(x0" in c.source:         # chapter 05: your functions on a frame
                drives += 1
                assert not c.outputs, (p.name, i)
            if "solution" in c.metadata.get("tags", []):
                # the placeholder's direction is true: the exercise and its checker are above
                assert "cell above" in c.source and "below" not in c.source
                assert "check_" in original[i - 1].source and not cells[i - 1].outputs
    assert drives >= 1


def test_strip_solutions_clears_outputs_that_ran_the_solution():
    sys.path.insert(0, str(ROOT / "tools"))
    from make_student import strip_solutions

    out = [nbformat.v4.new_output("stream", text="my_f: correct.")]
    nb = nbformat.v4.new_notebook()
    before = nbformat.v4.new_code_cell("tr = 3\nprint(tr)",
                                       outputs=[nbformat.v4.new_output("stream", text="3")])
    stub = nbformat.v4.new_code_cell("def my_f():\n    return None\n\n_ = check_f(my_f)",
                                     outputs=[nbformat.v4.new_output("stream", text="not yet")])
    sol = nbformat.v4.new_code_cell("def my_f():\n    return 1\n\n_ = check_f(my_f)\ntr = 4",
                                    outputs=out, metadata={"tags": ["solution"]})
    use = nbformat.v4.new_code_cell("print(drive(my_f))", outputs=list(out), execution_count=9)
    other = nbformat.v4.new_code_cell("print(my_fx)", outputs=[nbformat.v4.new_output(
        "stream", text="5")])
    nb.cells = [before, stub, sol, use, other]
    assert strip_solutions(nb) == 1
    assert before.outputs and other.outputs            # not the student's: kept
    assert stub.outputs == [] and sol.outputs == [] and use.outputs == []
    assert use.execution_count is None
