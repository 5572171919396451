"""Chapter 08's figure: the latency study (errors against the camera's delay, by method).
"""

from __future__ import annotations

import matplotlib.pyplot as plt

from .plots import DPI

__all__ = ["LATENCY_METHOD_STYLES", "plot_latency_study"]

#: Colours and labels of the late-frame methods of :mod:`slamlib.delay`.
LATENCY_METHOD_STYLES = {
    "naive": {"color": "tab:red", "marker": "o", "label": "naive: fused on arrival"},
    "fixed": {"color": "tab:blue", "marker": "s", "label": "fixed: fused at capture time"},
    "compensated": {"color": "tab:green", "marker": "^",
                    "label": "readings moved by odometry"},
}

_LATENCY_METRIC_LABELS = {
    "ate_xy": "position ATE (m)", "ate_theta": "heading ATE (rad)",
    "mean_nees": "mean pose NEES", "map_rmse": "map RMS error (m)",
    "final_xy_error": "final position error (m)", "rejected": "readings rejected by the gate",
}

def plot_latency_study(rows, metrics=("ate_xy", "map_rmse"), *, axes=None,
                       title: str | None = None, legend_panel: int = 0,
                       legend_loc: str = "best"):
    """Errors against camera latency, one line per method (chapter 08).

    Parameters
    ----------
    rows : list of dict
        :func:`slamlib.delay.latency_study` output (keys ``latency``,
        ``method`` and the metrics).
    metrics : sequence of str
        One panel per metric.
    axes : sequence of Axes, optional
    legend_panel, legend_loc : int, str
        Which panel gets the legend, and where (None: no legend).

    Returns
    -------
    (Figure, axes)
    """
    metrics = list(metrics)
    if axes is None:
        fig, axes = plt.subplots(1, len(metrics), figsize=(3.6 * len(metrics), 3.2), dpi=DPI,
                                 squeeze=False)
        axes = axes[0]
    fig = axes[0].figure
    methods = list(dict.fromkeys(r["method"] for r in rows))
    for ax, key in zip(axes, metrics):
        for m in methods:
            pts = sorted((r["latency"], r[key]) for r in rows if r["method"] == m and key in r)
            if not pts:
                continue
            style = dict(LATENCY_METHOD_STYLES.get(m, {"label": m}))
            ax.plot([p[0] for p in pts], [p[1] for p in pts], lw=1.4, ms=5, **style)
        ax.set_xlabel("camera latency (s)")
        ax.set_ylabel(_LATENCY_METRIC_LABELS.get(key, key))
        ax.set_ylim(bottom=0)
        ax.grid(True, lw=0.4, alpha=0.5)
    if legend_panel is not None:
        axes[legend_panel].legend(fontsize=9, loc=legend_loc)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig, axes
