"""The printed edition (``make pdf``): the whole course as one PDF, read back as text and images.

Built once with Sphinx's LaTeX builder and XeLaTeX (``tools/build_book.py --pdf``), then
read with poppler's ``pdftotext`` and ``pdfimages``: every chapter is there with its
title, its equations typeset (no TeX source left), its printed tables and its figures;
the solutions are not in the chapters but in the appendix "Solutions"; no line of the
PDF runs more than a few points past the text's edge (LaTeX's overfull boxes).

Debian's ``latexmk``, ``texlive-xetex``, ``texlive-latex-extra``, ``fonts-freefont-otf``
and ``poppler-utils``; ``.ci/run`` installs them. Outside CI the test is skipped
without them.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

ROOT = Path(__file__).resolve().parent.parent
TOOLS = ("latexmk", "xelatex", "pdftotext", "pdfimages")

if not all(shutil.which(t) for t in TOOLS):
    if os.environ.get("CI"):
        raise RuntimeError("CI needs latexmk, XeLaTeX and poppler-utils (.ci/run installs them)")
    pytest.skip("latexmk / XeLaTeX / poppler-utils not installed", allow_module_level=True)


@pytest.fixture(scope="module")
def pdf(tmp_path_factory):
    out = tmp_path_factory.mktemp("pdf")
    run = subprocess.run([sys.executable, str(ROOT / "tools" / "build_book.py"), "--pdf",
                          "--out", str(out)], capture_output=True, text=True, timeout=1800)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    path = out / "pdf" / "ekf-slam-aruco.pdf"
    text = subprocess.run(["pdftotext", "-layout", str(path), "-"], capture_output=True,
                          text=True, check=True).stdout
    images = subprocess.run(["pdfimages", "-list", str(path)], capture_output=True, text=True,
                            check=True).stdout.splitlines()[2:]
    log = (out / "latex" / "ekf-slam-aruco.log").read_text(encoding="utf-8", errors="replace")
    return path, text, images, log


def _notebooks():
    paths = sorted((ROOT / "notebooks").glob("*.ipynb"))
    return [(p, nbformat.read(p, as_version=4)) for p in paths]


def _title(nb) -> str:
    for c in nb.cells:
        m = re.search(r"^# (.+)$", c.source, flags=re.M) if c.cell_type == "markdown" else None
        if m:
            return m.group(1).strip()
    raise AssertionError("a chapter without a title")


def _flat(s: str) -> str:
    return " ".join(s.replace("’", "'").split())


def test_every_chapter_is_in_the_pdf_with_its_title(pdf):
    _, text, _, _ = pdf
    flat = _flat(text)
    pages = text.count("\f")
    assert pages > 100, f"{pages} pages"
    missing = [p.name for p, nb in _notebooks()
               if _flat(re.sub(r"[*`$]", "", _title(nb)))[:40] not in flat]
    assert not missing, f"chapters whose title is not in the PDF: {missing}"
    assert "Solutions" in flat and "Errata of the report" in flat


def test_equations_are_typeset_not_left_as_tex(pdf):
    _, text, _, log = pdf
    for tex in ("\\frac", "\\mathbf", "\\begin{", "$$"):
        assert tex not in text, f"TeX source {tex!r} in the PDF's text"
    for symbol in ("θ", "ρ", "Σ", "χ"):
        assert symbol in text, f"no {symbol} in the PDF: equations missing?"
    assert "Missing character" not in log, "a glyph the fonts lack"


def test_figures_are_in_the_pdf(pdf):
    _, _, images, _ = pdf
    figures = sum(1 for _, nb in _notebooks() for c in nb.cells if c.cell_type == "code"
                  for o in c.outputs if "image/png" in o.get("data", {}))
    pictures = [row for row in images if row.split()[2] == "image"]
    assert len(pictures) >= figures > 50, (len(pictures), figures)
    widths = [int(row.split()[3]) for row in pictures]
    assert min(widths) > 100


def test_printed_tables_are_in_the_pdf(pdf):
    _, text, _, _ = pdf
    # chapter 03's table of filters fed by the camera, header and a row
    assert "filter fed by the camera" in text and "every 10th frame" in text


def test_solutions_are_in_the_appendix_not_in_the_chapters(pdf):
    _, text, _, _ = pdf
    appendix = _flat(text).index("The solutions of the exercises and the answers")
    text = _flat(text)
    assert text.index("x, y, yaw = pose") > appendix       # chapter 00's solution
    assert "def my_pose_from_zup(pose):" in text[:appendix]   # the exercise stays in its chapter


def test_nothing_runs_past_the_page(pdf):
    _, _, _, log = pdf
    over = [float(m) for m in re.findall(r"Overfull \\hbox \(([\d.]+)pt too wide\)", log)]
    assert not [w for w in over if w > 20], f"lines too wide for the page by {sorted(over)[-5:]} pt"
