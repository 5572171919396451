"""The figure primitives every chapter shares: top views, ellipses, trajectories, a
filter's trace and its errors.

Top views follow one rule: the world frame N is z-down (x forward, y to the
right), so a picture of the world *seen from above* puts x to the right and
y **downwards** on the screen (:func:`world_axes` inverts the y axis and fixes
an equal aspect). Then a positive (clockwise) rotation looks clockwise and a
left turn looks like a left turn. The chapters' own figures are in
:mod:`slamlib.course.plots_ch00` ... :mod:`slamlib.course.plots_ch11`.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Ellipse

__all__ = ["FIGSIZE", "DPI", "TRUTH_STYLE", "ESTIMATE_STYLE", "world_axes", "finish_top_view",
           "plot_world",
           "covariance_ellipse_params", "plot_covariance_ellipse", "plot_robot", "plot_trajectory",
           "plot_pose_errors", "plot_trace", "plot_trace_errors", "plot_error_comparison"]

#: Default size (inches) and resolution of the course's figures (small PNGs in the notebooks).
FIGSIZE = (6.4, 4.8)

#: A figure shows at FIGSIZE x DPI pixels; in a notebook its PNG holds twice as many pixels per
#: side (:func:`slamlib.course.inline_figures.sharp_inline_figures`), sharp on high-resolution
#: screens and when the web edition scales it down to its column.
DPI = 80

TRUTH_STYLE = {"color": "tab:red", "lw": 1.6, "label": "ground truth"}

ESTIMATE_STYLE = {"color": "tab:blue", "lw": 1.4, "label": "estimate"}

def world_axes(ax=None, world=None, *, margin: float = 0.3, title: str | None = None):
    """Prepare a top view: x right, y down (z-down world seen from above), equal aspect.

    Parameters
    ----------
    ax : matplotlib Axes, optional
        A new figure of size :data:`FIGSIZE` if None.
    world : World, optional
        If given, the limits are the world's bounds plus ``margin``.

    Returns
    -------
    matplotlib Axes
    """
    if ax is None:
        _, ax = plt.subplots(figsize=FIGSIZE, dpi=DPI)
    # fixed limits (a world's bounds) need the box to adjust; free limits adjust the data range
    ax.set_aspect("equal", adjustable="box" if world is not None else "datalim")
    if world is not None:
        xmin, xmax, ymin, ymax = world.bounds
        ax.set_xlim(xmin - margin, xmax + margin)
        ax.set_ylim(ymin - margin, ymax + margin)
    if not ax.yaxis_inverted():
        ax.invert_yaxis()
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m), downwards: seen from above")
    ax.grid(True, lw=0.4, alpha=0.5)
    if title:
        ax.set_title(title)
    return ax

def plot_world(ax, world, *, ids: bool = True, facing: bool = True, color: str = "k",
               label: str | None = "markers (truth)", facing_length: float = 0.25,
               label_spread: float = 0.3, skip_ids=()):
    """Draw the markers as stars, with their ids and (optionally) their facing direction.

    ``skip_ids``: markers whose id is not written (e.g. named by a label of their own).

    An id is written up and to the right of its star, except when another marker
    lies within ``label_spread`` (m) to its right: then it goes to the left, so
    that the ids of two close markers do not run into each other.
    """
    p = world.positions
    ax.plot(p[:, 0], p[:, 1], "*", color=color, ms=9, label=label, zorder=4)
    if facing:
        for m in world.markers:
            ax.plot([m.x, m.x + facing_length * np.cos(m.yaw)],
                    [m.y, m.y + facing_length * np.sin(m.yaw)], "-", color=color, lw=0.8,
                    alpha=0.6)
    if ids:
        xy = np.array([[m.x, m.y] for m in world.markers], dtype=float).reshape(-1, 2)
        for i, m in enumerate(world.markers):
            if int(m.id) in skip_ids:
                continue
            d = np.hypot(xy[:, 0] - m.x, xy[:, 1] - m.y)
            d[i] = np.inf
            close = (d < label_spread) & ((xy[:, 0] > m.x)
                                          | ((xy[:, 0] == m.x) & (np.arange(len(d)) > i)))
            left = bool(np.any(close))
            ax.annotate(str(m.id), (m.x, m.y), textcoords="offset points",
                        xytext=(-4, 4) if left else (4, 4), ha="right" if left else "left",
                        fontsize=8, color=color)
    return ax

def covariance_ellipse_params(cov, nsigma: float = 2.0) -> tuple[float, float, float]:
    """Width, height and angle (degrees) of the ``nsigma`` ellipse of a 2x2 covariance."""
    cov = np.asarray(cov, dtype=float)[:2, :2]
    vals, vecs = np.linalg.eigh(0.5 * (cov + cov.T))
    vals = np.clip(vals, 0.0, None)
    angle = np.degrees(np.arctan2(vecs[1, 1], vecs[0, 1]))
    return 2.0 * nsigma * np.sqrt(vals[1]), 2.0 * nsigma * np.sqrt(vals[0]), float(angle)

def plot_covariance_ellipse(ax, mean, cov, nsigma: float = 2.0, *, color: str = "gold",
                            alpha: float = 0.35, fill: bool = True, **kwargs):
    """Draw the ``nsigma`` uncertainty ellipse of the position block of ``cov`` at ``mean``.

    ``cov`` may be the 3x3 pose covariance (its x-y block is used). In data
    coordinates, so it is right on an inverted y axis too.
    """
    w, h, angle = covariance_ellipse_params(cov, nsigma)
    e = Ellipse(xy=(float(mean[0]), float(mean[1])), width=w, height=h, angle=angle,
                facecolor=color if fill else "none", edgecolor=color,
                alpha=alpha, **kwargs)
    ax.add_patch(e)
    return e

def plot_robot(ax, pose, *, size: float = 0.15, color: str = "tab:green", **kwargs):
    """A triangle at ``pose`` pointing along the heading."""
    x, y, th = (float(v) for v in pose[:3])
    c, s = np.cos(th), np.sin(th)
    pts = np.array([[size, 0.0], [-0.5 * size, 0.5 * size], [-0.5 * size, -0.5 * size]])
    world = np.column_stack([x + c * pts[:, 0] - s * pts[:, 1], y + s * pts[:, 0] + c * pts[:, 1]])
    patch = plt.Polygon(world, closed=True, color=color, **kwargs)
    ax.add_patch(patch)
    return patch

def plot_trajectory(ax, poses, *, style: dict | None = None, **kwargs):
    """Draw the path of poses ``(n, 3)`` (or points ``(n, 2)``); ``style`` merged with kwargs."""
    poses = np.asarray(poses, dtype=float)
    opts = {**(style or {}), **kwargs}
    (line,) = ax.plot(poses[:, 0], poses[:, 1], **opts)
    return line

def plot_pose_errors(t, errors, sigmas=None, *, nsigma: float = 2.0, axes=None,
                     label: str = "error", color: str = "tab:blue", title: str | None = None):
    """Errors in x, y and theta against time, with the ``+-nsigma`` bands of the filter.

    Parameters
    ----------
    t : array_like (n,)
    errors : array_like (n, 3)
        Estimate minus truth (theta wrapped).
    sigmas : array_like (n, 3), optional
        Standard deviations from the covariance's diagonal.

    Returns
    -------
    (Figure, array of 3 Axes)
    """
    t = np.asarray(t, dtype=float)
    errors = np.asarray(errors, dtype=float)
    if axes is None:
        fig, axes = plt.subplots(3, 1, sharex=True, figsize=(6.4, 4.8), dpi=DPI)
    else:
        fig = axes[0].figure
    names = ["x error (m)", "y error (m)", "theta error (rad)"]
    for i, ax in enumerate(axes):
        ax.plot(t, errors[:, i], color=color, lw=1.0, label=label)
        if sigmas is not None:
            s = nsigma * np.asarray(sigmas, dtype=float)[:, i]
            ax.fill_between(t, -s, s, color="gold", alpha=0.35,
                            label=f"$\\pm{nsigma:g}\\sigma$")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(names[i], fontsize=8)
        ax.grid(True, lw=0.4, alpha=0.5)
    axes[-1].set_xlabel("t (s)")
    axes[0].legend(loc="upper left", fontsize=8)
    if title:
        axes[0].set_title(title)
    return fig, axes

def plot_trace(ax, trace, world=None, *, ellipse_every: float = 5.0, nsigma: float = 2.0,
               show_map: bool = True, title: str | None = None, legend_outside: bool = False,
               estimate_label: str = "estimate"):
    """Top view of a filter run: truth (red), estimate (blue), ``nsigma`` pose ellipses
    every ``ellipse_every`` seconds, the true markers (stars) and, for SLAM, the mapped
    landmarks (plus signs) with their ellipses. The report's Figs. 4, 5 and 7.

    Parameters
    ----------
    ax : matplotlib Axes
        Prepared with :func:`world_axes` (done here if it is not yet inverted).
    trace : slamlib.runner.Trace
    world : World, optional
        The true markers to draw.
    legend_outside : bool
        Put the legend to the right of the axes instead of inside.
    estimate_label : str
        The estimate's legend entry.
    """
    if not ax.yaxis_inverted():
        world_axes(ax, world)
    if world is not None:
        plot_world(ax, world, facing=False)
    plot_trajectory(ax, trace.truth, style=TRUTH_STYLE)
    plot_trajectory(ax, trace.x, style=ESTIMATE_STYLE, label=estimate_label)
    next_t = trace.t[0]
    first = True
    for k in range(trace.t.size):
        if trace.t[k] >= next_t:
            plot_covariance_ellipse(ax, trace.x[k], trace.P[k], nsigma,
                                    label=f"{nsigma:g}-sigma pose ellipse" if first else None)
            first = False
            next_t = trace.t[k] + ellipse_every
    lms = getattr(trace.filter, "landmarks", None)
    if show_map and lms and hasattr(trace.filter, "landmark_cov"):
        pts = np.array(list(lms.values()))
        ax.plot(pts[:, 0], pts[:, 1], "+", color="tab:blue", ms=10, mew=2,
                label="mapped landmarks", zorder=5)
        for i in lms:
            plot_covariance_ellipse(ax, lms[i], trace.filter.landmark_cov(i), nsigma,
                                    color="tab:blue", alpha=0.25)
    ax.plot(*trace.truth[0, :2], "o", color="k", ms=5, label="start")
    return finish_top_view(ax, title, legend_outside)

def plot_trace_errors(trace, *, nsigma: float = 2.0, axes=None, title: str | None = None):
    """x, y, theta errors of a filter run with its ``nsigma`` bands (the report's Figs. 6, 8)."""
    return plot_pose_errors(trace.t, trace.error, trace.sigma, nsigma=nsigma, axes=axes,
                            title=title)

def plot_error_comparison(traces, *, colors=("tab:red", "tab:blue", "tab:green", "tab:purple"),
                          marks=None, mark_label: str = "", axes=None,
                          position_ylim=(1e-3, 10.0)):
    """Position error (log scale) and heading error of several runs against time (chapter 05).

    Parameters
    ----------
    traces : dict name -> Trace
        One line per run (:mod:`slamlib.runner`).
    marks : array_like of float, optional
        Times to tick at the bottom of the position panel (e.g. misread readings).
    mark_label : str
        Legend label of the ticks.
    axes : two Axes (sharing x), optional

    Returns
    -------
    (Figure, axes)
    """
    if axes is None:
        fig, axes = plt.subplots(2, 1, sharex=True, figsize=(8, 4.8), dpi=DPI)
    fig = axes[0].figure
    for (name, tr), color in zip(traces.items(), colors):
        axes[0].semilogy(tr.t, np.hypot(tr.error[:, 0], tr.error[:, 1]), color=color, lw=1,
                         label=name)
        axes[1].plot(tr.t, np.degrees(tr.error[:, 2]), color=color, lw=1, label=name)
    lo, hi = position_ylim
    if marks is not None and len(marks):
        marks = np.asarray(marks, dtype=float)
        axes[0].plot(marks, np.full(marks.size, 2.0 * lo), "|", color="k", ms=8,
                     label=mark_label or None)
    axes[0].set_ylabel("position error (m)")
    axes[0].set_ylim(lo, hi)
    axes[1].set_ylabel("heading error (deg)")
    axes[1].set_xlabel("t (s)")
    axes[0].legend(fontsize=8, loc="upper left", ncol=3)
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
    return fig, axes


def finish_top_view(ax, title: str | None = None, legend_outside: bool = False):
    """A top view's legend (beside the axes, or inside where it fits best) and title; ``ax``."""
    if legend_outside:
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
    else:
        ax.legend(loc="best", fontsize=8)
    if title:
        ax.set_title(title)
    return ax
