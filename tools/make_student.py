"""Write the student edition of the notebooks: every solution emptied.

Usage: python tools/make_student.py notebooks student

A cell tagged ``solution`` keeps its place but loses its source and outputs
(a comment tells the student what to do). A cell tagged ``answer`` (the answer
to a "More to try" item, usually markdown) is emptied the same way. Every
other cell is copied as it is, so the student notebook still runs from the
top: each exercise's checker then reports that the student's function is not
written yet, instead of raising. The stored outputs of every cell that uses
a name a solution defines (the exercise's own cell, which calls the checker,
and any later cell that runs the student's code, such as chapter 05's own
filter) are cleared too: they were made with the solution and would claim
that code the student has not written yet passes.

In the notebooks an exercise is one cell (the student's stub and the call of
its checker) followed by the solution cell, so the placeholder points up.

Nothing is lost: every notebook is read before anything is written; a
destination that is, contains or lies inside the source, or holds the
project or the current folder, is refused; an existing destination is
replaced only if it holds nothing but what this tool writes; and the edition
is built in a temporary folder beside the destination that takes its place
only when complete. Any refusal is one line on stderr and exit status 1.
"""

from __future__ import annotations

import ast
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

import nbformat

PLACEHOLDER = ("# Solution removed in the student edition.\n"
               "# Your answer goes in the exercise cell above, which calls the checker:\n"
               "# write it there and run that cell again; the checker tells you if it is right.")
ANSWER_PLACEHOLDER = "*(answer removed in the student edition: try it yourself)*"
#: Written into every edition: an existing destination holding it may be replaced.
MARKER = ".student-edition"
PROJECT_ROOT = Path(__file__).resolve().parents[1]


class Refused(Exception):
    """The tool will not run: nothing was written or removed."""


_TOP_LEVEL = re.compile(r"^(?:def|class)\s+(\w+)|^(\w+)\s*(?::[^=\n]*)?=(?!=)", re.M)


def _tags(cell) -> list:
    return cell.metadata.get("tags", [])


def defined_names(source: str) -> set[str]:
    """The names a cell defines at top level (functions, classes, assigned variables),
    except ``_``-prefixed ones."""
    src = "\n".join(ln for ln in source.splitlines() if not ln.lstrip().startswith(("%", "!")))
    names: set[str] = set()
    try:
        body = ast.parse(src).body
    except SyntaxError:                          # not plain Python: top-level names by pattern
        names.update(a or b for a, b in _TOP_LEVEL.findall(src))
        body = []
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                names.update(n.id for n in ast.walk(t) if isinstance(n, ast.Name))
    return {n for n in names if not n.startswith("_")}


def student_names(nb: nbformat.NotebookNode) -> dict[str, int]:
    """The student's names and the index of the exercise cell where each is first written.

    An exercise is the cell above a ``solution`` cell; the student's names are those both
    define (the stub's function or variable), or all the solution's if they share none.
    """
    found: dict[str, int] = {}
    for i, cell in enumerate(nb.cells):
        if cell.cell_type != "code" or "solution" not in _tags(cell):
            continue
        mine = defined_names(cell.source)
        above = nb.cells[i - 1] if i > 0 else None
        stub = (defined_names(above.source) if above is not None and above.cell_type == "code"
                else set())
        for name in (mine & stub) or mine:
            found.setdefault(name, i - 1 if stub else i)
    return found


def strip_solutions(nb: nbformat.NotebookNode) -> int:
    """Empty the cells tagged ``solution`` or ``answer``; return how many there were.

    The outputs of every other code cell that uses one of the student's names, from its
    exercise cell on, are cleared as well (see the module docstring).
    """
    names = student_names(nb)
    n = 0
    for i, cell in enumerate(nb.cells):
        tags = _tags(cell)
        if "solution" in tags:
            cell.source = PLACEHOLDER if cell.cell_type == "code" else "*(solution removed)*"
        elif "answer" in tags:
            cell.source = (ANSWER_PLACEHOLDER if cell.cell_type == "markdown"
                           else "# " + ANSWER_PLACEHOLDER)
        else:
            if cell.cell_type == "code" and any(
                    i >= first and re.search(rf"\b{re.escape(name)}\b", cell.source)
                    for name, first in names.items()):
                cell.outputs = []
                cell.execution_count = None
            continue
        n += 1
        if cell.cell_type == "code":
            cell.outputs = []
            cell.execution_count = None
    return n


