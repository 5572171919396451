"""Sphinx configuration of the course's web edition (``make book``).

``tools/build_book.py`` lays out the sources in ``book/_build/src`` (this
folder's pages and a copy of every committed notebook, outputs as committed:
nothing is executed) and runs Sphinx with this configuration. MathJax 3 is
served from the built site itself (the ``django-static-mathjax`` package's
copy, no CDN), so the site reads offline.
"""

project = "EKF SLAM with ArUco markers"
author = "the course's authors"
copyright = "the course's authors"

extensions = ["myst_nb"]
myst_enable_extensions = ["dollarmath", "amsmath"]
nb_execution_mode = "off"              # the committed outputs are the book's outputs
nb_merge_streams = True
nb_ipywidgets_js = {}                  # widget views are dropped; no widget JavaScript from a CDN
suppress_warnings = ["mystnb.unknown_mime_type"]

exclude_patterns = ["_build", "**.ipynb_checkpoints"]
html_theme = "sphinx_book_theme"
html_title = project
html_static_path: list[str] = []     # tools/build_book.py passes the MathJax copy (-D)
mathjax_path = "mathjax/es5/tex-chtml.js"
mathjax3_config = {"tex": {"inlineMath": [["\\(", "\\)"]], "displayMath": [["\\[", "\\]"]]}}
html_theme_options = {
    "show_toc_level": 2,
    "use_download_button": False,
    "use_fullscreen_button": False,
}
html_last_updated_fmt = None
html_copy_source = False
html_favicon = "favicon.svg"           # an ArUco-like square (a browser asks for one)
html_context = {"default_mode": "light"}
