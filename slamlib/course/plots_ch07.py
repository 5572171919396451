"""Chapter 07's figures: the coverage grid, a closed-loop exploration seen from above and
its history (coverage, landmarks, position error) against time.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from .plots import DPI, finish_top_view, plot_trace, world_axes

__all__ = ["RETURN_STYLE", "plot_coverage", "plot_exploration", "plot_exploration_history"]


RETURN_STYLE = {"color": "tab:orange", "lw": 0, "marker": ".", "ms": 3,
                "label": "estimate while returning"}

def plot_coverage(ax, grid, *, color: str = "tab:green", alpha: float = 0.18,
                  label: str | None = "cells seen"):
    """Shade the seen cells of a :class:`slamlib.explore.CoverageGrid` on a top view."""
    from matplotlib.colors import ListedColormap

    xmin, xmax, ymin, ymax = grid.bounds
    rows, cols = grid.shape
    extent = (xmin, xmin + cols * grid.cell, ymin, ymin + rows * grid.cell)
    inverted = ax.yaxis_inverted()
    img = np.ma.masked_where(~grid.seen, np.ones(grid.shape))
    ax.imshow(img, origin="lower", extent=extent, cmap=ListedColormap([color]), alpha=alpha,
              interpolation="nearest", aspect="equal", zorder=0)
    if inverted and not ax.yaxis_inverted():          # imshow re-orders the y limits
        ax.invert_yaxis()
    if label:
        ax.fill([], [], color=color, alpha=alpha, label=label)     # the legend's entry
    return ax

def plot_exploration(ax, exploration, world=None, *, ellipse_every: float = 20.0,
                     nsigma: float = 2.0, title: str | None = None, legend_outside: bool = True):
    """Top view of a closed-loop exploration (chapter 07).

    The seen cells (shaded), truth (red) and estimate (blue, orange dots while
    returning to a landmark) with ``nsigma`` pose ellipses, the true markers
    (stars, a ring around the anchors of the returns) and the mapped landmarks.

    Parameters
    ----------
    exploration : slamlib.explore.Exploration
    world : World, optional
    """
    if not ax.yaxis_inverted():
        world_axes(ax, world)
    pol = exploration.policy
    if getattr(pol, "grid", None) is not None:
        plot_coverage(ax, pol.grid)
        if world is not None:
            world_axes(ax, world)
    tr = exploration.trace
    plot_trace(ax, tr, world, ellipse_every=ellipse_every, nsigma=nsigma,
               legend_outside=legend_outside)
    returns = getattr(pol, "returns", [])
    if returns:
        mask = np.zeros(tr.t.size, dtype=bool)
        for t0, t1, *_ in returns:
            mask |= (tr.t >= t0) & (tr.t <= t1)
        ax.plot(tr.x[mask, 0], tr.x[mask, 1], zorder=3, **RETURN_STYLE)
        if world is not None:
            anchors = sorted({r[2] for r in returns if r[2] in set(world.ids.tolist())})
            pts = np.array([world.marker(i).position for i in anchors]).reshape(-1, 2)
            ax.plot(pts[:, 0], pts[:, 1], "o", mfc="none", mec="tab:orange", ms=14, mew=1.5,
                    label="anchor of a return", zorder=5)
    ax.plot(*tr.truth[-1, :2], "s", color="k", ms=5, label="end (truth)")
    return finish_top_view(ax, title, legend_outside)

def plot_exploration_history(exploration, *, nsigma: float = 2.0, axes=None,
                             title: str | None = None):
    """Coverage, mapped landmarks, the return rule's input and the position error against time.

    Four panels: coverage; landmarks mapped; ``sigma_xy = sqrt(P_xx + P_yy)`` (the filter's
    position uncertainty) with the return threshold, the two numbers the rule compares; the
    true position error with the filter's ``nsigma * sigma_xy``. The returns to a landmark
    are shaded. ``axes``: four axes to draw in (default: a new figure).

    Returns
    -------
    (Figure, axes)
    """
    from matplotlib.ticker import MaxNLocator

    h = exploration.history()
    own = axes is None
    if own:
        fig, axes = plt.subplots(4, 1, figsize=(7.2, 7.4), dpi=DPI, sharex=True)
    if len(axes) != 4:
        raise ValueError(f"axes: expected 4 axes, got {len(axes)}")
    fig = axes[0].figure
    axes[0].plot(h["t"], 100 * h["coverage"], color="tab:green")
    axes[0].set_ylabel("coverage (%)")
    axes[0].set_ylim(0, 100)
    axes[1].step(h["t"], h["landmarks"], where="post", color="tab:blue")
    axes[1].set_ylabel("landmarks")
    axes[1].yaxis.set_major_locator(MaxNLocator(nbins=4, integer=True))
    axes[2].plot(h["t"], h["sigma_xy"], color="tab:blue", label="sigma_xy (filter)")
    sr = getattr(exploration.policy, "sigma_return", None)
    if sr is not None:
        axes[2].axhline(sr, color="tab:orange", lw=1.0, ls=":", label="return threshold")
    axes[2].set_ylabel("sigma_xy (m)")
    axes[2].set_ylim(0, 1.45 * max(float(np.max(h["sigma_xy"])), sr or 0.0))
    axes[3].plot(h["t"], h["error_xy"], color="tab:red", label="position error (truth)")
    axes[3].plot(h["t"], nsigma * h["sigma_xy"], "--", color="tab:blue",
                 label=f"{nsigma:g} sigma_xy (filter)")
    axes[3].set_ylabel("position (m)")
    axes[3].set_xlabel("t (s)")
    # head room above the curves for a legend that hides none of them
    top = float(np.nanmax(np.concatenate([h["error_xy"], nsigma * h["sigma_xy"]])))
    axes[3].set_ylim(0, 1.45 * top if top > 0 else 1.0)
    first = True
    for t0, t1, *_ in getattr(exploration.policy, "returns", []):
        for ax in axes:
            ax.axvspan(t0, t1, color="tab:orange", alpha=0.2,
                       label="return to a landmark" if (first and ax is axes[2]) else None)
        first = False
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
    axes[2].legend(fontsize=8, loc="upper left", ncol=3)
    axes[3].legend(fontsize=8, loc="upper left", ncol=2)
    if title:
        axes[0].set_title(title)
    if own:
        fig.tight_layout()
    return fig, axes
