"""Build the course's web edition (``make book``) or its printed edition (``make pdf``).

Usage: python tools/build_book.py [--out book/_build] [--pdf]

Nothing is executed: the pages are the committed notebooks with their outputs.
The sources are laid out in ``<out>/src`` (``<out>/src-pdf`` for the PDF): the
pages of ``book/`` and a copy of every notebook in ``chapters/``. The copies,
never the notebooks themselves, are transformed (:func:`prepare_notebook`):

- a solution cell (tag ``solution``), an answer cell (``answer``) and an
  evidence cell (``evidence``) is folded WITH its outputs behind a button that
  says what it hides ("Show solution", ...); a markdown answer or evidence cell
  is wrapped in ``<details>``. In the PDF the solutions and answers leave the
  chapters for an appendix, "Solutions" (:func:`solutions_page`);
- printed text (streams, plain-text results) becomes HTML that fits the
  column (:func:`text_html`): lines of prose wrap, with their indentation kept;
  runs of aligned columns (a table) are kept as printed, in a box of their own
  that scrolls sideways on a narrow screen. The plain text stays for the PDF;
- library source printed with ``inspect.getsource`` is highlighted and folded
  (:func:`source_html`);
- the plain-text stand-ins of widget views (``VBox(children=...``,
  ``interactive(children=...``) are dropped: a browser without a kernel cannot
  show live controls, and the figure drawn at the defaults stays
  (:func:`slamlib.course.widgets.interact_figure`); a figure's displayed height
  is dropped so that it scales with its width.

The web edition offers each chapter's committed notebook for download (the
original, not the transformed copy). MathJax is copied from the ``mathjax``
package (django-static-mathjax, MathJax 3) into the site's ``_static``, so the
site needs no network. The PDF is Sphinx's LaTeX builder run by ``latexmk``
with XeLaTeX (Debian: ``latexmk``, ``texlive-xetex``, ``texlive-latex-extra``,
``fonts-freefont-otf``), written as ``<out>/pdf/ekf-slam-aruco.pdf``.
"""

from __future__ import annotations

import argparse
import html
import re
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
from execute_notebooks import merge_streams  # noqa: E402  (one join of split prints)

WIDGET_REPR = re.compile(r"^(VBox|HBox|interactive)\(children=")
#: A gap of two or more spaces between two printed words: the mark of aligned columns.
COLUMN_GAP = re.compile(r"(?<=\S) {2,}(?=\S)")
GETSOURCE = re.compile(r"getsource\(\s*([\w.]+)")
FOLDS = {"solution": "solution", "answer": "answer", "evidence": "evidence"}
PDF_NAME = "ekf-slam-aruco"


# --------------------------------------------------------------------------- printed text

def _is_table_line(line: str) -> bool:
    return len(COLUMN_GAP.findall(line)) >= 2


def text_blocks(text: str) -> list[tuple[str, list[str]]]:
    """Split printed text into ``("table", lines)`` and ``("prose", lines)`` runs.

    A table is two or more consecutive lines with at least two column gaps each
    (two or more spaces between words); a line with one gap (a header over the
    columns, a title) next to a table joins it. Everything else is prose.
    """
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    kind = ["table" if _is_table_line(line) else "prose" for line in lines]
    for i in range(len(lines)):   # a lone table-like line is prose
        if kind[i] == "table" and not any(
                0 <= j < len(lines) and kind[j] == "table" for j in (i - 1, i + 1)):
            kind[i] = "prose"
    changed = True
    while changed:                # headers with one gap join an adjacent table
        changed = False
        for i, line in enumerate(lines):
            if kind[i] == "prose" and COLUMN_GAP.search(line) and any(
                    0 <= j < len(lines) and kind[j] == "table" for j in (i - 1, i + 1)):
                kind[i], changed = "table", True
    blocks: list[tuple[str, list[str]]] = []
    for k, line in zip(kind, lines):
        if blocks and blocks[-1][0] == k:
            blocks[-1][1].append(line)
        else:
            blocks.append((k, [line]))
    return blocks


