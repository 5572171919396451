"""Reading the stored studies of ``data/studies`` and ``data/evidence``, one way for all."""

from __future__ import annotations

import json
from pathlib import Path

from ..validate import read_json_file

__all__ = ["load_stored", "write_or_check", "save_rows"]


def load_stored(path, make_target: str):
    """The parsed JSON of a stored study; a missing or malformed file raises a ValueError that
    names the file and the ``make`` target that writes it."""
    if not Path(path).is_file():
        raise ValueError(f"no stored study {path} (`make {make_target}` writes it)")
    try:
        return read_json_file(path)[0]
    except ValueError as exc:
        raise ValueError(f"{exc} (`make {make_target}` writes it)") from None


def write_or_check(path, build, argv: list[str], what: str = "stored study") -> int:
    """The command line of a ``tools/make_*.py`` script that writes one stored file.

    ``build(workers)`` returns the file's text (``--workers N`` in ``argv``, default
    2). With ``--check`` in ``argv`` nothing is written: returns 1 if the file would
    change (0 if it is up to date); otherwise writes it and returns 0.
    """
    path = Path(path)
    workers = int(argv[argv.index("--workers") + 1]) if "--workers" in argv else 2
    text = build(workers)
    if "--check" in argv:
        same = path.is_file() and path.read_text(encoding="utf-8") == text
        print(f"{what}: up to date" if same else f"would change: {path}")
        return 0 if same else 1
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return 0


def save_rows(data: dict, rows_key: str, path) -> None:
    """Write a study as JSON that diffs well: each entry of ``data`` on its own line, the
    rows ``data[rows_key]`` (a list, or a dict) last, one row per line, compact."""
    def compact(v) -> str:
        return json.dumps(v, separators=(",", ":"))

    rows = data[rows_key]
    if isinstance(rows, dict):
        brackets, items = "{}", [f"{json.dumps(k)}: {compact(v)}" for k, v in rows.items()]
    else:
        brackets, items = "[]", [compact(v) for v in rows]
    lines = (["{"] + [f"{json.dumps(k)}: {compact(v)}," for k, v in data.items() if k != rows_key]
             + [f"{json.dumps(rows_key)}: {brackets[0]}", ",\n".join(items), brackets[1], "}"])
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(line for line in lines if line) + "\n", encoding="utf-8")
