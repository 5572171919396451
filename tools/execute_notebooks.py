"""Re-execute notebooks in place, reproducibly.

Usage: python tools/execute_notebooks.py notebooks/01_dead_reckoning.ipynb [...]

Each notebook runs top to bottom in a fresh kernel of this environment (so it
imports the installed ``slamlib``), from the notebook's own folder. Timing
metadata is not recorded, widget state and widget views are dropped (a widget
cell keeps its plain-text output) and the notebook metadata is normalised, so
that re-running an unchanged notebook rewrites no byte. A notebook is written
only if its content changed.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import nbformat
from nbclient import NotebookClient

WIDGET_MIME = "application/vnd.jupyter.widget-view+json"
KERNELSPEC = {"display_name": "Python 3 (ipykernel)", "language": "python", "name": "python3"}


def merge_streams(outputs: list) -> list:
    """Join consecutive stream outputs of the same stream: the kernel may split one print
    into several messages depending on timing, which must not change the file."""
    merged: list = []
    for out in outputs:
        prev = merged[-1] if merged else None
        if (out.get("output_type") == "stream" and prev is not None
                and prev.get("output_type") == "stream" and prev.get("name") == out.get("name")):
            prev["text"] = prev["text"] + out["text"]
        else:
            merged.append(out)
    return merged


def normalise(nb: nbformat.NotebookNode) -> None:
    """Drop what changes from run to run or cannot be shown without a live kernel."""
    nb.metadata.pop("widgets", None)
    nb.metadata["kernelspec"] = dict(KERNELSPEC)
    nb.metadata["language_info"] = {"name": "python", "pygments_lexer": "ipython3"}
    for cell in nb.cells:
        cell.metadata.pop("execution", None)
        if cell.cell_type != "code":
            continue
        cell.outputs = merge_streams(cell.get("outputs", []))
        for out in cell.get("outputs", []):
            data = out.get("data")
            if data and WIDGET_MIME in data:
                del data[WIDGET_MIME]
            out.get("metadata", {}).pop(WIDGET_MIME, None)


def execute(path: Path, timeout: int = 900) -> bool:
    """Execute one notebook in place; return True if its file changed."""
    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3", record_timing=False,
                            resources={"metadata": {"path": str(path.parent)}})
    client.execute()
    normalise(nb)
    new = nbformat.writes(nb) + "\n"
    old = path.read_text(encoding="utf-8")
    if new == old:
        return False
    path.write_text(new, encoding="utf-8")
    return True


def main(argv: list[str]) -> int:
    os.environ.pop("MPLBACKEND", None)
    if not argv:
        print(__doc__)
        return 2
    for name in argv:
        p = Path(name)
        changed = execute(p)
        print(f"{p}: {'rewritten' if changed else 'unchanged'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
