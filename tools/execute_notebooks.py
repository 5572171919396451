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
failed ones are listed in ``.notebooks-failed`` (one path a line) so that
``--failed`` (``make notebooks-failed``) reruns only them. A path that is
missing, empty, not UTF-8 or not valid JSON fails the same way, with one line
naming it, and the others still run. The exit status is 1 if any failed.

A notebook is written to a temporary file beside it, which then replaces it
(same permissions): a full disk or a crash leaves the old notebook whole.

``--check`` executes without writing anything (not ``.notebooks-failed``
either) and fails (exit 1) if a notebook's file would change: CI's proof that
the committed notebooks are what ``make notebooks`` writes. Outputs of cells
tagged ``nbval-ignore-output`` (a timing, a widget's live view) are not
compared; everything else is, byte for byte.
"""

from __future__ import annotations

import json
import os
import re
import stat
import sys
import tempfile
from pathlib import Path

import nbformat
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError, CellTimeoutError

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


_ANSI = re.compile(r"\x1b\[[0-?]*[ -/]*[@-~]")


def plain(text: str) -> str:
    """``text`` without terminal colour codes (IPython's tracebacks carry them)."""
    return _ANSI.sub("", text)


def read_text(path: Path) -> str:
    """The notebook file's text, or NotebookFailed naming the file and what is wrong."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise NotebookFailed(f"{path}: no such file") from None
    except OSError as exc:
        raise NotebookFailed(f"{path}: cannot read it ({exc.strerror})") from None
    if not raw.strip():
        raise NotebookFailed(f"{path}: empty file, not a notebook")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise NotebookFailed(f"{path}: line {line}: not UTF-8 (byte "
                             f"0x{raw[exc.start]:02x})") from None


def read_notebook(path: Path) -> nbformat.NotebookNode:
    """The notebook at ``path``, or NotebookFailed with one line naming it and the reason."""
    text = read_text(path)
    try:
        json.loads(text)
    except json.JSONDecodeError as exc:
        raise NotebookFailed(f"{path}: line {exc.lineno}: not valid JSON ({exc.msg})") from None
    except (ValueError, RecursionError) as exc:
        raise NotebookFailed(f"{path}: not valid JSON ({type(exc).__name__})") from None
    try:
        return nbformat.reads(text, as_version=4)
    except Exception as exc:  # valid JSON but not a notebook
        first = (plain(str(exc)).strip().splitlines() or [type(exc).__name__])[0]
        raise NotebookFailed(f"{path}: not a notebook ({first})") from None


def _reason(exc: Exception, timeout: int) -> str:
    """One plain line saying why a notebook stopped."""
    if isinstance(exc, CellTimeoutError):
        return f"timed out after {timeout} s (--timeout {timeout})"
    if isinstance(exc, CellExecutionError):
        return plain(f"{exc.ename}: {exc.evalue}")
    lines = plain(str(exc)).strip().splitlines()
    return f"{type(exc).__name__}: {lines[-1] if lines else ''}".rstrip(": ")


def run(path: Path, timeout: int = 300) -> nbformat.NotebookNode:
    """Execute one notebook (fresh kernel, its folder as working directory); return it normalised.

    Raises
    ------
    NotebookFailed
        Naming the notebook and the cell (index and first line) that raised or timed
        out, or, for a file that is not a readable notebook, what is wrong with it.
    """
    nb = read_notebook(path)
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
        what = _reason(exc, timeout)                  # "timed out after ..." or the error
        what = what if isinstance(exc, CellTimeoutError) else f"failed: {what}"
        raise NotebookFailed(plain(f"{path}: cell {i} ({first!r}) {what}")) from exc
    normalise(nb)
    return nb


def write_atomic(path: Path, text: str) -> None:
    """Replace ``path`` by ``text`` through a temporary file beside it (same permissions):
    the file is either the old one or the new one, never cut."""
    mode = stat.S_IMODE(path.stat().st_mode)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


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
    old = read_text(path)
    new = nbformat.writes(run(path, timeout)) + "\n"
    if check:
        return comparable(new) != comparable(old)
    if new == old:
        return False
    try:
        write_atomic(path, new)
    except OSError as exc:
        raise NotebookFailed(f"{path}: not written ({exc.strerror or exc}); the file is as it "
                             f"was") from None
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
        paths += [Path(line) for line in FAILED_LIST.read_text(encoding="utf-8").splitlines()
                  if line.strip()]
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
    if failed and args.check:
        print(f"{len(failed)} notebook(s) failed")
    elif failed:
        FAILED_LIST.write_text("".join(f"{p}\n" for p in failed), encoding="utf-8")
        print(f"{len(failed)} notebook(s) failed; rerun only them: make notebooks-failed")
    elif FAILED_LIST.exists() and not args.check:
        FAILED_LIST.unlink()
    if args.check and changed:
        print(f"{len(changed)} committed notebook(s) differ from what make notebooks writes: "
              + " ".join(str(p) for p in changed))
    return 1 if failed or (args.check and changed) else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
