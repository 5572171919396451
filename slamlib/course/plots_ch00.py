"""Chapter 00's figures: frames drawn in a top view, the correlations of a covariance.
"""

from __future__ import annotations

import numpy as np

__all__ = ["plot_frame", "plot_covariance_blocks"]


def plot_frame(ax, pose, *, length: float = 0.3, name: str = "", color: str = "k",
               axis_names: tuple[str, str] = ("x", "y")):
    """Draw a planar frame at ``pose`` (its x and y axes as arrows, labelled).

    In a :func:`world_axes` view (y down) a z-down frame's axes appear with y
    to the right of x, as seen from above.
    """
    x, y, th = (float(v) for v in pose[:3])
    for k, (ang, lab) in enumerate(zip((th, th + np.pi / 2), axis_names)):
        dx, dy = length * np.cos(ang), length * np.sin(ang)
        ax.annotate("", xy=(x + dx, y + dy), xytext=(x, y),
                    arrowprops={"arrowstyle": "->", "color": color, "lw": 1.5 if k == 0 else 1.0})
        ax.text(x + 1.15 * dx, y + 1.15 * dy, f"{lab}$_{{{name}}}$" if name else lab,
                color=color, ha="center", va="center", fontsize=9)

def plot_covariance_blocks(ax, P, n_landmarks: int, *, title: str = "|correlation|",
                           ids=None, colorbar: bool = False):
    """Show a SLAM covariance as an image of |correlation| with the state's blocks outlined.

    ``ids``: the landmarks' ids in state order (``EKFSLAM.landmark_ids``); the
    ticks are then ``x31, y31, ...`` instead of ``x1, y1, ...`` (counting from 1).
    ``colorbar``: add a colour bar labelled "|correlation|". Returns the image.
    """
    P = np.asarray(P, dtype=float)
    d = np.sqrt(np.diag(P))
    C = np.abs(P / np.outer(d, d))
    im = ax.imshow(C, cmap="viridis", vmin=0.0, vmax=1.0, interpolation="nearest")
    edges = [3 + 2 * i for i in range(n_landmarks + 1)]
    for e in edges:
        ax.axhline(e - 0.5, color="w", lw=0.6)
        ax.axvline(e - 0.5, color="w", lw=0.6)
    names = list(range(1, n_landmarks + 1)) if ids is None else [int(i) for i in ids]
    if len(names) != n_landmarks:
        raise ValueError(f"ids: expected {n_landmarks} landmark ids, got {len(names)}")
    labels = ["x", "y", "θ"] + [f"{c}{i}" for i in names for c in ("x", "y")]
    ax.set_xticks(range(P.shape[0]), labels, fontsize=7, rotation=90)
    ax.set_yticks(range(P.shape[0]), labels, fontsize=7)
    ax.set_title(title)
    if colorbar:
        ax.figure.colorbar(im, ax=ax, shrink=0.8, label="|correlation|")
    return im
