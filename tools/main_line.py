"""Measure each chapter's main line: the prose a student reads without opening a fold.

    python tools/main_line.py [notebooks/*.ipynb]

The main line is every markdown cell that is not tagged ``evidence``, without the inside of
its ``<details>...</details>`` blocks (their ``<summary>`` line stays: it is read folded).
Only a bare ``<details>`` tag is a fold: the end-of-session count reads one with attributes
(``<details class="...">``) as prose, so the chapters write it bare (the web edition adds its
class). A cell tagged ``answer`` counts unless its text is inside ``<details>``: the tag folds it in
JupyterLab and in the web edition, but not in every viewer a student may open the notebook
in. Of its prose we count the words (a run of characters between spaces that holds a letter
or a digit) and the numbers (a word with a digit in it). Headings, link texts and inline
code are read, so they count; math (``$...$``, ``$$...$$``), fenced code, markdown tables,
HTML tags and link targets are not prose.
The quality bar (COURSE.md, "Teach first"): at most 3,000 words and at most 5 numbers
per 100 words.
"""

from __future__ import annotations

import json
import re
import sys
from dataclasses import dataclass
from pathlib import Path

MAX_WORDS = 3000
MAX_NUMBERS_PER_100 = 5.0
FOLDED_TAGS = {"evidence"}

_DETAILS = re.compile(r"<details>.*?</details>", re.S | re.I)   # a bare tag (see the docstring)
_SUMMARY = re.compile(r"<summary\b[^>]*>(.*?)</summary>", re.S | re.I)
_STRIP = [
    re.compile(r"```.*?```", re.S),                         # fenced code
    re.compile(r"\$\$.*?\$\$", re.S),                       # display math
    re.compile(r"\\begin\{(\w+\*?)\}.*?\\end\{\1\}", re.S),  # LaTeX environments
    re.compile(r"(?<!\\)\$(?:[^$\n]|\n(?![ \t]*\n))+?(?<!\\)\$"),  # inline math (one paragraph)
    re.compile(r"`"),                                       # inline code's backticks
    re.compile(r"^\s*\|.*$", re.M),                         # markdown table rows
    re.compile(r"<[^>\n]+>"),                               # HTML tags
    re.compile(r"\]\([^)\s]*\)"),                           # link targets
]
_WORD = re.compile(r"\S+")
_ALNUM = re.compile(r"[^\W_]")
_DIGIT = re.compile(r"\d")


@dataclass(frozen=True)
class MainLine:
    """The main line's size: ``words`` of prose, of which ``numbers`` carry a digit."""

    path: str
    words: int
    numbers: int

    @property
    def numbers_per_100(self) -> float:
        return 100.0 * self.numbers / max(self.words, 1)

    @property
    def ok(self) -> bool:
        return self.words <= MAX_WORDS and self.numbers_per_100 <= MAX_NUMBERS_PER_100


def prose(markdown: str) -> str:
    """The prose of one markdown cell: folds (but their summaries), math, fenced code, tables,
    tags and link targets removed."""
    markdown = _DETAILS.sub(lambda m: " " + " ".join(_SUMMARY.findall(m.group(0))) + " ", markdown)
    for pattern in _STRIP:
        markdown = pattern.sub(" ", markdown)
    return markdown


def main_line_text(notebook: dict) -> str:
    """The main line's prose of a notebook (nbformat 4 as a dict), cells joined by blank lines."""
    cells = []
    for cell in notebook.get("cells", []):
        tags = set(cell.get("metadata", {}).get("tags", []))
        if cell.get("cell_type") != "markdown" or tags & FOLDED_TAGS:
            continue
        source = cell.get("source", "")
        cells.append(prose("".join(source) if isinstance(source, list) else source))
    return "\n\n".join(cells)


def measure(path: str | Path) -> MainLine:
    """Words and numbers of a notebook's main line."""
    text = main_line_text(json.loads(Path(path).read_text(encoding="utf-8")))
    words = [w for w in _WORD.findall(text) if _ALNUM.search(w)]
    return MainLine(str(path), len(words), sum(bool(_DIGIT.search(w)) for w in words))


def main(argv: list[str]) -> int:
    paths = argv or sorted(str(p) for p in Path("notebooks").glob("*.ipynb"))
    print(f"{'notebook':44s} {'words':>6s} {'num/100':>8s}")
    bad = 0
    for p in paths:
        m = measure(p)
        flag = "" if m.ok else "  over the bar"
        bad += not m.ok
        print(f"{Path(p).name:44s} {m.words:6d} {m.numbers_per_100:8.1f}{flag}")
    print(f"bar: at most {MAX_WORDS} words and {MAX_NUMBERS_PER_100:g} numbers per 100 words")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
