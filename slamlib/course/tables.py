"""Aligned tables of results for the chapters' printed output.

The chapters print many small tables of numbers (a row per gate, per robot,
per run...). :func:`format_table` lays one out from its headers, its rows and
one format per column, so that a cell holds the numbers and not the
alignment::

    print_table(["p", "ATE (m)", "rejected"], rows, [".3g", ".3f", "d"])

Columns are as wide as their widest entry; text columns are aligned left,
number columns right (a format ``">s"`` or ``"<"`` says otherwise); a header
may span several lines (``"median\\nNEES"``); a missing value (None or NaN) is
printed as ``missing``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence

__all__ = ["format_table", "print_table"]


def _is_missing(v) -> bool:
    return v is None or (isinstance(v, numbers.Real) and not isinstance(v, numbers.Integral)
                         and math.isnan(v))


def _cell(v, fmt, missing: str) -> str:
    if _is_missing(v):
        return missing
    if callable(fmt):
        return str(fmt(v))
    return format(v, fmt)


def format_table(headers: Sequence[str], rows: Sequence[Sequence], formats:
                 Sequence[str | Callable | None] | None = None, *, missing: str = "-",
                 sep: str = "  ") -> str:
    """Lay out rows of values under headers, each column aligned (chapters 03-10).

    Parameters
    ----------
    headers : sequence of str, length c
        One per column; ``"\\n"`` splits a header over several lines.
    rows : sequence of sequences, each of length c
        The values (numbers, strings, None).
    formats : sequence of length c, optional
        Per column a format spec for :func:`format` (``".3f"``, ``"+.2f"``,
        ``"d"``, ``".1%"``, ``"s"``...), a callable ``value -> str``, or None
        (``format(value, "")``). Default: None for every column. A spec that
        starts with ``"<"`` or ``">"`` also aligns its column left or right.
    missing : str
        What None and NaN are printed as.
    sep : str
        Between two columns.

    Returns
    -------
    str
        The table, one line per header line and per row, without a final newline.
        A column of text (every value a str) is aligned left, any other right.

    Raises
    ------
    ValueError
        If a row or ``formats`` does not have one entry per header.
    """
    headers = [str(h) for h in headers]
    c = len(headers)
    if c == 0:
        raise ValueError("headers: expected at least one column")
    formats = [None] * c if formats is None else list(formats)
    if len(formats) != c:
        raise ValueError(f"formats: expected {c} entries (one per header), got {len(formats)}")
    rows = [list(r) for r in rows]
    for j, r in enumerate(rows):
        if len(r) != c:
            raise ValueError(f"rows[{j}]: expected {c} values (one per header), got {len(r)}")
    cells = [[_cell(v, f or "", missing) for v, f in zip(r, formats)] for r in rows]
    text = [all(isinstance(r[i], str) for r in rows) and bool(rows) for i in range(c)]
    for i, f in enumerate(formats):                             # "<..." / ">...": forced
        if isinstance(f, str) and f[:1] in "<>":
            text[i] = f[0] == "<"
    head = [h.split("\n") for h in headers]
    depth = max(len(h) for h in head)
    head = [[""] * (depth - len(h)) + h for h in head]          # headers sit on the bottom line
    width = [max([len(s) for s in head[i]] + [len(r[i]) for r in cells]) for i in range(c)]

    def line(values):
        out = [v.ljust(w) if t else v.rjust(w) for v, w, t in zip(values, width, text)]
        return sep.join(out).rstrip()

    lines = [line([head[i][d] for i in range(c)]) for d in range(depth)]
    lines += [line(r) for r in cells]
    return "\n".join(lines)


def print_table(headers: Sequence[str], rows: Sequence[Sequence], formats:
                Sequence[str | Callable | None] | None = None, *, missing: str = "-",
                sep: str = "  ") -> None:
    """Print :func:`format_table` (same arguments)."""
    print(format_table(headers, rows, formats, missing=missing, sep=sep))
