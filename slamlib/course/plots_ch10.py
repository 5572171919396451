"""Chapter 10's figures: the MRCLAM robots' paths, yaw rates, reading residuals, SLAM runs.
"""

from __future__ import annotations

import numpy as np

from . import plots

__all__ = ["plot_paths", "plot_yaw_rates", "plot_whiteness", "plot_reading_residuals",
           "plot_slam_comparison", "plot_heldout"]


def plot_paths(ax, logs, world, ids: bool = False):
    """The robots' Vicon paths and the landmarks, seen from above (z-down); ``ids`` labels
    each landmark with its barcode (they crowd where landmarks stand in groups)."""

    plots.world_axes(ax)
    pts = np.vstack([world.positions] + [lg.truth[:, :2] for lg in logs.values()])
    lo, hi = pts.min(axis=0) - 0.3, pts.max(axis=0) + 0.3
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(hi[1], lo[1])                  # y downwards: z-down seen from above
    for r, lg in logs.items():
        ax.plot(lg.truth[:, 0], lg.truth[:, 1], lw=0.9, label=f"robot {r}")
        ax.plot(*lg.start_pose[:2], "o", color=ax.lines[-1].get_color(), ms=5)
    pos = world.positions
    ax.plot(pos[:, 0], pos[:, 1], "ks", ms=5, label="landmarks")
    if ids:
        for i, p in world.landmarks().items():
            ax.annotate(str(i), p, xytext=(3, 3), textcoords="offset points", fontsize=7)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return ax

def plot_yaw_rates(ax, log, cal, span: float = 40.0, start: float = 20.0,
                   legend: str = "best"):
    """Vicon's yaw rate against the logged command and the corrected one (z-down);
    ``cal`` an :class:`~slamlib.datasets.identify.CommandFit`."""
    from ..datasets import identify

    raw = identify.odometry_windows(log, window=0.25)
    fit = identify.odometry_windows(log, window=0.25, delay=cal.delay)
    t = raw.t - log.enc_t[0]
    m = (t >= start) & (t <= start + span)
    ax.plot(t[m], raw.w_true[m], "k", lw=1.4, label="Vicon")
    ax.plot(t[m], raw.w_cmd[m], color="tab:red", lw=1, label="command as logged")
    tf = fit.t - log.enc_t[0]
    mf = (tf >= start) & (tf <= start + span)
    ax.plot(tf[mf], cal.scale_w * fit.w_cmd[mf], color="tab:blue", lw=1,
            label=f"command x {cal.scale_w:.3f}, {cal.delay:.2f} s later")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("yaw rate, z-down (rad/s)")
    ax.legend(fontsize=9, loc=legend)
    ax.grid(True, lw=0.4, alpha=0.5)
    return ax

def plot_whiteness(ax, white, q_textbook=None):
    """The density ``q(T) = T mean(r^2)`` of the window residuals against the window ``T``,
    each relative to its value at 1 s: flat for white noise (log-log axes)."""
    T = white.windows
    k = int(np.argmin(np.abs(T - 1.0)))
    for q, c, name in ((white.q_w, "tab:blue", "yaw rate"), (white.q_v, "tab:red",
                                                             "forward speed")):
        ax.plot(T, q / q[k], "o-", color=c, lw=1.2, ms=4, label=name)
    ax.axhline(1.0, color="k", lw=0.8, ls="--", label="white noise (flat)")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log", base=2)
    ax.set_xticks(T)
    ax.set_xticklabels([f"{t:g}" for t in T])
    ax.set_xlabel("window T (s)")
    ax.set_ylabel("q(T) / q(1 s)")
    ax.grid(True, which="both", lw=0.4, alpha=0.5)
    ax.legend(fontsize=9)
    return ax

