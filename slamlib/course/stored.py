"""Reading the stored studies of ``data/studies`` and ``data/evidence``, one way for all."""

from __future__ import annotations

from pathlib import Path

from ..validate import read_json_file

__all__ = ["load_stored"]


def load_stored(path, make_target: str):
    """The parsed JSON of a stored study; a missing or malformed file raises a ValueError that
    names the file and the ``make`` target that writes it."""
    if not Path(path).is_file():
        raise ValueError(f"no stored study {path} (`make {make_target}` writes it)")
    try:
        return read_json_file(path)[0]
    except ValueError as exc:
        raise ValueError(f"{exc} (`make {make_target}` writes it)") from None
