"""Sharp inline figures: a notebook's figures as pixel-doubled ("retina") PNGs.

Importing :mod:`slamlib.course` calls :func:`sharp_inline_figures` (every chapter imports it
before its first figure), so no chapter has to.
"""

from __future__ import annotations

__all__ = ["sharp_inline_figures"]


def sharp_inline_figures() -> bool:
    """In a Jupyter kernel, draw inline figures as pixel-doubled PNGs; True if it did.

    A figure shows at the same size as before (the PNG carries its displayed width and
    height: ``figsize`` times the figure's dpi), with twice the pixels per side, so lines,
    ticks and legends stay sharp on high-resolution screens and in the web edition, which
    scales figures down to its column. Outside a kernel (scripts, tests) nothing changes.
    """
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    if shell is None or not hasattr(shell, "kernel"):
        return False
    from matplotlib_inline.backend_inline import set_matplotlib_formats

    set_matplotlib_formats("retina")
    return True
