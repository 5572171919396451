"""Re-execute notebooks in place, reproducibly.

Usage: python tools/execute_notebooks.py [--check] [--timeout S] notebooks/01_x.ipynb [...]
       python tools/execute_notebooks.py --failed        (again only those that failed last time)

Each notebook runs top to bottom in a fresh kernel of this environment (so it
imports the installed ``slamlib``), from the notebook's own folder. Timing
metadata is not recorded, widget state and widget views are dropped (a widget
cell keeps its plain-text output) and the notebook metadata is normalised, so
that re-running an unchanged notebook rewrites no byte. A notebook is written
only if its content changed.

A cell that runs longer than ``--timeout`` seconds (300) fails its notebook
with an error naming the notebook and the cell, and the next notebook runs; the
failed ones are listed in ``.notebooks-failed`` so that ``--failed`` (``make
notebooks-failed``) reruns only them. The exit status is 1 if any failed.

``--check`` executes without writing and fails (exit 1) if a notebook's file
would change: CI's proof that the committed notebooks are what ``make
notebooks`` writes. Outputs of cells tagged ``nbval-ignore-output`` (a timing,
a widget's live view) are not compared; everything else is, byte for byte.
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


FAILED_LIST = Path(".notebooks-failed")


class NotebookFailed(Exception):
    """A notebook did not run to the end: which cell, and why."""


def run(path: Path, timeout: int = 300) -> nbformat.NotebookNode:
    """Execute one notebook (fresh kernel, its folder as working directory); return it normalised.

    Raises
    ------
    NotebookFailed
        Naming the notebook and the cell (index and first line) that raised or timed out.
    """
    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3", record_timing=False,
                            resources={"metadata": {"path": str(path.parent)}})
    current = {"index": None}

    def on_cell_start(cell, cell_index, **kwargs):
        current["index"] = cell_index

    client.on_cell_start = on_cell_start
    try:
        client.execute()
    except Exception as exc:  # CellExecutionError, CellTimeoutError, DeadKernelError, ...
        i = current["index"]
        first = nb.cells[i].source.splitlines()[0] if i is not None and nb.cells[i].source else ""
        kind = type(exc).__name__
        reason = str(exc).strip().splitlines()
        raise NotebookFailed(f"{path}: cell {i} ({first!r}) failed: {kind}: "
                             f"{reason[-1] if reason else ''}") from exc
    normalise(nb)
    return nb


def comparable(text: str) -> str:
    """The notebook's text with the outputs of ``nbval-ignore-output`` cells left out."""
    nb = nbformat.reads(text, as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code" and "nbval-ignore-output" in cell.metadata.get("tags", []):
            cell.outputs = []
    return nbformat.writes(nb)


def execute(path: Path, timeout: int = 300, check: bool = False) -> bool:
    """Execute one notebook; return True if its file changed (or, with ``check``, would change).

    With ``check`` nothing is written and the outputs of cells tagged
    ``nbval-ignore-output`` are not compared.
    """
    new = nbformat.writes(run(path, timeout)) + "\n"
    old = path.read_text(encoding="utf-8")
    if check:
        return comparable(new) != comparable(old)
    if new == old:
        return False
    path.write_text(new, encoding="utf-8")
    return True


def main(argv: list[str]) -> int:
    import argparse

    os.environ.pop("MPLBACKEND", None)
    ap = argparse.ArgumentParser(description="Re-execute notebooks in place, reproducibly.")
    ap.add_argument("notebooks", nargs="*", type=Path)
    ap.add_argument("--check", action="store_true",
                    help="write nothing; exit 1 if a notebook would change")
    ap.add_argument("--timeout", type=int, default=300, help="seconds per cell (300)")
    ap.add_argument("--failed", action="store_true",
                    help=f"run the notebooks listed in {FAILED_LIST} by the last run")
    args = ap.parse_args(argv)
    paths = list(args.notebooks)
    if args.failed:
        if not FAILED_LIST.exists():
            print(f"{FAILED_LIST}: no failed notebooks recorded")
            return 0
        paths += [Path(line) for line in FAILED_LIST.read_text().split() if line]
    if not paths:
        ap.print_help()
        return 2
    failed, changed = [], []
    for p in paths:
        try:
            differs = execute(p, args.timeout, args.check)
        except NotebookFailed as exc:
            print(f"FAILED {exc}", flush=True)
            failed.append(p)
            continue
        if differs:
            changed.append(p)
        word = ("would change" if differs else "reproduced") if args.check else (
            "rewritten" if differs else "unchanged")
        print(f"{p}: {word}", flush=True)
    if failed:
        FAILED_LIST.write_text("".join(f"{p}\n" for p in failed))
        print(f"{len(failed)} notebook(s) failed; rerun only them: make notebooks-failed")
    elif FAILED_LIST.exists() and not args.check:
        FAILED_LIST.unlink()
    if args.check and changed:
        print(f"{len(changed)} committed notebook(s) differ from what make notebooks writes: "
              + " ".join(str(p) for p in changed))
    return 1 if failed or (args.check and changed) else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
