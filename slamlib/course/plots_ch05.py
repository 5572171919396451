"""Chapter 05's figures: where a wrong map entry is, the NEES of one run against many,
the Monte-Carlo NEES of several filters.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from .plots import DPI

__all__ = ["plot_map_errors", "plot_errors_against", "plot_nees_per_run", "plot_nees_monte_carlo"]


def plot_map_errors(ax, filt, world, *, threshold: float = 0.3, color: str = "tab:purple",
                    legend: bool = True):
    """Mark the wrong entries of an estimated map on a top view (chapter 05).

    A line joins each mapped landmark that lies more than ``threshold`` (m) from
    the true marker with the same id to that marker; an x marks each mapped id
    that is no marker of the world at all (a misread that made it into the map).

    Parameters
    ----------
    ax : Axes
        A top view (:func:`world_axes`).
    filt : EKFSLAM
        The filter (its ``landmarks`` dict).
    world : slamlib.worlds.World
        The true markers (``world.landmarks()``).
    legend : bool
        Put the legend beside the map (upper left, outside the axes).

    Returns
    -------
    (misplaced, spurious) : (list of int, list of int)
        The ids drawn with a line and with an x.
    """
    true = world.landmarks()
    misplaced, spurious = [], []
    for mid, p in filt.landmarks.items():
        if mid in true and np.hypot(*(p - true[mid])) > threshold:
            ax.plot([p[0], true[mid][0]], [p[1], true[mid][1]], "-", color=color, lw=1.2,
                    label=None if misplaced else "mapped id -> its true marker")
            misplaced.append(int(mid))
        elif mid not in true:
            ax.plot(*p, "x", color=color, ms=7, mew=1.5,
                    label=None if spurious else "id not in the world")
            spurious.append(int(mid))
    if legend:
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
    return misplaced, spurious

def plot_errors_against(trace, reference, *, label: str, reference_label: str,
                        band_label: str | None = None, nsigma: float = 2.0, axes=None,
                        title: str | None = None):
    """x, y, theta errors of one run with its ``nsigma`` bands, and another run's errors in grey.

    Shows what differs between two runs of the same drive without drawing the
    second run's figure again (chapter 05: the median run of a Monte-Carlo study
    against the recorded run, whose own bands are in an earlier figure).

    Parameters
    ----------
    trace : Trace
        The run drawn in full: its errors (blue) and its bands (gold).
    reference : Trace
        The run drawn for comparison: its errors only, as a thin grey line.
    label, reference_label : str
        Legend labels of the two runs.
    band_label : str, optional
        Legend label of the band (default ``+-nsigma sigma``): name its run when two are drawn.

    Returns
    -------
    (Figure, array of 3 Axes)
    """
    from .plots import plot_pose_errors

    if axes is None:
        fig, axes = plt.subplots(3, 1, sharex=True, figsize=(8, 5.4), dpi=DPI)
    fig = axes[0].figure
    for i, ax in enumerate(axes):
        ax.plot(reference.t, reference.error[:, i], color="0.55", lw=0.8,
                label=reference_label)
    plot_pose_errors(trace.t, trace.error, trace.sigma, nsigma=nsigma, axes=axes, label=label,
                     title=title)
    if band_label is not None:
        for ax in axes:
            ax.collections[-1].set_label(band_label)     # the band plot_pose_errors just drew
        axes[0].legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    return fig, axes


def plot_nees_per_run(study, single=None, *, axes=None, single_label: str = "the recorded run"):
    """Each run's time-averaged NEES, pose and heading, against the Monte-Carlo mean (chapter 05).

    One dot per run of ``study`` (:class:`slamlib.studies.NEESStudy`), sorted;
    a solid line at the mean over the runs, a dotted one at the value of a
    consistent filter (3 for the pose, 1 for the heading), and optionally the
    time averages of one more run (``single = (pose, heading)``) as a red line.

    Returns
    -------
    (Figure, axes)
    """
    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.2), dpi=DPI)
    fig = axes[0].figure
    n = study.n_runs
    for ax, heading, dof in ((axes[0], False, 3), (axes[1], True, 1)):
        means = np.sort(study.run_means(heading))
        ax.plot(np.arange(1, n + 1), means, "o", color="tab:blue", ms=5,
                label=f"one simulated run each (seeds {min(study.seeds)}-{max(study.seeds)})")
        ax.axhline(means.mean(), color="tab:blue", lw=1.2,
                   label=f"mean over the {n} runs: {means.mean():.2f}")
        ax.axhline(dof, color="k", lw=0.9, ls=":", label=f"consistent filter: {dof}")
        if single is not None:
            v = float(single[1 if heading else 0])
            ax.axhline(v, color="tab:red", lw=1.2, ls="--", label=f"{single_label}: {v:.2f}")
        ax.set_xlabel("run (sorted by its mean)")
        ax.set_ylabel("time-averaged NEES" + (" of the heading" if heading else " of the pose"))
        ax.set_title(f"{'heading' if heading else 'pose'} ({dof} dof)")
        top = max(means.max(), 0.0 if single is None else float(single[int(heading)]))
        ax.set_ylim(0, 1.7 * top)                       # room for the legend above the dots
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig, axes

def plot_nees_monte_carlo(studies, *, axes=None, prob: float = 0.95, title: str | None = None,
                          colors=("tab:blue", "tab:red", "tab:green", "tab:purple")):
    """The Monte-Carlo average NEES against time with its chi-square band (chapter 06).

    Left: the pose NEES (3 degrees of freedom) averaged over the runs; right: the
    heading's normalised error ``e_theta^2 / P_theta_theta`` (1 degree of
    freedom). The gold band is :func:`slamlib.metrics.chi2_band` ``(dof, N,
    prob)``, where the average of a consistent filter stays ``prob`` of the time.

    Parameters
    ----------
    studies : NEESStudy or sequence/dict of them (:mod:`slamlib.studies`)
        One curve each, labelled with its method; the band uses the first
        study's number of runs (all should have the same).
    axes : two Axes, optional

    Returns
    -------
    (Figure, axes)
    """
    from ..metrics import chi2_band

    if hasattr(studies, "values"):
        studies = list(studies.values())
    elif hasattr(studies, "average"):
        studies = [studies]
    studies = list(studies)
    if not studies:
        raise ValueError("studies: expected at least one NEESStudy")
    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(11, 3.6), dpi=DPI)
    fig = axes[0].figure
    n = studies[0].n_runs
    names = {"localization": "map-based EKF", "slam": "EKF SLAM", "fej": "FEJ EKF SLAM",
             "ideal": "ideal EKF SLAM", "ideal_init": "ideal EKF SLAM, landmarks at the truth"}
    for ax, heading, dof in ((axes[0], False, 3), (axes[1], True, 1)):
        lo, hi = chi2_band(dof, n, prob)
        t_all = np.concatenate([s.t for s in studies])
        ax.fill_between([t_all.min(), t_all.max()], lo, hi, color="gold", alpha=0.45, lw=0,
                        label=f"{100 * prob:g}% band of the average of {n} runs")
        ax.axhline(dof, color="k", lw=0.8, ls=":")
        for s, c in zip(studies, colors):
            avg = s.average(heading)
            inside = np.mean((avg > lo) & (avg < hi))
            ax.plot(s.t, avg, color=c, lw=1.2,
                    label=f"{names.get(s.method, s.method)}: mean {avg.mean():.2f}, "
                          f"{inside:.0%} inside")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("average NEES" + (" of the heading" if heading else " of the pose"))
        ax.set_title(f"{'heading' if heading else 'pose'} ({dof} dof), {n} runs")
        ax.set_ylim(0, max(2.2 * hi, 1.1 * max(float(np.max(s.average(heading)))
                                               for s in studies)))
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.legend(fontsize=8, loc="upper left")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig, axes