def text_html(text: str, stream: str = "stdout") -> str:
    """Printed text as HTML that fits the column (see the module's docstring)."""
    parts = []
    for kind, lines in text_blocks(text):
        if kind == "table":
            body = html.escape("\n".join(lines))
            parts.append(f'<div class="course-table" tabindex="0"><pre>{body}</pre></div>')
        else:
            rows = []
            for line in lines:
                indent = len(line) - len(line.lstrip(" "))
                style = f' style="padding-left:min({indent + 2}ch,40%)"' if indent else ""
                rows.append(f'<div class="course-line"{style}>{html.escape(line.lstrip(" "))}'
                            "</div>")
            parts.append('<div class="course-prose">' + "".join(rows) + "</div>")
    return f'<div class="course-text course-{stream}">' + "".join(parts) + "</div>"


def source_html(code: str, name: str) -> str:
    """Printed library source as a folded, highlighted block (Sphinx's Pygments classes)."""
    from pygments import highlight
    from pygments.formatters import HtmlFormatter
    from pygments.lexers import PythonLexer

    body = highlight(code.rstrip("\n") + "\n", PythonLexer(), HtmlFormatter(nowrap=True))
    return (f'<details class="course-source"><summary>The library\'s code: '
            f"<code>{html.escape(name)}</code></summary>"
            f'<div class="highlight-python notranslate"><div class="highlight"><pre>{body}'
            "</pre></div></div></details>")


def _text_output(text: str, stream: str = "stdout", source_of: str | None = None) -> dict:
    rendered = source_html(text, source_of) if source_of else text_html(text, stream)
    return nbformat.v4.new_output("display_data", data={"text/html": rendered, "text/plain": text})


#: Printed text in the PDF: the font size a block needs so that its widest table line fits
#: the A4 text width (characters per line), prose lines wrap at any size.
PDF_SIZES = ((110, None), (126, r"\scriptsize"), (175, r"\tiny"))


def text_markdown_pdf(text: str) -> str:
    """Printed text for the PDF: a verbatim block, in a smaller font when a table needs it."""
    widest = max((len(line) for kind, lines in text_blocks(text) if kind == "table"
                  for line in lines), default=0)
    size = next((sz for width, sz in PDF_SIZES if widest <= width), PDF_SIZES[-1][1])
    runs = re.findall(r"~{3,}", text)
    fence = "~" * max(3, *(len(r) + 1 for r in runs)) if runs else "~~~"
    block = f"{fence}text\n{text.rstrip(chr(10))}\n{fence}\n"
    if size is None:
        return block
    return (f"```{{raw}} latex\n\\begingroup\\fvset{{fontsize={size}}}\n```\n\n{block}\n"
            "```{raw} latex\n\\endgroup\n```\n")


def _top_level_splits(tex: str, mark: str = r"\\q?quad(?![a-zA-Z])") -> list[int]:
    """Positions of ``\\quad`` / ``\\qquad`` (or ``mark``) outside braces and environments."""
    depth, out, i = 0, [], 0
    while i < len(tex):
        if tex.startswith("\\begin{", i):
            depth += 1
        elif tex.startswith("\\end{", i):
            depth -= 1
        elif tex[i] == "{":
            depth += 1
        elif tex[i] == "}":
            depth -= 1
        elif depth == 0 and re.match(mark, tex[i:]):
            out.append(i)
        i += 1
    return out


def break_long_equation(tex: str, width: int = 100) -> str:
    """A long one-line display equation made of parts set apart by ``\\quad`` becomes one part a
    line (``gathered``): print cannot scroll, and a line wider than the page is cut."""
    flat = " ".join(tex.split())
    if len(flat) <= width or _top_level_splits(flat, r"\\\\") or not _top_level_splits(flat):
        return tex
    parts, last = [], 0
    for pos in _top_level_splits(flat):
        parts.append(flat[last:pos])
        last = pos + len(re.match(r"\\q?quad", flat[pos:]).group(0))
    parts.append(flat[last:])
    lines = [p.strip() for p in parts if p.strip()]
    return "\\begin{gathered}" + " \\\\ ".join(lines) + "\\end{gathered}"


def long_equations_broken(md: str) -> str:
    """Every ``$$ ... $$`` display equation of a markdown cell through
    :func:`break_long_equation`."""
    return re.sub(r"\$\$(.+?)\$\$", lambda m: "$$" + break_long_equation(m.group(1)) + "$$", md,
                  flags=re.S)


# --------------------------------------------------------------------------- cells