# --------------------------------------------------------------------------- checks first
def _inside(path: Path, folder: Path) -> bool:
    """True if ``path`` is ``folder`` or lies inside it (both resolved)."""
    return path == folder or folder in path.parents


def check_paths(src: Path, dst: Path) -> tuple[Path, Path]:
    """Refuse a source that is not a folder of notebooks and any destination whose
    replacement could remove something else; return both resolved."""
    if not src.is_dir():
        raise Refused(f"source {src}: no such folder")
    s, d = src.resolve(), dst.resolve()
    here = Path.cwd().resolve()
    if d == s:
        raise Refused(f"refusing to write into {dst}: it is the source folder {src}")
    if _inside(d, s):
        raise Refused(f"refusing to write into {dst}: it is inside the source folder {src}")
    if _inside(s, d):
        raise Refused(f"refusing to write into {dst}: it contains the source folder {src}")
    if _inside(here, d):
        raise Refused(f"refusing to write into {dst}: it is or contains the current folder")
    if _inside(PROJECT_ROOT, d):
        raise Refused(f"refusing to write into {dst}: it is or contains the project "
                      f"{PROJECT_ROOT}")
    if d.exists() and not d.is_dir():
        raise Refused(f"refusing to write into {dst}: it exists and is not a folder")
    return s, d


def read_course(src: Path) -> tuple[list[tuple[str, nbformat.NotebookNode, int]], list[Path]]:
    """Every notebook of ``src`` read and stripped (in memory) and the sub-folders to copy."""
    paths = sorted(src.glob("*.ipynb"))
    if not paths:
        raise Refused(f"source {src}: no notebooks (*.ipynb) in it")
    books = []
    for p in paths:
        try:
            nb = nbformat.read(p, as_version=4)
        except Exception as exc:  # OSError, UnicodeDecodeError, invalid JSON, not a notebook
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise Refused(f"{p}: not a readable notebook ({first}); nothing written") from None
        books.append((p.name, nb, strip_solutions(nb)))
    extras = [e for e in sorted(src.iterdir()) if e.is_dir() and not e.name.startswith(".")]
    return books, extras


def check_replaceable(d: Path, dst: Path, expected: set[str]) -> None:
    """An existing destination may be replaced only if it is empty, is an edition this tool
    wrote, or holds nothing but the names it writes."""
    if not d.exists() or (d / MARKER).is_file():
        return
    foreign = sorted(e.name for e in d.iterdir() if e.name not in expected)
    if foreign:
        shown = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
        raise Refused(f"refusing to replace {dst}: it holds files this tool did not write "
                      f"({shown}); remove them or choose another folder")


# --------------------------------------------------------------------------- then write
def write_edition(d: Path, books, extras: list[Path]) -> None:
    """Build the edition in a temporary folder beside ``d``, then put it in ``d``'s place."""
    d.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{d.name}.tmp-", dir=d.parent))
    old = None
    try:
        mask = os.umask(0)
        os.umask(mask)
        tmp.chmod(0o777 & ~mask)               # mkdtemp's 0700 would hide the edition
        for name, nb, _ in books:
            nbformat.write(nb, tmp / name)
        for extra in extras:
            shutil.copytree(extra, tmp / extra.name, symlinks=True)
        (tmp / MARKER).write_text("The student edition, written by tools/make_student.py; "
                                  "the next run replaces this folder.\n", encoding="utf-8")
        if d.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{d.name}.old-", dir=d.parent))
            old.rmdir()
            os.rename(d, old)
        try:
            os.rename(tmp, d)
        except OSError:
            if old is not None:
                os.rename(old, d)
                old = None
            raise
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if old is not None:
        shutil.rmtree(old)


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__)
        return 2
    src, dst = Path(argv[0]), Path(argv[1])
    try:
        _, d = check_paths(src, dst)
        books, extras = read_course(src)
        check_replaceable(d, dst, {name for name, _, _ in books}
                          | {e.name for e in extras} | {MARKER})
        write_edition(d, books, extras)
    except Refused as exc:
        print(f"make_student.py: {exc}", file=sys.stderr)
        return 1
    for name, _, n in books:
        print(f"{dst / name}: {n} solution cell(s) emptied")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
