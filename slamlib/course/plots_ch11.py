"""Chapter 11's figures: the factor graph of a short run, sparsity, NEES over seeds, cost.

Top views follow :mod:`slamlib.course.plots` (z-down seen from above: y downwards).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from .plots import DPI, plot_world, world_axes

__all__ = ["plot_factor_graph", "plot_sparsity", "plot_nees_study", "plot_cost_per_step",
           "plot_errors_at", "plot_error_and_sigma"]

_POSE = {"color": "tab:blue"}
_LM = {"color": "tab:purple"}
_FACTOR = {"color": "k"}


def plot_factor_graph(ax, trace, world=None, *, title: str | None = None):
    """Draw the factor graph of a (short) smoothed run over the world.

    Pose variables (blue circles, at their estimates), landmark variables
    (purple squares), and each factor as a small black square on the line it
    joins: the prior (on x0 only), the odometry factors (x_i to x_i+1), and the
    range-bearing factors (pose to landmark, thin grey).
    """
    if not ax.yaxis_inverted():
        world_axes(ax, world)
    X = trace.x
    L = trace.landmarks
    if world is not None:
        # a mapped marker is named once, by its landmark variable's label (l41 is marker 41):
        # its grey id would sit on the square and the factor lines beside it
        plot_world(ax, world, facing=False, color="0.6", label="markers (truth)",
                   skip_ids=set(L))
    first = True
    for k, (ids, _, _) in enumerate(trace.problem.readings):
        for m in ids:
            p = L[int(m)]
            ax.plot([X[k, 0], p[0]], [X[k, 1], p[1]], "-", color="0.7", lw=0.6, zorder=1)
            mid = 0.5 * (X[k, :2] + p)
            ax.plot(*mid, "s", ms=2.5, zorder=3, label="range-bearing factor" if first else None,
                    **_FACTOR, alpha=0.6)
            first = False
    ax.plot(X[:, 0], X[:, 1], "-", lw=1.0, zorder=2, **_POSE)
    mids = 0.5 * (X[1:, :2] + X[:-1, :2])
    ax.plot(mids[:, 0], mids[:, 1], "s", ms=3.5, zorder=4, label="odometry factor", **_FACTOR)
    ax.plot(X[0, 0] - 0.12, X[0, 1], "s", ms=5, mfc="w", mec="k", zorder=4, label="prior factor")
    ax.plot([X[0, 0] - 0.12, X[0, 0]], [X[0, 1], X[0, 1]], "k-", lw=0.8, zorder=3)
    ax.plot(X[:, 0], X[:, 1], "o", ms=5, zorder=5, label=f"pose variables ({len(X)})", **_POSE)
    pts = np.array(list(L.values())).reshape(-1, 2)
    m0 = min(L) if L else 0
    ax.plot(pts[:, 0], pts[:, 1], "s", ms=8, zorder=5,
            label=f"landmark variables ({len(L)}):\nl{m0} is marker {m0}", **_LM)
    for m, p in L.items():
        # a landmark just to the right would hide the label: put it on the left
        left = any(0.0 < q[0] - p[0] < 0.4 and abs(q[1] - p[1]) < 0.3
                   for k, q in L.items() if k != m)
        ax.annotate(f"l{m}", p, textcoords="offset points", xytext=(-7, -9) if left else (5, -9),
                    ha="right" if left else "left", fontsize=8, **_LM)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
    if title:
        ax.set_title(title)
    return ax


def _pattern(ax, M, split, title):
    """Non-zero entries black; a line at ``split`` (where the landmarks start)."""
    nz = np.abs(M) > 1e-12 * np.max(np.abs(M))
    ax.imshow(np.where(nz, 1.0, 0.0), cmap="Greys", vmin=0, vmax=1, interpolation="nearest")
    ax.axhline(split - 0.5, color="tab:orange", lw=1.0)
    ax.axvline(split - 0.5, color="tab:orange", lw=1.0)
    ax.set_title(f"{title}\n{100 * nz.mean():.0f} % of entries non-zero", fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])


def plot_sparsity(Lam, n_poses: int, n_landmarks: int, P_ekf, *, axes=None):
    """Non-zero pattern of the graph's information matrix beside the EKF's covariance
    and the EKF's information matrix (its inverse) at the same instant.

    ``Lam``: poses (3 each) then landmarks (2 each); ``P_ekf``: the EKF's full P
    (pose, then landmarks).
    """
    if axes is None:
        _, axes = plt.subplots(1, 3, figsize=(11, 4.0), dpi=DPI,
                               gridspec_kw={"width_ratios": [2.2, 1, 1]})
    _pattern(axes[0], Lam, 3 * n_poses,
             f"graph: information of {n_poses} poses + {n_landmarks} landmarks")
    axes[0].set_xlabel("poses in time order | landmarks")
    _pattern(axes[1], P_ekf, 3, "EKF: covariance P\n(pose + landmarks)")
    _pattern(axes[2], np.linalg.inv(P_ekf), 3, "EKF: information P^-1\n(past poses "
             "marginalised)")
    for a in axes[1:]:
        a.set_xlabel("pose | landmarks")
    return axes


def plot_nees_study(study, case: str, *, ax=None,
                    estimates=("ekf", "ekf_ungated", "isam2_online", "batch"),
                    title: str | None = None):
    """Average pose NEES over the seeds against time, with the 95 % band."""
    if ax is None:
        _, ax = plt.subplots(figsize=(7.5, 3.6), dpi=DPI)
    names = {"ekf": "EKF (filtered)", "ekf_ungated": "EKF without gate (filtered)",
             "isam2_online": "iSAM2 online (filtered)", "batch": "batch smoother (smoothed)"}
    styles = {"ekf": ("tab:red", "-"), "ekf_ungated": ("tab:orange", "--"),
              "isam2_online": ("tab:green", "-"), "batch": ("tab:blue", "-")}
    for e in estimates:
        color, ls = styles[e]
        ax.plot(study.grid, study.average_nees(case, e), color=color, ls=ls, lw=1.4,
                label=names[e])
    lo, hi = study.band()
    ax.axhspan(lo, hi, color="0.85", zorder=0, label=f"95 % band, {len(study.seeds)} runs")
    ax.axhline(3.0, color="0.4", lw=0.8, ls="--")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("average pose NEES (3 dof)")
    ax.set_title(title or f"{case}: sigma_wheel = {study.sigma_wheel(case)} m/s, "
                 f"{len(study.seeds)} seeds")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(True, lw=0.4, alpha=0.5)
    return ax


def plot_cost_per_step(map_size, ekf_work, isam2_work, *, ax=None, title: str | None = None):
    """Work of one update against the map's size: the EKF's entries of P rewritten
    (``(3 + 2L)^2``) and iSAM2's variables re-eliminated, log scale."""
    if ax is None:
        _, ax = plt.subplots(figsize=(7.0, 3.6), dpi=DPI)
    ax.semilogy(map_size, ekf_work, ".", ms=3, color="tab:red",
                label="EKF: entries of P rewritten, (3 + 2L)^2")
    ax.semilogy(map_size, isam2_work, ".", ms=3, color="tab:green",
                label="iSAM2: variables re-eliminated")
    ax.set_xlabel("landmarks in the map, L")
    ax.set_ylabel("work of one update")
    ax.legend(fontsize=8)
    ax.grid(True, lw=0.4, alpha=0.5)
    if title:
        ax.set_title(title)
    return ax


