"""Chapter 04's figure: a Monte-Carlo cloud of inverse observations against its
linearised Gaussian.
"""

from __future__ import annotations

import numpy as np

from .plots import plot_covariance_ellipse, plot_robot, world_axes

__all__ = ["plot_inverse_cloud"]


def plot_inverse_cloud(ax, cloud, mean, cov, *, pose=None, nsigma: float = 2.0,
                       title: str | None = None, legend_loc: str = "upper right"):
    """Samples of a transformed Gaussian against its linearisation (chapter 04).

    Draws the samples (grey dots), the linearised mean (orange +) and its
    ``nsigma`` ellipse, the samples' mean (black x) and optionally the robot's
    mean pose, on a top view.

    Parameters
    ----------
    cloud : array_like, shape (N, 2)
        The samples, e.g. ``inverse_observe`` of sampled poses and readings.
    mean, cov : array_like, shapes (2,), (2, 2)
        The linearised Gaussian (``g`` at the means, ``J1 P J1^T + J2 R J2^T``).
    pose : array_like, shape (3,), optional

    The ellipse's legend entry gives the share of a Gaussian inside it (86.5 % at
    2 sigma); :func:`slamlib.metrics.mahalanobis2` counts the samples inside.
    """
    cloud = np.asarray(cloud, dtype=float)
    expected = 1.0 - np.exp(-0.5 * nsigma**2)          # chi-square, 2 dof
    world_axes(ax, title=title)
    ax.plot(cloud[:, 0], cloud[:, 1], ".", ms=1.5, alpha=0.35, color="tab:gray",
            label="samples")
    plot_covariance_ellipse(ax, mean, cov, nsigma=nsigma, color="tab:orange", fill=False,
                            alpha=1.0, lw=2,
                            label=f"linearised {nsigma:g}σ ({100 * expected:.1f} %)")
    ax.plot(*mean, "+", color="tab:orange", ms=10, mew=2, label="linearised mean")
    ax.plot(*cloud.mean(axis=0), "x", color="k", ms=8, mew=2, label="sample mean")
    if pose is not None:
        plot_robot(ax, pose, size=0.2, label="robot (mean pose)")
    ax.legend(fontsize=9, loc=legend_loc)
    return ax
