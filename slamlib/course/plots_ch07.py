"""Chapter 07's figures: the coverage grid, a sketch of the return rule, a closed-loop
exploration seen from above and its history (coverage, landmarks, position error) against time.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np

from ..explore import Explorer, position_sigma
from .plots import DPI, finish_top_view, plot_robot, plot_trace, world_axes

__all__ = ["RETURN_STYLE", "CUT_OFF_STYLE", "plot_coverage", "plot_exploration",
           "plot_exploration_history", "unfinished_return", "ReturnSketch",
           "return_rule_sketch", "plot_return_rule"]


RETURN_STYLE = {"color": "tab:orange", "lw": 0, "marker": ".", "ms": 3,
                "label": "estimate while returning"}

#: The estimate during a return that the end of the run cut off (not in ``policy.returns``).
CUT_OFF_STYLE = {"color": "tab:orange", "lw": 9, "alpha": 0.3, "solid_capstyle": "round",
                 "label": "return cut off by the end (band)"}


def unfinished_return(policy):
    """``(t_start, anchor id)`` of a return started but not ended when the run stopped, or None.

    ``policy.returns`` records a return when it ends; one still under way at the end is
    only in the policy's final ``mode`` and in its ``goals`` (the last goal set in mode
    ``"return"`` is the start of that return).
    """
    if getattr(policy, "mode", None) != "return":
        return None
    starts = [g[0] for g in getattr(policy, "goals", []) if g[3] == "return"]
    if not starts:
        return None
    return float(starts[-1]), getattr(policy, "anchor", None)


# --------------------------------------------------------------------------- the rule's sketch
class _SketchFilter:
    """The five things of an EKFSLAM that ``Explorer.choose_anchor`` and a return read."""

    def __init__(self, pose, sigma_xy, landmarks):
        self.pose = np.asarray(pose, dtype=float)
        self.pose_cov = np.diag([sigma_xy ** 2 / 2, sigma_xy ** 2 / 2, 0.01])
        self._lm = {i: (np.asarray(p, dtype=float), s) for i, (p, s) in landmarks.items()}
        self.landmark_ids = list(self._lm)

    def landmark(self, i):
        return self._lm[i][0].copy()

    def landmark_cov(self, i):
        return np.eye(2) * self._lm[i][1] ** 2 / 2          # position sigma = s


@dataclass
class ReturnSketch:
    """A made-up scene and what :class:`slamlib.explore.Explorer` decides in it.

    ``landmarks``: id -> (position, position sigma, sighting angles in rad); ``sightings``:
    id -> unit vectors from the landmark towards the robot; ``anchor``, ``view`` and
    ``closer``: the rule's choice and its two goals, computed by ``Explorer`` itself.
    """

    explorer: Explorer
    pose: np.ndarray
    sigma_xy: float
    landmarks: dict
    sightings: dict
    anchor: int
    view: np.ndarray
    closer: np.ndarray
    notes: dict


def return_rule_sketch(explorer: Explorer | None = None) -> ReturnSketch:
    """Four landmarks around a robot whose ``sigma_xy`` just crossed ``sigma_return``.

    Landmark 2 is near but known too poorly (sigma above ``anchor_ratio * sigma_xy``),
    landmark 3 near but seen in too few frames, landmark 4 good but farther than landmark 1,
    the anchor. The anchor and the two goals come from ``Explorer.choose_anchor`` and the
    start of a return, run on a stand-in for the filter (no randomness).
    """
    ex = explorer if explorer is not None else Explorer(sigma_return=0.1)
    sigma = 1.2 * ex.sigma_return
    pose = np.array([5.0, 1.3, 0.4])
    n = ex.min_sightings
    deg = np.deg2rad
    landmarks = {   # id: position, its sigma, the angles it was seen from (landmark -> robot)
        1: ((1.6, 0.2), 0.25 * sigma, deg(np.linspace(-10.0, 80.0, n + 2))),
        2: ((3.5, -0.8), 0.75 * sigma, deg(np.linspace(60.0, 120.0, n + 4))),
        3: ((3.9, 2.6), 0.3 * sigma, deg(np.linspace(-60.0, -40.0, max(n // 3, 1)))),
        4: ((0.7, -1.7), 0.2 * sigma, deg(np.linspace(20.0, 70.0, 3 * n))),
    }
    notes = {2: "too uncertain:\n"
                + r"$\sigma_{\mathrm{landmark}}$ > anchor_ratio $\cdot\,\sigma_{xy}$",
             3: "seen in fewer than\nmin_sightings frames",
             4: "qualifies, but farther"}
    ex.reset(SimpleNamespace(bounds=(-1.0, 7.0, -3.0, 4.0)))
    ex.sightings = {i: [np.array([np.cos(a), np.sin(a)]) for a in v[2]]
                    for i, v in landmarks.items()}
    filt = _SketchFilter(pose, sigma, {i: v[:2] for i, v in landmarks.items()})
    if not ex._start_return(0.0, filt, sigma):
        raise RuntimeError("the sketch's scene has no anchor")
    view, closer = ex.ctl.waypoints
    return ReturnSketch(ex, pose, position_sigma(filt.pose_cov), landmarks,
                        {i: np.array(v) for i, v in ex.sightings.items()},
                        int(ex.anchor), view.copy(), closer.copy(), notes)


def plot_return_rule(ax=None, sketch: ReturnSketch | None = None):
    """Draw the return rule's geometry (chapter 07, section 3) on a top view; returns ``ax``.

    The robot with its ``sigma_xy`` circle; the filter's landmark estimates (blue plus signs,
    the course's sign for mapped landmarks) and the reason each but the anchor is passed
    over; the anchor's sightings (grey rays, landmark towards robot); the line of length
    ``return_distance`` along their mean direction to the ``view`` goal; the ``approach`` to
    the ``closer`` goal; the path of the return (orange, dotted). Artists carry a ``gid``
    (``"robot"``, ``"sigma_xy"``, ``"landmarks"``, ``"anchor"``, ``"sightings"``,
    ``"return_distance"``, ``"view"``, ``"closer"``, ``"path"``) so that tests can find them.
    """
    sk = sketch if sketch is not None else return_rule_sketch()
    if ax is None:
        _, ax = plt.subplots(figsize=(7.6, 5.0), dpi=DPI)
    world_axes(ax)
    ax.set_aspect("equal", adjustable="box")
    ex, a = sk.explorer, sk.landmarks[sk.anchor][0]
    a = np.asarray(a, dtype=float)
    # the robot and the uncertainty that triggered the return
    plot_robot(ax, sk.pose, size=0.2, gid="robot", zorder=4)
    circ = plt.Circle(sk.pose[:2], sk.sigma_xy, fill=False, ls="--", color="tab:blue",
                      gid="sigma_xy", lw=1.2, zorder=5,
                      label=r"$\sigma_{xy}$ of the robot (circle)")
    ax.add_patch(circ)
    ax.annotate(r"robot (estimate): $\sigma_{xy} > \sigma_{\mathrm{return}}$",
                sk.pose[:2], xytext=(sk.pose[0] - 0.9, sk.pose[1] - 0.75), fontsize=9,
                arrowprops={"arrowstyle": "-", "color": "0.4", "lw": 0.6})
    # the landmarks and why all but one are passed over
    # the filter's landmark estimates: blue plus signs, as the mapped landmarks everywhere in
    # the course (black stars are true markers)
    pts = np.array([p for p, _, _ in sk.landmarks.values()], dtype=float)
    ax.plot(pts[:, 0], pts[:, 1], "+", color="tab:blue", ms=12, mew=2, ls="none", zorder=5,
            gid="landmarks", label="landmarks (the filter's estimates)")
    for i, (p, _, _) in sk.landmarks.items():
        p = np.asarray(p, dtype=float)
        if i in sk.notes:
            ax.annotate(sk.notes[i], p, xytext=(p[0] + 0.2, p[1] - 0.2), fontsize=8.5,
                        color="0.3", va="bottom")
    # the sightings of the anchor and their mean direction
    rays = []
    for u in sk.sightings[sk.anchor]:
        rays += [a, a + 0.7 * u, [np.nan, np.nan]]
    rays = np.array(rays)
    ax.plot(rays[:, 0], rays[:, 1], color="0.6", lw=0.8, gid="sightings",
            label="sightings of the anchor (landmark to robot)")
    ax.plot(*a, "o", mfc="none", mec="tab:orange", ms=18, mew=1.5, gid="anchor", zorder=5)
    ax.annotate("anchor: the nearest that qualifies", a, xytext=(a[0] - 1.3, a[1] - 0.55),
                fontsize=9, color="tab:orange")
    ax.plot([a[0], sk.view[0]], [a[1], sk.view[1]], color="k", lw=1.2, gid="return_distance")
    mid = 0.5 * (a + sk.view)
    ax.annotate("return_distance\nalong the mean direction", mid,
                xytext=(mid[0] - 2.1, mid[1] + 1.0), fontsize=9,
                arrowprops={"arrowstyle": "-", "color": "0.4", "lw": 0.6})
    # the two goals and the path there
    ax.plot(*sk.view, "s", color="tab:orange", ms=7, gid="view", zorder=6)
    ax.plot(*sk.closer, "D", color="tab:orange", ms=6, mfc="white", gid="closer", zorder=6)
    ax.annotate("view", sk.view, xytext=(sk.view[0] + 0.15, sk.view[1] + 0.3), fontsize=9)
    ax.annotate("closer: approach\ntowards the anchor", sk.closer,
                xytext=(sk.closer[0] + 0.35, sk.closer[1] - 0.55), fontsize=9,
                arrowprops={"arrowstyle": "-", "color": "0.4", "lw": 0.6})
    path = np.array([sk.pose[:2], sk.view, sk.closer])
    ax.plot(path[:, 0], path[:, 1], ":", color="tab:orange", lw=1.6, gid="path",
            label="the return's path: to view, then closer")
    ax.set_xlim(-0.3, 7.3)
    ax.set_ylim(3.1, -2.5)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=8)  # below
    ax.set_title(f"the return rule (min_sightings = {ex.min_sightings}; "
                 "to scale)", fontsize=10)
    return ax

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
    returning to a landmark, under a light orange band during a return the end of
    the run cut off, :func:`unfinished_return`) with ``nsigma`` pose ellipses, the true markers
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
    cut = unfinished_return(pol)
    if cut is not None:
        ax.plot(tr.x[tr.t >= cut[0], 0], tr.x[tr.t >= cut[0], 1], zorder=1.5, gid="cut_off",
                **CUT_OFF_STYLE)
        if world is not None and cut[1] in set(world.ids.tolist()):
            ax.plot(*world.marker(cut[1]).position, "D", mfc="none", mec="tab:orange", ms=13,
                    mew=1.5, ls="none", label="anchor of the cut-off return", zorder=5)
    ax.plot(*tr.truth[-1, :2], "s", color="k", ms=5, label="end (truth)")
    return finish_top_view(ax, title, legend_outside)

def plot_exploration_history(exploration, *, nsigma: float = 2.0, axes=None,
                             title: str | None = None):
    """Coverage, mapped landmarks, the return rule's input and the position error against time.

    Four panels: coverage; landmarks mapped; ``sigma_xy = sqrt(P_xx + P_yy)`` (the filter's
    position uncertainty) with the return threshold, the two numbers the rule compares; the
    true position error with the filter's ``nsigma * sigma_xy``. The returns to a landmark
    are shaded; a return the end of the run cut off (:func:`unfinished_return`) is hatched.
    ``axes``: four axes to draw in (default: a new figure).

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
    cut = unfinished_return(exploration.policy)
    if cut is not None:              # started, not ended when the run stopped: hatched, paler
        for ax in axes:
            ax.axvspan(cut[0], exploration.trace.t[-1], facecolor="tab:orange", alpha=0.08,
                       edgecolor="tab:orange", hatch="///", lw=0, gid="cut_off",
                       label="return cut off by the end" if ax is axes[2] else None)
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
    axes[2].legend(fontsize=8, loc="upper left", ncol=3)
    axes[3].legend(fontsize=8, loc="upper left", ncol=2)
    if title:
        axes[0].set_title(title)
    if own:
        fig.tight_layout()
    return fig, axes
