"""Chapter 06's figure: average NEES curves over Monte-Carlo runs against their band.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from .plots import DPI

__all__ = ["plot_nees_averages"]


def plot_nees_averages(curves, n_runs: int, *, axes=None, prob: float = 0.95,
                       title: str | None = None,
                       colors=("tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange")):
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

    Returns
    -------
    (Figure, axes)
    """
    from ..metrics import chi2_band

    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(11, 3.4), dpi=DPI)
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
        ax.set_xlabel("t (s)")
        ax.set_ylabel(f"average {name}")
        ax.grid(True, lw=0.4, alpha=0.5, which="both")
    axes[0].legend(fontsize=7, loc="upper left")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig, axes
