"""Chapter 09's figures (markers without ids): gates in reading space, runs, the study."""

from __future__ import annotations

import numpy as np

from . import plots

__all__ = ["plot_reading_gates", "plot_wrong_associations", "plot_study", "plot_jcbb_cost",
           "summarise_study", "drift_columns", "plot_drift_study"]

METHOD_COLORS = {"ids": "tab:gray", "nn": "tab:red", "jcbb": "tab:blue"}


def plot_reading_gates(ax, report_nn, report_jcbb, labels, *, nsigma: float = 2.4477,
                       title: str | None = None):
    """Predicted readings with their 95 % gates, the readings, and the pairs NN and JCBB chose.

    ``report_*`` are :class:`slamlib.ekf.UpdateReport` of the same frame (without ids);
    ``labels`` maps a map id to a name. Axes: bearing (deg) against range (m).
    The ellipses are each landmark's ``S`` as the report gives it for the
    reading paired with (or nearest to) it, so they include that reading's R.
    """
    z = report_nn.z
    # every landmark's prediction and S: from whichever report paired something with it
    preds = {}
    for rep in (report_nn, report_jcbb):
        for i in range(len(rep)):
            mid = int(rep.matched[i])
            if mid >= 0 and mid not in preds:
                preds[mid] = (rep.predicted[i], rep.S[i])
    T = np.array([[0.0, 180.0 / np.pi], [1.0, 0.0]])     # (range, bearing) -> (bearing deg, range)
    for mid, (h, S) in sorted(preds.items()):
        Sd = T @ S @ T.T
        c = T @ h
        plots.plot_covariance_ellipse(ax, c, Sd, nsigma=nsigma, color="0.5", alpha=0.15)
        ax.plot(*c, "o", color="0.3", ms=5)
        ax.annotate(labels.get(mid, str(mid)), c, textcoords="offset points", xytext=(6, 4),
                    fontsize=9, color="0.2")
    ax.plot(np.degrees(z[:, 1]), z[:, 0], "kx", ms=9, mew=2, label="readings")
    for rep, color, name, ms in ((report_nn, "tab:red", "NN", 17), (report_jcbb, "tab:blue",
                                                                        "JCBB", 11)):
        first = True
        for i in range(len(rep)):
            mid = int(rep.matched[i])
            if mid in preds:
                h = preds[mid][0]
                ax.plot([np.degrees(z[i, 1]), np.degrees(h[1])], [z[i, 0], h[0]], "-",
                        color=color, lw=2, marker="o", ms=ms, mfc="none", mew=1.8,
                        markevery=[1], label=f"{name}: reading -> landmark" if first else None)
                first = False
    ax.set_xlabel("bearing (deg)")
    ax.set_ylabel("range (m)")
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(fontsize=9, loc="best")
    if title:
        ax.set_title(title, fontsize=10)


def plot_wrong_associations(ax, scores, traces, *, title: str | None = None):
    """Wrong associations per second of the run, one line per method.

    ``scores`` and ``traces``: dicts method -> AssociationScore / (trace, true_ids).
    """
    for m, (tr, tid) in traces.items():
        label = scores[m].label
        t, wrong = [], []
        for (tt, rep), ti in zip(tr.reports, tid):
            w = sum(1 for i, x in enumerate(ti) if x >= 0 and rep.accepted[i]
                    and label[int(rep.matched[i])] != x)
            t.append(tt)
            wrong.append(w)
        t, wrong = np.array(t), np.cumsum(wrong)
        ax.step(t, wrong, where="post", color=METHOD_COLORS.get(m, None), label=m)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("wrong associations so far")
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(fontsize=9)
    if title:
        ax.set_title(title, fontsize=10)


def summarise_study(rows: list[dict]) -> dict[str, dict[str, float]]:
    """Per method: mean ATE, mean NEES, wrong-association rate, rejected readings, clutter."""
    out = {}
    for m in dict.fromkeys(r["method"] for r in rows):
        sel = [r for r in rows if r["method"] == m]
        fused = sum(r["fused"] for r in sel)
        out[m] = {"runs": len(sel),
                  "ate": float(np.mean([r["ate"] for r in sel])),
                  "ate_max": float(np.max([r["ate"] for r in sel])),
                  "nees": float(np.mean([r["nees"] for r in sel])),
                  "wrong_rate": sum(r["wrong"] for r in sel) / fused if fused else 0.0,
                  "runs_with_wrong": sum(1 for r in sel if r["wrong"] > 0),
                  "rejected_rate": sum(r["rejected"] for r in sel)
                  / sum(r["readings"] for r in sel),
                  "clutter_landmarks": sum(r["clutter_landmarks"] for r in sel),
                  "duplicates": sum(r["duplicates"] for r in sel)}
    return out


