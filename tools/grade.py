"""Grade the students' notebooks with the course's own checkers (``make grade SUBMISSIONS=dir``).

Usage: python tools/grade.py SUBMISSIONS [--timeout S] [--reference notebooks]

``SUBMISSIONS`` holds one folder per student; each folder holds any of the
chapter notebooks, named as the student edition names them (``make student``:
the chapters' own names). Writes ``SUBMISSIONS/grades.csv`` (the student's
folder name, one column per exercise with its points, ``total``) and, beside
each student's work, ``feedback.md``: every exercise's points and what its
checker said. Nothing else is written, and a submitted file is never changed:
each notebook is graded as a copy, in a temporary folder.

The exercises are the reference notebooks' solution cells (tag ``solution``):
one exercise each, worth ``points`` (the cell's metadata, 1 if absent), graded
by the checker call that the solution cell ends with (``check_...(...)``). In
the student's copy a grader cell is inserted right after the place of that
solution cell (found by its cell id, which the student edition keeps; else
after the exercise cell before it; else at the end). The grader cell runs the
REFERENCE checker call, whatever the student's cells call, and prints its
verdict with a token the student's code cannot know in advance.

Each notebook runs in its own kernel; each cell may run ``--timeout`` seconds
(120), then the kernel is interrupted. A cell that ignores the interrupt or
kills the kernel costs what it broke and no more: the kernel is restarted and
the cells that ran before are run again, without that cell. A notebook that is
not valid JSON, or not a notebook, gets no points and says so in the feedback.

This is not a sandbox: the submissions' code runs as the grader's user. Grade
untrusted work in a container or a throw-away account.

Why not otter-grader or nbgrader: otter grades in Docker containers by default
(its local mode needs notebooks written in its own ``otter assign`` format,
with tests as its test files), and nbgrader needs its course folder layout,
its gradebook database and its own release step with nbgrader cell metadata,
and scores a test cell by whether it raises. The course's checkers print a
verdict and return True or False, and the student edition is made by
``tools/make_student.py``; nbclient (which both build on) runs them as they are.
"""

from __future__ import annotations

import argparse
import ast
import csv
import hashlib
import re
import secrets
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parent.parent
FEEDBACK = "feedback.md"
GRADES = "grades.csv"


@dataclass(frozen=True)
class Exercise:
    """One graded exercise of a chapter."""

    notebook: str          # the chapter's file name
    key: str               # the column of grades.csv: "<chapter>.<name>"
    call: str              # the checker call, as in the reference solution cell
    cell_id: str | None    # the reference solution cell's id
    before_id: str | None  # the id of the code cell before it (the exercise cell)
    points: float = 1.0


@dataclass
class Result:
    """An exercise's points and the checker's words."""

    points: float = 0.0
    feedback: list[str] = field(default_factory=list)


def _name(func: ast.expr) -> str:
    """A called function's own name: ``check_x`` for ``check_x(...)`` and ``mod.check_x(...)``."""
    if isinstance(func, ast.Name):
        return func.id
    return func.attr if isinstance(func, ast.Attribute) else ""


