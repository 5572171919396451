"""slamlib.course.inline_figures: a kernel's inline figures are pixel-doubled PNGs."""

from __future__ import annotations

import base64
import struct

import nbformat
from nbclient import NotebookClient

from slamlib.course.inline_figures import sharp_inline_figures


def test_outside_a_kernel_nothing_changes():
    assert sharp_inline_figures() is False


def test_figures_are_drawn_sharp_in_a_kernel(tmp_path):
    """Importing slamlib.course in a kernel makes inline figures pixel-doubled PNGs that
    show at their nominal size (figsize x dpi)."""
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(
        "import matplotlib.pyplot as plt\nimport slamlib.course\n"
        "plt.subplots(figsize=(3, 2), dpi=80)\nplt.plot([0, 1])\nplt.show()")])
    NotebookClient(nb, timeout=120, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    out = next(o for o in nb.cells[0].outputs if "image/png" in o.get("data", {}))
    png = base64.b64decode(out["data"]["image/png"])
    width, height = struct.unpack(">II", png[16:24])
    shown = out["metadata"]["image/png"]
    assert (width, height) == (2 * shown["width"], 2 * shown["height"])
    assert 200 <= shown["width"] <= 240   # 3 in x 80 dpi, trimmed to the drawing


def test_a_widgets_default_figure_is_sharp_too(tmp_path):
    """interact_figure's default figure (the one the book shows) keeps its displayed size."""
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(
        "import matplotlib.pyplot as plt\nimport ipywidgets as w\n"
        "from slamlib.course.widgets import interact_figure\n"
        "def plot(a):\n    plt.subplots(figsize=(3, 2), dpi=80)\n    plt.plot([0, a])\n"
        "    plt.show()\n"
        "_ = interact_figure(plot, a=w.FloatSlider(value=1.0, min=0, max=2))")])
    NotebookClient(nb, timeout=120, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    out = next(o for o in nb.cells[0].outputs if "image/png" in o.get("data", {}))
    png = base64.b64decode(out["data"]["image/png"])
    width, height = struct.unpack(">II", png[16:24])
    shown = out["metadata"]["image/png"]
    assert (width, height) == (2 * shown["width"], 2 * shown["height"])