def plot_study(rows: list[dict], *, axes=None):
    """Per-run ATE, mean NEES and wrong associations for each method (strip plots)."""
    import matplotlib.pyplot as plt

    if axes is None:
        _, axes = plt.subplots(1, 3, figsize=(11, 3.3))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    for ax, key, label in zip(axes, ("ate", "nees", "wrong"),
                              ("position ATE (m)", "time-averaged pose NEES",
                               "wrong associations per run")):
        for q, m in enumerate(methods):
            v = np.array([r[key] for r in rows if r["method"] == m], dtype=float)
            jitter = np.linspace(-0.25, 0.25, v.size)
            ax.plot(q + jitter, v, ".", color=METHOD_COLORS.get(m), alpha=0.6, ms=4)
            ax.plot([q - 0.3, q + 0.3], [np.mean(v)] * 2, "k-", lw=2)
        ax.set_xticks(range(len(methods)), methods)
        ax.set_ylabel(label)
        ax.grid(True, axis="y", lw=0.4, alpha=0.5)
        if key == "nees":
            ax.axhline(3.0, color="tab:green", lw=1, ls="--", label="3: a consistent filter's mean")
            ax.legend(fontsize=9)
    plt.tight_layout()
    return axes


def plot_jcbb_cost(ax, ks, nodes_by_case: dict[str, list[int]],
                   maxima: dict[str, list[int]] | None = None):
    """Nodes JCBB visits per frame against the readings in the frame (log scale); with
    ``maxima`` (same keys), the largest count of each k dashed in the same colour."""
    for name, nodes in nodes_by_case.items():
        line, = ax.semilogy(ks, nodes, "o-", label=name)
        if maxima is not None:
            ax.semilogy(ks, maxima[name], "--", color=line.get_color(), lw=0.9)
    ax.set_xlabel("readings in the frame")
    ax.set_ylabel("nodes JCBB visits")
    ax.grid(True, which="both", lw=0.4, alpha=0.5)
    ax.legend(fontsize=9)


def drift_columns(rows: list[dict]) -> dict[tuple[str, float], dict[str, np.ndarray]]:
    """The drift study's rows (``association_study.drift_study``) as arrays per (method, gate),
    each in seed order: ``columns[("jcbb", 0.95)]["wrong"][k]`` is seed ``seeds[k]``'s count."""
    out: dict = {}
    for r in sorted(rows, key=lambda r: r["seed"]):
        d = out.setdefault((r["method"], float(r["gate"])), {})
        for key, v in r.items():
            if key not in ("method", "gate"):
                d.setdefault(key, []).append(v)
    return {k: {key: np.asarray(v) for key, v in d.items()} for k, d in out.items()}


def plot_drift_study(cols: dict, *, seed: int = 1, seed_label: str | None = None, axes=None):
    """Wrong associations per drifted run, JCBB against NN, at gates 0.95 and 0.99 (symlog);
    ``seed`` (the chapter's run) ringed, labelled ``seed_label`` (default ``"seed <seed>"``)."""
    import matplotlib.pyplot as plt

    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(9.5, 4.0))
    for ax, gate in zip(axes, (0.95, 0.99)):
        nn, jc = cols[("nn", gate)], cols[("jcbb", gate)]
        ax.plot(nn["wrong"], jc["wrong"], ".", color="tab:purple", alpha=0.6, ms=6,
                label=f"{nn['wrong'].size} seeds")
        k = int(np.flatnonzero(nn["seed"] == seed)[0])
        ax.plot(nn["wrong"][k], jc["wrong"][k], "o", ms=11, mfc="none", mec="k", mew=1.5,
                label=seed_label or f"seed {seed}")
        top = max(nn["wrong"].max(), jc["wrong"].max()) * 1.3 + 1
        ax.plot([0, top], [0, top], "k--", lw=0.8, label="equal")
        # counts are integers: the linear part [0, 1] is squeezed to a fifth of a decade, so
        # the zero row sits just below the row of 1 with no empty band between them
        ax.set_xscale("symlog", linthresh=1, linscale=0.2)
        ax.set_yscale("symlog", linthresh=1, linscale=0.2)
        ticks = [0] + [10 ** e for e in range(int(np.log10(top)) + 1)]
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_ticks(ticks, [str(t) for t in ticks])
        ax.set_xlim(-0.5, top)
        ax.set_ylim(-0.5, top)
        ax.set_xlabel("NN: wrong associations in the run")
        ax.set_ylabel("JCBB: wrong associations in the run")
        ax.set_title(f"gate {gate:g}", fontsize=10)
        ax.grid(True, which="both", lw=0.4, alpha=0.5)
        ax.legend(fontsize=9, loc="upper left")
    plt.tight_layout()
    return axes
