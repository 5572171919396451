"""Chapter 06's figures: average NEES curves against their band, the marker-density sweep, the
loop closure's D^2 against the NEES before it.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from .plots import DPI

__all__ = ["plot_nees_averages", "plot_density_sweep", "plot_closure_against_nees"]


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
    axes[0].legend(fontsize=8, loc="upper left")
    if title:
        fig.suptitle(title, fontsize=10)
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

    fig, ax = plt.subplots(figsize=(7.5, 4.0))
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
    ax.set_xlabel("pose NEES just before the loop-closure reading")
    ax.set_ylabel("D^2 of the loop-closure reading")
    ax.set_title("EKF SLAM, 100 seeds per setting: a rejection comes with an overconfident "
                 "filter", fontsize=9)
    ax.grid(True, lw=0.4, alpha=0.5, which="both")
    ax.legend(fontsize=8, loc="upper left")
    plt.tight_layout()
    return fig