def _fold(cell, what: str) -> None:
    """Fold a cell (code: with its outputs) behind a button that names ``what`` it hides."""
    if cell.cell_type == "markdown":
        if cell.source.lstrip().startswith("<details>"):   # folded in the notebook already
            cell.source = cell.source.replace("<details>", f'<details class="course-{what}">', 1)
            return
        cell.source = (f"<details class=\"course-{what}\">\n<summary>Show {what}</summary>\n\n"
                       f"{cell.source}\n\n</details>")
        return
    tags = [t for t in cell.metadata.get("tags", []) if t not in ("hide-input", "hide-output")]
    cell.metadata["tags"] = [*tags, "hide-cell"]
    cell.metadata["mystnb"] = {**cell.metadata.get("mystnb", {}),
                               "code_prompt_show": f"Show {what}",
                               "code_prompt_hide": f"Hide {what}"}


def display_math_apart(md: str) -> str:
    """Put a blank line before a line that opens ``$$`` and after one that closes it.

    MyST reads ``$$`` display math only as a block of its own: glued to a paragraph, its
    dollars pair up with the inline ones around it and turn prose into math. Jupyter's
    renderer forgives that, so the chapters have it.
    """
    lines, out, inside = md.split("\n"), [], False
    for line in lines:
        s = line.strip()
        opens = s.startswith("$$") and not inside
        if opens and out and out[-1].strip():
            out.append("")
        out.append(line)
        n = s.count("$$")
        if n % 2 == 1:
            inside = not inside
        if not inside and n and s.endswith("$$"):
            out.append("")
    return "\n".join(out).rstrip("\n") + ("\n" if md.endswith("\n") else "")


def _is_widget_stand_in(out) -> bool:
    data = out.get("data", {})
    if out.get("output_type") not in ("display_data", "execute_result") or set(data) != {
            "text/plain"}:
        return False
    return bool(WIDGET_REPR.match(data["text/plain"]))


def _outputs(cell) -> list:
    match = GETSOURCE.search(cell.source)
    source_of = match.group(1) if match else None
    outputs = []
    for out in merge_streams([o for o in cell.outputs if not _is_widget_stand_in(o)]):
        kind = out.get("output_type")
        data = out.get("data", {})
        if kind == "stream":
            code = source_of if out.get("name") == "stdout" else None
            out = _text_output(out["text"], out.get("name", "stdout"), code)
        elif kind in ("display_data", "execute_result") and set(data) == {"text/plain"}:
            out = _text_output(data["text/plain"], "result")
        for mime in ("image/png", "image/jpeg"):
            out.get("metadata", {}).get(mime, {}).pop("height", None)  # scale with the width
        outputs.append(out)
    return outputs


def _outputs_pdf(cell) -> list:
    outputs = []
    for out in merge_streams([o for o in cell.outputs if not _is_widget_stand_in(o)]):
        data = out.get("data", {})
        text = out.get("text") if out.get("output_type") == "stream" else (
            data.get("text/plain") if set(data) == {"text/plain"} else None)
        if text is not None:
            out = nbformat.v4.new_output("display_data", data={
                "text/markdown": text_markdown_pdf(text), "text/plain": text})
        outputs.append(out)
    return outputs


def prepare_notebook(nb: nbformat.NotebookNode, pdf: bool = False) -> nbformat.NotebookNode:
    """Transform a copy of a chapter for the book (in place; see the module's docstring)."""
    for cell in nb.cells:
        tags = cell.metadata.get("tags", [])
        folds = [FOLDS[t] for t in tags if t in FOLDS]
        if pdf and {"solution", "answer"} & set(tags):
            cell.metadata["tags"] = [*tags, "remove-cell"]   # into the appendix
        elif folds and not pdf:
            _fold(cell, folds[0])
        if cell.cell_type == "markdown":
            cell.source = display_math_apart(cell.source)
            if pdf:
                cell.source = long_equations_broken(cell.source)
        if cell.cell_type == "code":
            cell.outputs = _outputs_pdf(cell) if pdf else _outputs(cell)
    return nb


def solutions_page(notebooks: list[tuple[str, nbformat.NotebookNode]]) -> str:
    """The PDF's appendix: every chapter's solutions (code) and answers (text), in order."""
    parts = ["# Solutions\n",
             "The solutions of the exercises and the answers to the \"More to try\" lists, by "
             "chapter. Each solution replaces the exercise cell just before it.\n"]
    for title, nb in notebooks:
        cells = [c for c in nb.cells if {"solution", "answer"} & set(c.metadata.get("tags", []))]
        if not cells:
            continue
        parts.append(f"## {title}\n")
        for c in cells:
            if c.cell_type == "code":
                parts.append(f"```python\n{c.source.rstrip()}\n```\n")
            else:   # an answer, without the fold it has in the chapter
                text = re.sub(r"^\s*<details\b[^>]*>\s*<summary>.*?</summary>|</details>\s*$", "",
                              c.source.strip(), flags=re.S).strip()
                parts.append(re.sub(r"^(#+) ", r"#\1## ", text, flags=re.M) + "\n")
    return "\n".join(parts)


