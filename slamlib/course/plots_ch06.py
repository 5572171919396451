"""Chapter 06's figures: average NEES curves against their band, the marker-density sweep, the
loop closure's D^2 against the NEES before it.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import FuncFormatter, Locator, LogLocator, NullFormatter

from .plots import DPI

__all__ = ["plot_nees_averages", "plot_density_sweep", "plot_closure_against_nees",
           "keep_ids_clear"]


class _PlainLogLocator(Locator):
    """Major ticks of a log axis, as many as its range can carry: powers of ten alone over
    more than three decades, 1-2-5 over one to three, finer steps inside one decade (a
    log axis from 2.5 to 3.6 would otherwise carry one label or none)."""

    STEPS = ((3.0, (1.0,)), (1.2, (1.0, 2.0, 5.0)), (0.5, (1.0, 1.5, 2.0, 3.0, 5.0, 7.0)),
             (0.25, (1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0)),
             (-1.0, (1.0, 1.1, 1.2, 1.4, 1.6, 1.8, 2.0, 2.25, 2.5, 2.75, 3.0, 3.5, 4.0, 4.5, 5.0,
                     6.0, 7.0, 8.0, 9.0)))

    def __call__(self):
        return self.tick_values(*self.axis.get_view_interval())

    def tick_values(self, vmin, vmax):
        lo, hi = sorted((float(vmin), float(vmax)))
        if not (np.isfinite(lo) and np.isfinite(hi)) or lo <= 0.0:
            return LogLocator().tick_values(vmin, vmax)
        decades = np.log10(hi / lo)
        subs = next(s for d, s in self.STEPS if decades > d)
        powers = range(int(np.floor(np.log10(lo))), int(np.ceil(np.log10(hi))) + 1)
        ticks = [m * 10.0 ** e for e in powers for m in subs]
        return np.array([v for v in ticks if lo * (1 - 1e-9) <= v <= hi * (1 + 1e-9)])


def _plain_log_ticks(ax, axis: str = "y") -> None:
    """Log-axis ticks written as plain numbers (``2``, not ``2 x 10^0``), as many as the
    range can carry (:class:`_PlainLogLocator`), and no labels on the minor ticks."""
    target = ax.yaxis if axis == "y" else ax.xaxis
    target.set_major_locator(_PlainLogLocator())
    target.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    target.set_minor_formatter(NullFormatter())


def plot_nees_averages(curves, n_runs: int, *, axes=None, prob: float = 0.95,
                       title: str | None = None,
                       colors=("tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange"),
                       events=(), legend: str = "inside"):
    """Monte-Carlo average NEES curves against their band (chapter 06, stored studies).

    Parameters
    ----------
    curves : dict label -> (t, average pose NEES, average heading NEES)
        One curve per filter (arrays of the same length T), e.g. from
        :func:`slamlib.course.studies_ch06.summarise`'s ``t``, ``avg``, ``avg_heading``.
    n_runs : int
        Runs in each average (the band is :func:`slamlib.metrics.chi2_band`
        ``(dof, n_runs, prob)``, valid at each instant).
    axes : two Axes, optional
    events : sequence of (t, label)
        Instants marked by a vertical line on both panels, labelled above the left one.
    legend : {"inside", "below", "none"}
        One legend in the left panel, one under both panels (for many curves or long
        labels: three columns, two if a label is long), or none (the caller draws one).

    Returns
    -------
    (Figure, axes)
    """
    from ..metrics import chi2_band

    if legend not in ("inside", "below", "none"):
        raise ValueError(f"legend: expected 'inside', 'below' or 'none', got {legend!r}")
    ncol = 3 if max(len(str(label)) for label in curves) <= 40 else 2
    if axes is None:                      # room for a legend below: 0.2 in per row
        below = 0.2 * -(-(len(curves) + 1) // ncol) if legend == "below" else 0.0
        fig, axes = plt.subplots(1, 2, figsize=(11, 3.4 + below), dpi=DPI)
    fig = axes[0].figure
    for ax, k, dof, name in ((axes[0], 1, 3, "pose NEES"), (axes[1], 2, 1, "heading NEES")):
        lo, hi = chi2_band(dof, n_runs, prob)
        t_all = np.concatenate([np.asarray(c[0]) for c in curves.values()])
        ax.fill_between([t_all.min(), t_all.max()], lo, hi, color="gold", alpha=0.45, lw=0,
                        label=f"{100 * prob:g}% band, average of {n_runs} runs")
        ax.axhline(dof, color="k", lw=0.8, ls=":")
        for (label, c), col in zip(curves.items(), colors):
            ax.plot(c[0], c[k], color=col, lw=1.2, label=label)
        ax.set_yscale("log")
        _plain_log_ticks(ax)
        for j, (t, text) in enumerate(events):
            ax.axvline(t, color="0.35", lw=0.9, ls="--")
            if ax is axes[0]:             # above the axes: the first label ends at its line,
                tag = f"{text} \u2192" if j == 0 else f"\u2190 {text}"   # later ones start there
                ax.annotate(tag,
                            (t, 1.0), xycoords=("data", "axes fraction"), xytext=(0, 2),
                            textcoords="offset points", ha="right" if j == 0 else "left",
                            va="bottom", fontsize=8, color="0.25")
        ax.set_xlabel("t (s)")
        ax.set_ylabel(f"average {name}")
        ax.grid(True, lw=0.4, alpha=0.5, which="both")
    if legend == "inside":
        axes[0].legend(fontsize=8, loc="upper left")
    if title:
        fig.suptitle(title, fontsize=10)
    if legend == "below":                 # the legend's rows under the axes, the axes above them
        handles, labels = axes[0].get_legend_handles_labels()
        rows = -(-len(labels) // ncol)
        height = (0.05 + 0.2 * rows) / fig.get_figheight()
        fig.legend(handles, labels, loc="lower center", ncol=ncol, fontsize=8, frameon=False)
        fig.tight_layout(rect=(0.0, height, 1.0, 1.0))
    else:
        fig.tight_layout()
    return fig, axes


def plot_density_sweep(rows, counts):
    """The marker-density sweep (:func:`slamlib.course.studies_ch06.density_sweep`): ATE,
    final position error and map RMSE against the number of markers, one dot per run (spread
    a little sideways) and the median, on log-log axes. Returns the figure."""
    def column(name, n):
        return np.array([getattr(r, name) for r in rows if r.count == n], dtype=float)

    fig, axes = plt.subplots(1, 3, figsize=(11, 3.4))
    for ax, name, label in zip(axes, ("ate", "final_error", "map_rmse"),
                               ("ATE (m)", "final position error (m)", "map RMSE (m)")):
        for j, n in enumerate(counts):
            v = column(name, n)
            ax.plot(np.full(v.size, n) * np.exp(np.linspace(-0.08, 0.08, v.size)), v, "o",
                    color="tab:blue", ms=4, alpha=0.7, label="one run" if j == 0 else None)
        ax.plot(counts, [np.nanmedian(column(name, n)) for n in counts], "k-", lw=1.5,
                label="median")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        _plain_log_ticks(ax)
        ax.set_xticks(counts, [str(n) for n in counts])
        ax.set_xlabel("markers in the world")
        ax.set_ylabel(label)
        ax.grid(True, lw=0.4, alpha=0.5, which="both")
    axes[0].legend(fontsize=8)
    plt.tight_layout()
    return fig


def plot_closure_against_nees(stored: dict, settings):
    """The loop closure's ``D^2`` against the pose NEES just before it, one dot per stored run
    of EKF SLAM (:func:`slamlib.course.studies_ch06.load_ch06_studies`), filled when the gate
    accepted it; ``settings`` are ``(study key, colour, label)``. Returns the figure."""
    from scipy.stats import chi2

    fig, ax = plt.subplots(figsize=(7.5, 4.9))
    for key, color, label in settings:
        runs = stored["studies"][key]["methods"]["slam"]["runs"]
        nb = np.array([r["nees_before_closure"] for r in runs], dtype=float)
        d2 = np.array([r["closure_d2"] for r in runs], dtype=float)
        acc = np.array([r["closure_status"] == "accepted" for r in runs])
        ax.scatter(nb[acc], d2[acc], s=14, color=color, label=f"{label}: accepted")
        ax.scatter(nb[~acc], d2[~acc], s=18, facecolors="none", edgecolors=color,
                   label=f"{label}: rejected")
    ax.axhline(chi2.ppf(0.95, 2), color="k", ls="--", lw=1, label="gate 5.99")
    ax.axvline(chi2.ppf(0.95, 3), color="k", ls=":", lw=1,
               label="pose NEES 7.81 (95 % of chi2(3))")
    ax.set_xscale("log")
    ax.set_yscale("log")
    _plain_log_ticks(ax, "x")
    _plain_log_ticks(ax, "y")
    ax.set_xlabel("pose NEES just before the loop-closure reading")
    ax.set_ylabel("D^2 of the loop-closure reading")
    ax.set_title("EKF SLAM, 100 seeds per setting: a rejection comes with an overconfident "
                 "filter", fontsize=9)
    ax.grid(True, lw=0.4, alpha=0.5, which="both")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2,
              frameon=False)                  # under the axes: no dot hidden
    plt.tight_layout()
    return fig


def _crowding(offset, dirs) -> float:
    """How much a label's corner ``offset`` points towards the directions ``dirs``."""
    v = np.array(offset, dtype=float) / np.hypot(*offset)
    return sum(float(v @ d) for d in dirs)