def plot_errors_at(axes, traces: dict, t, truth_at, colors=None, sigma_of=None, labels=None):
    """Position and heading errors of several estimates at the same times ``t`` (chapter 11).

    ``traces``: name -> Trace; each is sampled at ``t`` (the state after its last
    event at or before each time); ``truth_at``: the truth at any time (e.g.
    ``log.truth_at``). ``sigma_of``: the name whose 2-sigma bounds are drawn dotted.
    ``labels``: name -> legend entry (default: the name).
    """
    from ..metrics import pose_error
    from .graph_mrclam import node_samples

    a0, a1 = axes
    t = np.asarray(t, dtype=float)
    truth = truth_at(t)
    colors = colors or {}
    for name, tr in traces.items():
        x, P, _ = node_samples(tr, t)
        e = pose_error(x, truth)
        c = colors.get(name)
        label = (labels or {}).get(name, name)
        a0.plot(t - t[0], np.hypot(*e[:, :2].T), lw=1.1, color=c, label=label)
        a1.plot(t - t[0], np.degrees(e[:, 2]), lw=1.1, color=c, label=label)
        if name == sigma_of:
            a0.plot(t - t[0], 2 * np.sqrt(P[:, 0, 0] + P[:, 1, 1]), lw=0.8, ls=":", color=c)
            s = 2 * np.degrees(np.sqrt(P[:, 2, 2]))
            a1.plot(t - t[0], s, lw=0.8, ls=":", color=c)
            a1.plot(t - t[0], -s, lw=0.8, ls=":", color=c)
    a0.set_ylabel("position error (m)")
    a1.set_ylabel("heading error (deg)")
    a1.set_xlabel("time (s)")
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
    a0.legend(fontsize=8, loc="upper right")
    return axes


def plot_error_and_sigma(axes, traces: dict, colors=None):
    """Position error (top) and heading error (bottom) of each estimate against time, each
    with its own 2-sigma bound dotted (chapter 11, Fig. 3).

    ``traces``: legend entry -> Trace (``t``, ``x``, ``P``, ``truth``); ``colors``: entry ->
    colour. Where an error leaves its own band, that estimate is overconfident there.
    """
    a0, a1 = axes
    colors = colors or {}
    for name, tr in traces.items():
        t = tr.t - tr.t[0]
        e = tr.error
        c = colors.get(name)
        a0.plot(t, np.hypot(*e[:, :2].T), lw=1.1, color=c, label=f"{name}: error")
        a0.plot(t, 2 * np.sqrt(tr.P[:, 0, 0] + tr.P[:, 1, 1]), lw=0.9, ls=":", color=c,
                label=f"{name}: its own 2 sigma")
        s = 2 * np.degrees(np.sqrt(tr.P[:, 2, 2]))
        a1.plot(t, np.degrees(e[:, 2]), lw=1.1, color=c)
        a1.plot(t, s, lw=0.9, ls=":", color=c)
        a1.plot(t, -s, lw=0.9, ls=":", color=c)
    a0.set_ylabel("position error (m)")
    a1.set_ylabel("heading error (deg)")
    a1.set_xlabel("time (s)")
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
    a0.legend(fontsize=8, loc="upper left", ncol=2)
    return axes
