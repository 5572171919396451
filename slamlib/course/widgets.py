"""Interactive figures that leave a static figure behind (every chapter with a slider).

``ipywidgets.interact`` draws its figure inside an ``Output`` widget. A
notebook executed without a browser (nbval, ``make notebooks``) stores only the
widget's text representation, ``interactive(children=(FloatSlider(...``, so
GitHub's viewer and the web edition show that line instead of a figure.

:func:`interact_figure` draws the figure at the controls' default values as an
ordinary output (a PNG with a display id) and then shows the controls; moving
a control redraws the figure *in place* (``update_display_data`` on that id),
so in JupyterLab there is one figure that follows the sliders, and in a stored
notebook the default figure is there for every reader.
"""

from __future__ import annotations

import io
from collections.abc import Callable

__all__ = ["interact_figure", "render_outputs"]


def render_outputs(plot: Callable[..., object], kwargs: dict) -> tuple[str, list[bytes]]:
    """Call ``plot(**kwargs)`` and return what it printed and the PNGs of its figures.

    Figures shown with ``plt.show()`` under the notebook's inline backend are
    taken from the captured display messages; figures still open afterwards
    (any other backend) are saved as PNG and closed.
    """
    text, figures = _render(plot, kwargs)
    return text, [png for png, _ in figures]


def _render(plot: Callable[..., object], kwargs: dict) -> tuple[str, list[tuple[bytes, dict]]]:
    """:func:`render_outputs` with each PNG's display metadata (its displayed width and height
    when the PNG holds more pixels than it shows: the course's pixel-doubled figures)."""
    import matplotlib.pyplot as plt
    from IPython.utils.capture import capture_output

    before = set(plt.get_fignums())
    with capture_output(display=True) as cap:
        plot(**kwargs)
    figures = []
    for out in cap.outputs:
        if "image/png" in out.data:
            png = out.data["image/png"]
            png = png if isinstance(png, bytes) else _b64decode(png)
            figures.append((png, dict((out.metadata or {}).get("image/png", {}))))
    for num in plt.get_fignums():
        if num in before:
            continue
        fig = plt.figure(num)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", bbox_inches="tight", dpi=2 * fig.dpi)
        png = buf.getvalue()
        width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
        figures.append((png, {"width": width // 2, "height": height // 2}))
        plt.close(fig)
    return cap.stdout, figures


def _b64decode(s: str) -> bytes:
    import base64

    return base64.b64decode(s)


def interact_figure(plot: Callable[..., object], **controls):
    """``ipywidgets.interact(plot, **controls)`` whose default figure is an ordinary output.

    Parameters
    ----------
    plot : callable
        Draws one figure (and may print a line) for keyword arguments named as
        the controls; it is called once with the controls' default values, then
        again each time a control changes.
    **controls : ipywidgets.ValueWidget
        One control per keyword argument of ``plot`` (use
        ``continuous_update=False`` on sliders: each change redraws).

    Returns
    -------
    ipywidgets.VBox
        The controls (already displayed, below the figure).
    """
    import ipywidgets as widgets
    from IPython.display import display

    if not controls:
        raise ValueError("controls: expected at least one widget, e.g. sigma=FloatSlider(...)")
    for name, c in controls.items():
        if not isinstance(c, widgets.ValueWidget):
            raise ValueError(f"controls[{name!r}]: expected an ipywidgets control with a value, "
                             f"got {type(c).__name__}")
        if not c.description:
            c.description = name

    def values() -> dict:
        return {name: c.value for name, c in controls.items()}

    def bundles() -> tuple[dict | None, dict, dict]:
        text, figures = _render(plot, values())
        text = text.rstrip("\n")
        image = ({"image/png": figures[-1][0], "text/plain": "<Figure>"} if figures
                 else {"text/plain": "(no figure)"})
        shown = {"image/png": figures[-1][1]} if figures and figures[-1][1] else {}
        return ({"text/plain": text} if text else None), image, shown

    text, image, shown = bundles()
    text_handle = display(text, raw=True, display_id=True) if text else None
    image_handle = display(image, raw=True, display_id=True, metadata=shown)

    def redraw(_change=None) -> None:
        t, i, m = bundles()
        if text_handle is not None:
            text_handle.update(t or {"text/plain": ""}, raw=True)
        image_handle.update(i, raw=True, metadata=m)

    for c in controls.values():
        c.observe(redraw, names="value")
    box = widgets.VBox(list(controls.values()))
    display(box)
    return box
