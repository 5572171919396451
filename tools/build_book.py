"""Build the course's web edition into book/_build/html (``make book``).

Usage: python tools/build_book.py [--out book/_build]

Nothing is executed: the pages are the committed notebooks with their outputs.
The sources are laid out in ``<out>/src``: the pages of ``book/`` and a copy of
every notebook in ``chapters/``, in which

- each solution cell (tag ``solution``) is folded (tag ``hide-input``: the
  reader opens it with a click), and so is each answer to a "More to try"
  list (tag ``answer``, a markdown cell: wrapped in ``<details>``), and
- the plain-text stand-ins of widget views (``VBox(children=...``,
  ``interactive(children=...``) are dropped: a browser without a kernel cannot
  show live controls, and the figure drawn at the defaults stays
  (:func:`slamlib.course.widgets.interact_figure`).

MathJax is copied from the ``mathjax`` package (django-static-mathjax, MathJax
3) into the site's ``_static``, so the site needs no network.
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parent.parent
WIDGET_REPR = re.compile(r"^(VBox|HBox|interactive)\(children=")


def prepare_notebook(nb: nbformat.NotebookNode) -> nbformat.NotebookNode:
    """Fold the solutions and drop widget stand-ins (in place); return the notebook."""
    for cell in nb.cells:
        tags = cell.metadata.get("tags", [])
        if "solution" in tags and "hide-input" not in tags:
            cell.metadata["tags"] = [*tags, "hide-input"]
        if "answer" in tags and cell.cell_type == "markdown":
            cell.source = ("<details>\n<summary>Answers (open after trying)</summary>\n\n"
                           f"{cell.source}\n\n</details>")
        if cell.cell_type != "code":
            continue
        cell.outputs = [o for o in cell.outputs if not _is_widget_stand_in(o)]
    return nb


def _is_widget_stand_in(out) -> bool:
    data = out.get("data", {})
    if out.get("output_type") not in ("display_data", "execute_result") or set(data) != {
            "text/plain"}:
        return False
    return bool(WIDGET_REPR.match(data["text/plain"]))


def mathjax_dir() -> Path:
    import mathjax  # django-static-mathjax: MathJax 3 as static files

    return Path(mathjax.__path__[0]) / "static" / "mathjax"


def lay_out(src: Path) -> None:
    if src.exists():
        shutil.rmtree(src)
    (src / "chapters").mkdir(parents=True)
    for page in (ROOT / "book").glob("*.md"):
        shutil.copy2(page, src / page.name)
    for p in sorted((ROOT / "notebooks").glob("*.ipynb")):
        nb = prepare_notebook(nbformat.read(p, as_version=4))
        nbformat.write(nb, src / "chapters" / p.name)
    mj = mathjax_dir()
    dest = src / "_static" / "mathjax"
    shutil.copytree(mj / "es5", dest / "es5")
    shutil.copy2(mj / "LICENSE", dest / "LICENSE")


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "book" / "_build"))
    args = ap.parse_args(argv)
    out = Path(args.out)
    src = out / "src"
    lay_out(src)
    from sphinx.cmd.build import build_main

    html = out / "html"
    code = build_main(["-b", "html", "-q", "-c", str(ROOT / "book"), "-d", str(out / "doctrees"),
                       "-D", f"html_static_path={src / '_static'}", str(src), str(html)])
    if code == 0:
        print(f"web edition: {html / 'index.html'}")
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