def _checker_call(source: str) -> ast.Call | None:
    """The last call of a function named ``check...`` (or ``module.check...``) among the cell's
    statements."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return None
    found = None
    for stmt in tree.body:
        for node in ast.walk(stmt):
            if isinstance(node, ast.Call) and _name(node.func).startswith("check"):
                found = node
                break
    return found


def exercises(reference: Path) -> list[Exercise]:
    """Every exercise of the reference notebooks, in chapter order."""
    found = []
    for path in sorted(reference.glob("*.ipynb")):
        nb = nbformat.read(path, as_version=4)
        chapter = path.stem.split("_")[0]
        prev = None
        for cell in nb.cells:
            tags = cell.metadata.get("tags", [])
            if cell.cell_type == "code" and "solution" in tags:
                call = _checker_call(cell.source)
                if call is not None:
                    first = call.args[0] if call.args else None
                    name = first.id if isinstance(first, ast.Name) else _name(call.func)
                    found.append(Exercise(
                        notebook=path.name, key=f"{chapter}.{name}",
                        call=ast.get_source_segment(cell.source, call), cell_id=cell.get("id"),
                        before_id=prev.get("id") if prev is not None else None,
                        points=float(cell.metadata.get("points", 1))))
            if cell.cell_type == "code":
                prev = cell
    keys = [e.key for e in found]
    duplicated = sorted({k for k in keys if keys.count(k) > 1})
    if duplicated:
        raise ValueError(f"reference: two exercises share the column name(s) {duplicated}")
    return found


def grader_cell(ex: Exercise, token: str) -> nbformat.NotebookNode:
    """The cell that runs the reference checker call and prints the verdict with ``token``."""
    source = (f"__grade_ok = False\n"
              f"try:\n"
              f"    __grade_ok = bool({ex.call})\n"
              f"except BaseException as __grade_exc:\n"
              f"    print(f'the checker could not run: {{type(__grade_exc).__name__}}: "
              f"{{__grade_exc}}')\n"
              f"print({token!r}, {ex.key!r}, 'PASS' if __grade_ok is True else 'FAIL')\n")
    cell = nbformat.v4.new_code_cell(source)
    cell.metadata["grader"] = ex.key
    return cell


def graded_copy(nb: nbformat.NotebookNode, todo: list[Exercise], token: str
                ) -> nbformat.NotebookNode:
    """The student's cells (outputs cleared) with a grader cell after each exercise's place."""
    cells = [c for c in nb.cells if c.cell_type in ("code", "markdown", "raw")]
    for c in cells:
        if c.cell_type == "code":
            c.outputs, c.execution_count = [], None
    ids = [c.get("id") for c in cells]
    inserts: dict[int, list] = {}
    for ex in todo:
        where = len(cells) - 1
        for anchor in (ex.cell_id, ex.before_id):
            if anchor and anchor in ids:
                where = ids.index(anchor)
                break
        inserts.setdefault(where, []).append(grader_cell(ex, token))
    out = []
    for i, c in enumerate(cells):
        out.append(c)
        out += inserts.get(i, [])
    out += inserts.get(-1, [])
    graded = nbformat.v4.new_notebook(cells=out, metadata=nb.get("metadata", {}))
    return graded


TIMED_OUT = "CellTimeoutError"


def _timed_out(client, cell, index: int, timeout: int) -> bool:
    """Run one cell; True (and an error output on the cell) if it ran out of time."""
    start = time.monotonic()
    client.execute_cell(cell, index)
    if time.monotonic() - start < timeout:
        return False
    cell.outputs.append(nbformat.v4.new_output(
        "error", ename=TIMED_OUT, evalue=f"the cell ran longer than {timeout} s", traceback=[]))
    return True


def _run(nb: nbformat.NotebookNode, workdir: Path, timeout: int, skip: set[int]) -> int | None:
    """Run the code cells not in ``skip`` in a new kernel; the index of a cell that killed or
    wedged the kernel (the caller skips it and runs again), or None when all ran."""
    from nbclient import NotebookClient
    from nbclient.exceptions import DeadKernelError

    client = NotebookClient(
        nb, timeout=timeout, kernel_name="python3", allow_errors=True, record_timing=False,
        interrupt_on_timeout=True,
        error_on_timeout={"ename": TIMED_OUT, "evalue": f"the cell ran longer than {timeout} s",
                          "traceback": []},
        resources={"metadata": {"path": str(workdir)}})
    current = None
    try:
        with client.setup_kernel():
            for i, cell in enumerate(nb.cells):
                if cell.cell_type != "code" or i in skip:
                    continue
                current = i
                cell.outputs = []
                if _timed_out(client, cell, i, timeout):
                    # interrupted: does the kernel answer again?
                    nb.cells.append(nbformat.v4.new_code_cell("pass"))
                    client.timeout = 30
                    try:
                        wedged = _timed_out(client, nb.cells[-1], len(nb.cells) - 1, 30)
                    finally:
                        nb.cells.pop()
                        client.timeout = timeout
                    if wedged:
                        return i
    except DeadKernelError:
        nb.cells[current].outputs.append(nbformat.v4.new_output(
            "error", ename="DeadKernelError", evalue="the kernel died in this cell", traceback=[]))
        return current
    except Exception as exc:  # noqa: BLE001 - the grader goes on whatever a notebook did
        if current is None:
            raise
        nb.cells[current].outputs.append(nbformat.v4.new_output(
            "error", ename=type(exc).__name__, evalue=str(exc), traceback=[]))
        return current
    return None


def run_graded(nb: nbformat.NotebookNode, workdir: Path, timeout: int,
               max_restarts: int = 5) -> list[int]:
    """Run the graded copy; the indices of the cells left out (they killed or wedged it)."""
    skip: set[int] = set()
    for _ in range(max_restarts + 1):
        bad = _run(nb, workdir, timeout, skip)
        if bad is None:
            return sorted(skip)
        skip.add(bad)
        saved = nb.cells[bad].outputs
        for c in nb.cells:   # the next run starts from a fresh kernel
            if c.cell_type == "code":
                c.outputs = []
        nb.cells[bad].outputs = saved
    for i, c in enumerate(nb.cells):   # too many restarts: what is left did not run
        if c.cell_type == "code" and not c.outputs and i not in skip:
            skip.add(i)
    return sorted(skip)


def _text(outputs: list) -> str:
    parts = []
    for o in outputs:
        if o.get("output_type") == "stream":
            parts.append(o.get("text", ""))
        elif o.get("output_type") == "error":
            parts.append(f"{o.get('ename')}: {o.get('evalue')}\n")
    return "".join(parts)


def grade_notebook(path: Path, todo: list[Exercise], timeout: int) -> dict[str, Result]:
    """Grade one submitted notebook (a copy of it) against its chapter's exercises."""
    results = {ex.key: Result() for ex in todo}
    try:
        nb = nbformat.read(path, as_version=4)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is a message, not a crash
        for r in results.values():
            r.feedback.append(f"{path.name} could not be read as a notebook "
                              f"({type(exc).__name__}); no points.")
        return results
    token = "GRADE-" + secrets.token_hex(16)
    graded = graded_copy(nb, todo, token)
    with tempfile.TemporaryDirectory(prefix="grade-") as tmp:
        work = Path(tmp)
        nbformat.write(nb, work / path.name)   # the copy the student's code may see
        left_out = run_graded(graded, work, timeout)
    problems: list[str] = []
    for i in left_out:
        cell = graded.cells[i]
        first = (cell.source.strip().splitlines() or [""])[0][:70]
        why = _text(cell.outputs).strip().splitlines()
        problems.append(f"cell {i} ({first!r}) was left out, the kernel restarted without it: "
                        f"{why[-1] if why else 'no reply'}; then:")
    verdict = re.compile(rf"^{re.escape(token)} (\S+) (PASS|FAIL)$", re.M)
    for cell in graded.cells:
        key = cell.metadata.get("grader")
        if key is None:
            continue
        text = _text(cell.outputs)
        seen = {m.group(1): m.group(2) for m in verdict.finditer(text)}
        said = [line for line in verdict.sub("", text).splitlines() if line.strip()]
        r = results[key]
        ex = next(e for e in todo if e.key == key)
        if seen.get(key) == "PASS":
            r.points = ex.points
        r.feedback += said or (["the checker did not run (see above)"] if not seen else [])
    for r in results.values():
        if r.points == 0 and problems:
            r.feedback = [*problems, *r.feedback]
    return results