def _title(nb: nbformat.NotebookNode, fallback: str) -> str:
    for c in nb.cells:
        if c.cell_type == "markdown":
            m = re.search(r"^# (.+)$", c.source, flags=re.M)
            if m:
                return m.group(1).strip()
    return fallback


# --------------------------------------------------------------------------- layout, build

def mathjax_dir() -> Path:
    import mathjax  # django-static-mathjax: MathJax 3 as static files

    return Path(mathjax.__path__[0]) / "static" / "mathjax"


#: The PDF's root: the chapters; the errata and the solutions follow as appendices (conf.py).
PDF_ROOT = """# EKF SLAM with ArUco markers

```{toctree}
:maxdepth: 1
:glob:

chapters/[0-9]*
```
"""


def lay_out(src: Path, pdf: bool = False) -> None:
    if src.exists():
        shutil.rmtree(src)
    (src / "chapters").mkdir(parents=True)
    if pdf:
        (src / "pdf_root.md").write_text(PDF_ROOT, encoding="utf-8")
    else:
        for page in (ROOT / "book").glob("*.md"):
            shutil.copy2(page, src / page.name)
    shutil.copytree(ROOT / "book" / "static", src / "_static")
    chapters = []
    for p in sorted((ROOT / "notebooks").glob("*.ipynb")):
        original = nbformat.read(p, as_version=4)
        chapters.append((_title(original, p.stem), original))
        nb = prepare_notebook(nbformat.read(p, as_version=4), pdf=pdf)
        nbformat.write(nb, src / "chapters" / p.name)
    if pdf:
        (src / "solutions.md").write_text(solutions_page(chapters), encoding="utf-8")
        return
    mj = mathjax_dir()
    dest = src / "_static" / "mathjax"
    shutil.copytree(mj / "es5", dest / "es5")
    shutil.copy2(mj / "LICENSE", dest / "LICENSE")


def build_html(out: Path) -> int:
    from sphinx.cmd.build import build_main

    src, html_dir = out / "src", out / "html"
    lay_out(src)
    code = build_main(["-b", "html", "-q", "-c", str(ROOT / "book"), "-d", str(out / "doctrees"),
                       "-D", f"html_static_path={src / '_static'}", str(src), str(html_dir)])
    if code == 0:
        # the download button offers the committed notebook, not the book's transformed copy
        for p in sorted((ROOT / "notebooks").glob("*.ipynb")):
            shutil.copy2(p, html_dir / "_sources" / "chapters" / p.name)
        print(f"web edition: {html_dir / 'index.html'}")
    return code


def build_pdf(out: Path) -> int:
    from sphinx.cmd.build import build_main

    if not shutil.which("latexmk") or not shutil.which("xelatex"):
        print("make pdf needs latexmk and XeLaTeX (Debian: apt-get install latexmk texlive-xetex "
              "texlive-latex-extra texlive-fonts-recommended fonts-freefont-otf)", file=sys.stderr)
        return 2
    src, latex = out / "src-pdf", out / "latex"
    lay_out(src, pdf=True)
    if latex.exists():
        shutil.rmtree(latex)
    code = build_main(["-b", "latex", "-q", "-c", str(ROOT / "book"), "-d",
                       str(out / "doctrees-pdf"), "-t", "pdf", str(src), str(latex)])
    if code != 0:
        return code
    run = subprocess.run(["latexmk", "-pdfxe", "-interaction=nonstopmode", "-halt-on-error",
                          f"{PDF_NAME}.tex"], cwd=latex, capture_output=True, text=True)
    pdf = latex / f"{PDF_NAME}.pdf"
    if run.returncode != 0 or not pdf.exists():
        print(run.stdout[-4000:], file=sys.stderr)
        return run.returncode or 1
    final = out / "pdf" / f"{PDF_NAME}.pdf"
    final.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(pdf, final)
    print(f"printed edition: {final}")
    return 0


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "book" / "_build"))
    ap.add_argument("--pdf", action="store_true", help="the printed edition (LaTeX, XeLaTeX)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    return build_pdf(out) if args.pdf else build_html(out)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
