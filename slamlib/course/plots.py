"""Figures of the 100-seed evidence (chapters 02, 03, 05): figure-only helpers."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from ..plotting import DPI

__all__ = ["plot_run_values", "plot_interval_rows", "plot_error_autocorrelation"]


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
    ax.hist(v, bins=edges, color=color, alpha=0.6, label=f"{v.size} seeded runs")
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
    ax.legend(fontsize=7)
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
    ax.set_xlabel(xlabel)
    ax.grid(True, axis="x", lw=0.4, alpha=0.5)
    ax.legend(fontsize=7, loc="lower right")
    return ax


def plot_error_autocorrelation(lags_s, corr, *, labels=("range", "bearing"), ax=None,
                               title: str | None = None):
    """Correlation of the normalised reading errors against the lag between frames (s)."""
    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 3.0), dpi=DPI)
    corr = np.asarray(corr, dtype=float)
    ax.axhline(0.0, color="k", lw=0.8)
    for j, (label, mk) in enumerate(zip(labels, ("o-", "s-"))):
        ax.plot(lags_s, corr[:, j], mk, ms=4, label=label)
    ax.set_xlabel("lag between the two frames (s)")
    ax.set_ylabel("correlation of the errors")
    ax.set_ylim(-0.1, 1.0)
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=9)
    return ax