def keep_ids_clear(ax, world, landmarks, radius: float = 0.45):
    """Move a marker's id (written by :func:`plots.plot_world`, up and to the right of its star)
    to the corner of its star farthest from any mapped landmark (``landmarks``: id -> (x, y),
    drawn as a plus sign) or other star within ``radius`` (m), so that a landmark mapped
    close to its marker does not cover the id. Ids with nothing that close stay where they are."""
    stars = {int(m.id): np.array([m.x, m.y], dtype=float) for m in world.markers}
    others = [np.asarray(v, dtype=float)[:2] for v in landmarks.values()] + list(stars.values())
    flip = -1.0 if ax.yaxis_inverted() else 1.0            # data y -> screen y
    corners = (((4, 4), "left", "bottom"), ((-4, 4), "right", "bottom"),
               ((4, -4), "left", "top"), ((-4, -4), "right", "top"))
    for text in ax.texts:
        try:
            pos = stars[int(text.get_text())]
        except (KeyError, ValueError):
            continue
        if not np.allclose(getattr(text, "xy", (np.nan, np.nan)), pos):
            continue
        near = [o - pos for o in others if 0.0 < np.hypot(*(o - pos)) < radius]
        if not near:
            continue
        dirs = [np.array([d[0], flip * d[1]]) / np.hypot(*d) for d in near]

        offset, ha, va = min(corners, key=lambda c, dirs=dirs: _crowding(c[0], dirs))
        text.set_position(offset)
        text.set_ha(ha)
        text.set_va(va)
    return ax