def plot_heldout(ax, study, variant, reference="textbook", splits=None,
                 markers=("o", "s", "^", "D")):
    """Each held-out run (robot and split) as a dot: ``reference``'s ATE across, ``variant``'s
    up (log axes); below the diagonal ``variant`` did better."""
    from matplotlib.ticker import FixedLocator, NullFormatter, ScalarFormatter

    splits = splits or study.splits
    names = {"robots_excerpt": "robots, excerpt", "halves": "halves",
             "excerpt_rest": "excerpt -> rest", "robots": "robots, full"}
    lo, hi = np.inf, 0.0
    for s, m in zip(splits, markers):
        a, b = study.ate(s, reference), study.ate(s, variant)
        ax.plot(a, b, m, ms=6, mfc="none", mew=1.3, label=names.get(s, s.replace("_", " ")))
        lo, hi = min(lo, a.min(), b.min()), max(hi, a.max(), b.max())
    lim = (0.8 * lo, 1.25 * hi)
    ax.plot(lim, lim, "k", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(lim)
    ax.set_ylim(lim)
    ticks = [t for t in (0.1, 0.2, 0.3, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0) if lim[0] <= t <= lim[1]]
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(FixedLocator(ticks))
        axis.set_major_formatter(ScalarFormatter())
        axis.set_minor_formatter(NullFormatter())
    ax.set_aspect("equal")
    ax.set_xlabel(f"ATE with {reference} (m)")
    ax.set_ylabel(f"ATE with {variant} (m)")
    ax.grid(True, which="both", lw=0.4, alpha=0.5)
    ax.legend(fontsize=9, title="held-out split", title_fontsize=9)
    return ax

def plot_reading_residuals(axes, res, fit, textbook=(0.15, 0.03)):
    """Range residual against range with the fitted 2-sigma law, and the bearing residuals."""
    a0, a1 = axes
    ok = ~fit.outlier
    a0.plot(res.rho[ok], res.e_rho[ok], ".", ms=1.5, alpha=0.35, color="tab:blue",
            label="inliers")
    a0.plot(res.rho[~ok], res.e_rho[~ok], "x", ms=3, color="tab:red",
            label="outliers (range or bearing)")
    r = np.linspace(0.0, 8.0, 50)
    a0.plot(r, 2 * fit.sigma_range(r), "k", lw=1.2, label="identified $\\pm 2\\sigma(\\rho)$")
    a0.plot(r, -2 * fit.sigma_range(r), "k", lw=1.2)
    a0.axhline(2 * textbook[0], color="tab:orange", ls="--", lw=1.2,
               label=f"textbook $\\pm 2 \\times$ {textbook[0]} m")
    a0.axhline(-2 * textbook[0], color="tab:orange", ls="--", lw=1.2)
    mids = 0.5 * (fit.bins[1:] + fit.bins[:-1])
    a0.plot(mids, fit.bin_bias, "D", color="tab:green", ms=4, label="bin mean (bias)")
    a0.set_ylim(-1.2, 1.2)
    a0.set_xlabel("true range (m)")
    a0.set_ylabel("range residual (m)")
    a0.legend(fontsize=8, loc="lower left")
    a0.grid(True, lw=0.4, alpha=0.5)
    lim = max(0.15, float(np.max(np.abs(res.e_bearing))) * 1.05)
    edges = np.linspace(-lim, lim, 121)
    counts, _, _ = a1.hist(res.e_bearing, bins=edges, color="tab:blue", alpha=0.7,
                           label="all readings")
    g = np.linspace(-lim, lim, 801)
    dens = ok.sum() * (edges[1] - edges[0]) / (fit.sigma_bearing * np.sqrt(2 * np.pi)) * \
        np.exp(-0.5 * (g / fit.sigma_bearing) ** 2)
    keep = dens > 0.1
    a1.plot(g[keep], dens[keep], "k", lw=1,
            label=f"Gaussian, $\\sigma$ = {fit.sigma_bearing:.4f} rad")
    a1.axvline(2 * textbook[1], color="tab:orange", ls="--", lw=1.2,
               label=f"textbook $\\pm 2 \\times$ {textbook[1]} rad")
    a1.axvline(-2 * textbook[1], color="tab:orange", ls="--", lw=1.2)
    a1.set_yscale("log")
    a1.set_ylim(0.5, 3.0 * float(np.max(counts)))
    a1.set_xlabel("bearing residual (rad)")
    a1.set_ylabel("readings per bin")
    a1.legend(fontsize=8)
    return axes

def plot_slam_comparison(axes, log, traces, colors=("tab:red", "tab:blue"), legend_ax=None):
    """Top view of Vicon and SLAM estimates (squares: surveyed landmarks, +: each filter's
    mapped ones), and the position error against time with each filter's own 2 sigma.

    ``legend_ax``: an axes (turned off) to hold the top view's legend, e.g. the cell below
    the top view when the error plot spans both rows; without it the legend hangs below
    the top view."""

    a0, a1 = axes
    plots.world_axes(a0, log.world(), margin=0.2)
    a0.plot(log.truth[:, 0], log.truth[:, 1], "k", lw=1.6, label="Vicon")
    pos = log.world().positions
    a0.plot(pos[:, 0], pos[:, 1], "ks", ms=4, label="landmarks (surveyed)")
    for (name, tr), c in zip(traces.items(), colors):
        a0.plot(tr.x[:, 0], tr.x[:, 1], color=c, lw=1, label=name)
        lm = tr.filter.landmarks
        if lm:
            p = np.array(list(lm.values()))
            a0.plot(p[:, 0], p[:, 1], "+", color=c, ms=8, mew=1.5,
                    label=f"landmarks mapped, {name}")
        e = np.hypot(*tr.error[:, :2].T)
        a1.plot(tr.t - tr.t[0], e, color=c, lw=1, label=f"{name}: error")
        a1.plot(tr.t - tr.t[0], 2 * np.sqrt(tr.P[:, 0, 0] + tr.P[:, 1, 1]), color=c, lw=1.0,
                ls=":", label=f"{name}: its own 2 sigma")
    # limits from the world, Vicon's path and the filters' paths together: no path is cut off
    paths = np.vstack([log.truth[:, :2]] + [tr.x[:, :2] for tr in traces.values()])
    xmin, xmax, ymin, ymax = log.world().bounds
    m = 0.2
    xmin, xmax = min(xmin, paths[:, 0].min()) - m, max(xmax, paths[:, 0].max()) + m
    ymin, ymax = min(ymin, paths[:, 1].min()) - m, max(ymax, paths[:, 1].max()) + m
    a0.set_xlim(xmin, xmax)
    a0.set_ylim(ymax, ymin)                      # y downwards, as world_axes sets it
    if legend_ax is None:
        a0.legend(fontsize=8, loc="upper left", bbox_to_anchor=(0.0, -0.1), ncol=2)
    else:
        legend_ax.axis("off")
        legend_ax.legend(*a0.get_legend_handles_labels(), fontsize=8, loc="upper center")
    a1.set_xlabel("time (s)")
    a1.set_ylabel("position error (m)")
    a1.legend(fontsize=8)
    a1.grid(True, lw=0.4, alpha=0.5)
    return axes
