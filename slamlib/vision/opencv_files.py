"""OpenCV's own data files (YAML, XML or JSON ``cv2.FileStorage``), read so that a bad one
names itself (chapter 02's calibration and dictionary files).

``cv2.FileStorage`` given an empty, truncated or BOM-prefixed file raises a bare
``SystemError``; :func:`open_storage` checks the bytes first (through
:func:`slamlib.validate.read_text_file`), parses the text it checked, and turns OpenCV's
parse error into the caller's error with the file and the line.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import cv2

from ..validate import read_text_file

__all__ = ["open_storage"]

#: OpenCV's parse errors say "...in function '<source>(<line>): <reason>'".
_PARSE_ERROR = re.compile(r"\((\d+)\):\s*([^'\n]*)")


def open_storage(path, error: Callable[[str], Exception] = ValueError) -> cv2.FileStorage:
    """An open ``cv2.FileStorage`` (read) on the file at ``path``; the caller releases it.

    Raises
    ------
    error
        Naming the file and, where OpenCV says it, the line: a missing or empty file, a
        byte-order mark, bytes that are not UTF-8, or text OpenCV cannot parse.
    """
    p = Path(path)
    text = read_text_file(p, error)
    if not text.strip():
        raise error(f"{p}: line 1: empty file, expected OpenCV's storage format "
                    f"(%YAML:1.0, XML or JSON)")
    try:
        fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    except (cv2.error, SystemError) as exc:
        cause = exc.__cause__ or exc.__context__ or exc
        m = _PARSE_ERROR.search(str(cause))
        where = f"line {m.group(1)}: {m.group(2).strip() or 'parse error'}" if m else \
            "not a file OpenCV can parse"
        raise error(f"{p}: {where} (OpenCV)") from None
    if not fs.isOpened():
        raise error(f"{p}: not a file OpenCV can open")
    return fs
