"""Chapter 01's figure of the encoders: raw counters that wrap, and the distances after unwrapping.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from ..models import KOBUKI_TICKS_PER_REV, KOBUKI_WHEEL_RADIUS, tick_difference
from .plots import plot_covariance_ellipse

__all__ = ["plot_encoder_counters", "mark_ellipse_times"]


def plot_encoder_counters(run):
    """The run's 16-bit counters against time (they wrap) and each wheel's rim distance from
    the increments that :func:`slamlib.models.tick_difference` unwraps. Returns the figure."""
    tick = 2 * np.pi * KOBUKI_WHEEL_RADIUS / KOBUKI_TICKS_PER_REV
    fig, axes = plt.subplots(1, 2, figsize=(7.6, 3.0), dpi=100)
    axes[0].plot(run.enc_t, run.ticks_R, label="right counter")
    axes[0].plot(run.enc_t, run.ticks_L, label="left counter")
    axes[0].set(xlabel="t (s)", ylabel="raw counter", title="16-bit counters wrap")
    axes[0].legend(fontsize=9, loc="lower right")
    dR = tick_difference(run.ticks_R[1:], run.ticks_R[:-1])
    dL = tick_difference(run.ticks_L[1:], run.ticks_L[:-1])
    axes[1].plot(run.enc_t[1:], np.cumsum(dR) * tick, label="right wheel")
    axes[1].plot(run.enc_t[1:], np.cumsum(dL) * tick, label="left wheel")
    axes[1].set(xlabel="t (s)", ylabel="rim distance (m)", title="after tick_difference")
    axes[1].legend(fontsize=9)
    fig.tight_layout()
    return fig


def mark_ellipse_times(ax, trace, times, nsigma: float = 2.0, color: str = "tab:orange"):
    """Outline the ``nsigma`` pose ellipse of ``trace`` at each of ``times`` (s) on a top view
    and label it with its time, so that a sentence about "the ellipse after 5 s" can be
    found in the figure. Each time snaps to the nearest sample of the trace. Returns the
    sample indices used."""
    ks = []
    for t in times:
        k = int(np.argmin(np.abs(np.asarray(trace.t) - float(t))))
        plot_covariance_ellipse(ax, trace.x[k], trace.P[k], nsigma, color=color, fill=False,
                                alpha=1.0, lw=1.5)
        ax.annotate(f"{trace.t[k]:.0f} s", xy=trace.x[k, :2], xytext=(8, -8),
                    textcoords="offset points", fontsize=9, color=color, fontweight="bold")
        ks.append(k)
    return ks