def _digest(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != FEEDBACK}


def feedback_text(student: str, found: list[Exercise], results: dict[str, Result],
                  submitted: set[str]) -> str:
    total = sum(r.points for r in results.values())
    lines = [f"# Feedback for {student}", "",
             f"Total: {total:g} of {sum(e.points for e in found):g} points.", ""]
    chapters = list(dict.fromkeys(e.notebook for e in found))
    absent = [n for n in chapters if n not in submitted]
    if absent:
        lines += [f"Not submitted (no points): {', '.join(absent)}.", ""]
    for nb_name in [n for n in chapters if n in submitted]:
        todo = [e for e in found if e.notebook == nb_name]
        got = sum(results[e.key].points for e in todo)
        lines += [f"## {nb_name}: {got:g} of {sum(e.points for e in todo):g}", ""]
        for e in todo:
            r = results[e.key]
            lines.append(f"- `{e.key}` ({e.call.split('(')[0]}): {r.points:g} of {e.points:g}")
            lines += [f"    {line}" for line in r.feedback]
        lines.append("")
    return "\n".join(lines)


def grade(submissions: Path, reference: Path = ROOT / "notebooks", timeout: int = 120,
          log=print) -> list[dict]:
    """Grade every student folder of ``submissions``; write grades.csv and the feedback."""
    if not submissions.is_dir():
        raise ValueError(f"SUBMISSIONS: expected a folder of student folders, got {submissions}")
    found = exercises(reference)
    students = sorted(p for p in submissions.iterdir()
                      if p.is_dir() and not p.name.startswith((".", "_")))
    rows = []
    for folder in students:
        before = _digest(folder)
        results = {e.key: Result() for e in found}
        submitted = {p.name for p in folder.glob("*.ipynb")} & {e.notebook for e in found}
        for nb_name in sorted(submitted):
            todo = [e for e in found if e.notebook == nb_name]
            log(f"{folder.name}/{nb_name}: {len(todo)} exercise(s)")
            results.update(grade_notebook(folder / nb_name, todo, timeout))
        if _digest(folder) != before:
            log(f"{folder.name}: a submitted file changed while it was graded (the submission's "
                "own code wrote it)")
        fb = folder / FEEDBACK
        if fb.exists() and not fb.read_text(encoding="utf-8", errors="replace").startswith(
                "# Feedback for "):
            fb = folder / f"grader-{FEEDBACK}"   # the student's own file of that name stays
        fb.write_text(feedback_text(folder.name, found, results, submitted), encoding="utf-8")
        row = {"student": folder.name, **{e.key: f"{results[e.key].points:g}" for e in found}}
        row["total"] = f"{sum(r.points for r in results.values()):g}"
        rows.append(row)
        log(f"{folder.name}: {row['total']} point(s)")
    out = submissions / GRADES
    tmp = out.with_suffix(".csv.tmp")
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=["student", *[e.key for e in found], "total"])
        w.writeheader()
        w.writerows(rows)
    tmp.replace(out)
    log(f"grades: {out}")
    return rows


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("submissions", type=Path)
    ap.add_argument("--timeout", type=int, default=120, help="seconds per cell (120)")
    ap.add_argument("--reference", type=Path, default=ROOT / "notebooks",
                    help="the full notebooks (their solution cells define the exercises)")
    args = ap.parse_args(argv)
    try:
        grade(args.submissions, args.reference, args.timeout)
    except ValueError as exc:
        print(f"make grade: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
