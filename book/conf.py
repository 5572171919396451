"""Sphinx configuration of the course's web edition (``make book``) and PDF (``make pdf``).

``tools/build_book.py`` lays out the sources in ``book/_build/src`` (this
folder's pages and a transformed copy of every committed notebook, outputs as
committed: nothing is executed) and runs Sphinx with this configuration; for
the PDF it lays them out in ``book/_build/src-pdf`` and passes ``-t pdf``.
MathJax 3 is served from the built site itself (the ``django-static-mathjax``
package's copy, no CDN), so the site reads offline.
"""

project = "EKF SLAM with ArUco markers"
author = "the course's authors"
copyright = "the course's authors"

extensions = ["myst_nb", "sphinx_copybutton"]
myst_enable_extensions = ["dollarmath", "amsmath"]
nb_execution_mode = "off"              # the committed outputs are the book's outputs
nb_merge_streams = True
nb_render_markdown_format = "myst"     # the PDF's printed text (build_book.py) uses {raw} latex
nb_ipywidgets_js = {}                  # widget views are dropped; no widget JavaScript from a CDN
suppress_warnings = ["mystnb.unknown_mime_type"]

exclude_patterns = ["_build", "**.ipynb_checkpoints"]
html_theme = "sphinx_book_theme"
html_title = project
html_static_path: list[str] = []     # tools/build_book.py passes _static (CSS, MathJax) with -D
html_css_files = ["course.css"]
html_js_files = ["course.js"]             # inline formulas: a scroll box only where needed
mathjax_path = "mathjax/es5/tex-chtml.js"
mathjax3_config = {"tex": {"inlineMath": [["\\(", "\\)"]], "displayMath": [["\\[", "\\]"]]}}
html_theme_options = {
    "show_toc_level": 2,
    "use_download_button": True,       # the chapter's notebook (.ipynb)
    "use_fullscreen_button": False,
    # pydata-sphinx-theme 0.20 fills an unset navbar_persistent with a search button, which
    # makes it render its own header: hidden by sphinx-book-theme, but holding the page's FIRST
    # .primary-toggle and .secondary-toggle, to which both themes' scripts attach their clicks
    # (the visible buttons in the article header got none) and a second search box. Empty, the
    # header is not rendered at all.
    "navbar_persistent": [],
}
html_last_updated_fmt = None
html_copy_source = True                # the download button's notebook (build_book.py puts the
html_sourcelink_suffix = ""            # committed one there)
html_favicon = "favicon.svg"           # an ArUco-like square (a browser asks for one)
html_context = {"default_mode": "light"}

# sphinx-copybutton: leave prompts and outputs out of what is copied
copybutton_exclude = ".linenos, .gp, .go"
copybutton_selector = "div.cell_input div.highlight pre, div.highlight-python div.highlight pre"

# The printed edition: one PDF, XeLaTeX (Unicode in the printed outputs), the chapters, then the
# errata and the solutions as appendices.
if tags.has("pdf"):  # noqa: F821 - Sphinx defines ``tags`` while reading this file
    root_doc = "pdf_root"
    exclude_patterns += ["index.md"]
latex_engine = "xelatex"
latex_documents = [("pdf_root", "ekf-slam-aruco.tex", project, author, "manual", True)]
latex_appendices = ["chapters/A_errata", "solutions"]
latex_show_urls = "no"
latex_elements = {
    "papersize": "a4paper",
    "pointsize": "10pt",
    "fvset": r"\fvset{fontsize=\footnotesize}",   # printed outputs: about 95 characters a line
    "sphinxsetup": "verbatimwrapslines=true, verbatimforcewraps=true",
    # the chapters and their sections carry their own numbers ("03 · ...", "2. ...")
    "preamble": r"\setcounter{tocdepth}{1}\setcounter{secnumdepth}{-1}",
    "printindex": "",
}
latex_domain_indices = False
