"""Write the student edition of the notebooks: every solution emptied.

Usage: python tools/make_student.py notebooks student

A cell tagged ``solution`` keeps its place but loses its source and outputs
(a comment tells the student what to do). A cell tagged ``answer`` (the answer
to a "More to try" item, usually markdown) is emptied the same way. Every
other cell is copied as it is, so the student notebook still runs from the
top: each exercise's checker then reports that the student's function is not
written yet, instead of raising.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import nbformat

PLACEHOLDER = ("# Solution removed in the student edition.\n"
               "# Write your answer in the cell above; the checker below tells you if it is right.")
ANSWER_PLACEHOLDER = "*(answer removed in the student edition: try it yourself)*"


def strip_solutions(nb: nbformat.NotebookNode) -> int:
    """Empty the cells tagged ``solution`` or ``answer``; return how many there were."""
    n = 0
    for cell in nb.cells:
        tags = cell.metadata.get("tags", [])
        if "solution" in tags:
            cell.source = PLACEHOLDER if cell.cell_type == "code" else "*(solution removed)*"
        elif "answer" in tags:
            cell.source = (ANSWER_PLACEHOLDER if cell.cell_type == "markdown"
                           else "# " + ANSWER_PLACEHOLDER)
        else:
            continue
        n += 1
        if cell.cell_type == "code":
            cell.outputs = []
            cell.execution_count = None
    return n


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__)
        return 2
    src, dst = Path(argv[0]), Path(argv[1])
    if dst.exists():
        shutil.rmtree(dst)
    dst.mkdir(parents=True)
    for p in sorted(src.glob("*.ipynb")):
        nb = nbformat.read(p, as_version=4)
        n = strip_solutions(nb)
        nbformat.write(nb, dst / p.name)
        print(f"{dst / p.name}: {n} solution cell(s) emptied")
    for extra in src.iterdir():
        if extra.is_dir() and not extra.name.startswith("."):
            shutil.copytree(extra, dst / extra.name)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
