"""Chapter 03's figures: NIS and NEES against chi-square bands, a zoomed top view, the d^2
histogram against its chi-square density, the 100-seed evidence of the chapter.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from ..metrics import chi2_band
from .plots import plot_trace, world_axes

__all__ = ["plot_chi2_series", "plot_trace_zoom", "plot_d2_histogram",
           "plot_run_values", "plot_interval_rows"]


def plot_chi2_series(ax, t, values, dof, *, prob: float = 0.95, per_dof: bool = False,
                     label: str = "value", color: str = "tab:blue", ms: float = 3.0,
                     band_label: str | None = None) -> float:
    """Chi-square distributed values (NIS, NEES, d2) against time, with the ``prob`` band.

    Each value is one sample of a chi-square with its ``dof`` (a scalar or one
    per value). The band of a single sample (:func:`slamlib.metrics.chi2_band`) is
    drawn in gold, values outside it in red; with ``per_dof`` the values and
    the band are divided by ``dof`` (so that updates with different numbers of
    readings share one axis). The y axis is logarithmic.

    Returns
    -------
    float
        The fraction of the values outside the band (``1 - prob`` expected for
        independent samples of a consistent filter).
    """
    t = np.asarray(t, dtype=float)
    v = np.asarray(values, dtype=float)
    d = np.broadcast_to(np.asarray(dof, dtype=float), v.shape)
    if t.shape != v.shape:
        raise ValueError(f"t, values: expected equal shapes, got {t.shape} and {v.shape}")
    lo, hi = chi2_band(d, 1, prob)
    scale = d if per_dof else np.ones_like(d)
    out = (v < lo) | (v > hi)
    ax.fill_between(t, lo / scale, hi / scale, step="mid", color="gold", alpha=0.45, lw=0,
                    label=band_label or f"{100 * prob:g}% band of one sample")
    ax.plot(t[~out], v[~out] / scale[~out], ".", ms=ms, color=color, label=label)
    ax.plot(t[out], v[out] / scale[out], ".", ms=ms + 1, color="tab:red",
            label=f"outside ({np.mean(out):.1%})")
    ax.set_yscale("log")
    ax.grid(True, lw=0.4, alpha=0.5)
    return float(np.mean(out)) if v.size else float("nan")

def plot_trace_zoom(ax, az, trace, box, *, ellipse_every: float = 0.5,
                    title: str | None = None):
    """A zoomed top view of a filter run next to the whole one (chapter 03, Fig. 5).

    Draws the zoom area ``box = (x_from, x_to, y_from, y_to)`` (m) as a dashed
    rectangle on ``ax`` (a top view already drawn, e.g. with :func:`plot_trace`)
    and the run on ``az`` limited to that box, with pose ellipses every
    ``ellipse_every`` seconds, y down and no legend (the big view has it).
    """
    x0, x1, y0, y1 = box
    ax.add_patch(plt.Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ls="--", lw=0.8,
                               color="k"))
    world_axes(az, title=title or f"zoom (dashed box): ellipses every {ellipse_every:g} s")
    plot_trace(az, trace, ellipse_every=ellipse_every)
    az.set_aspect("equal", adjustable="box")
    az.set_xlim(x0, x1)
    az.set_ylim(y1, y0)                                # y down
    legend = az.get_legend()
    if legend is not None:
        legend.remove()
    return az

def plot_d2_histogram(ax, d2, *, dof: int = 2, threshold: float | None = None,
                      clip: float = 20.0, n_bins: int = 40, color: str = "tab:blue",
                      label: str = "d² of the readings"):
    """Histogram of squared Mahalanobis distances against the chi-square density (chapter 03).

    Values at or above ``clip`` are counted in the last bin (so an over-confident
    filter's tail stays visible); ``threshold`` draws the gate as a dashed line.
    NaN values (readings that were not gated) are ignored.

    Returns
    -------
    float
        The fraction of the values at or above ``clip`` (the last bin's overflow).
    """
    from scipy.stats import chi2

    d2 = np.asarray(d2, dtype=float)
    d2 = d2[np.isfinite(d2)]
    bins = np.linspace(0.0, clip, n_bins + 1)
    ax.hist(np.minimum(d2, np.nextafter(clip, 0.0)), bins=bins, density=True, color=color,
            alpha=0.6, label=label)
    s = np.linspace(0.01, clip, 300)
    ax.plot(s, chi2.pdf(s, dof), "k", lw=1.2, label=f"chi-square, {dof} dof")
    if threshold is not None and np.isfinite(threshold):
        ax.axvline(threshold, color="k", ls="--", lw=0.8, label=f"gate {threshold:.2f}")
    ax.set_xlabel(f"d² (last bin: {clip:g} and above)")
    ax.set_ylabel("density")
    ax.legend(fontsize=9)
    return float(np.mean(d2 >= clip)) if d2.size else float("nan")

def plot_run_values(ax, values, *, expected: float | None = None, marks: dict | None = None,
                    xlabel: str = "", bins: int = 30, log: bool = False, color="tab:blue"):
    """Histogram of one number per seeded run, with the runs of ``marks`` as labelled lines.

    ``marks`` maps a label (e.g. "the recorded run") to its value; each line's
    label also gives how many runs are at or above it. ``expected``: a dotted
    line at the value of a consistent filter.
    """
    v = np.asarray(values, dtype=float)
    edges = (np.geomspace(v.min(), v.max(), bins + 1) if log
             else np.linspace(v.min(), v.max(), bins + 1))
    counts, _, _ = ax.hist(v, bins=edges, color=color, alpha=0.6, label=f"{v.size} seeded runs")
    ax.set_ylim(0, 1.7 * counts.max())                  # room for the legend above the bars
    if log:
        ax.set_xscale("log")
    if expected is not None:
        ax.axvline(expected, color="k", ls=":", lw=1.0, label=f"consistent filter: {expected:g}")
    for (label, x), c in zip((marks or {}).items(), ("tab:red", "tab:green", "tab:purple")):
        k = int(np.sum(v >= x))
        ax.axvline(x, color=c, lw=1.5, ls="--",
                   label=f"{label}: {x:.2f} ({k} of {v.size} runs at or above)")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("runs")
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(fontsize=9)
    return ax

def plot_interval_rows(ax, names, means, halfwidths, *, expected: float | None = None,
                       band=None, xlabel: str = "mean NEES", color="tab:blue"):
    """One row per filter: its mean with a +-interval, against a consistent filter's value.

    ``band`` = (lo, hi): the range where a consistent filter's mean falls (grey).
    """
    y = np.arange(len(names))[::-1]
    if band is not None:
        ax.axvspan(band[0], band[1], color="0.85", lw=0, label="95 % band of a consistent filter")
    if expected is not None:
        ax.axvline(expected, color="k", ls=":", lw=1.0)
    ax.errorbar(means, y, xerr=halfwidths, fmt="o", color=color, capsize=3,
                label="mean over the runs, 95 % interval")
    ax.set_yticks(y, names)
    ax.set_ylim(-1.3, len(names) - 0.5)                 # room for the legend below the rows
    ax.set_xlabel(xlabel)
    ax.grid(True, axis="x", lw=0.4, alpha=0.5)
    ax.legend(fontsize=9, loc="lower right")
    return ax
