"""Chapter 00's figures: frames drawn in a top view, the arena with the robot's frames
and a close-up of the camera on the robot, the correlations of a covariance.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Rectangle

from .plots import plot_robot, plot_world, world_axes

__all__ = ["plot_frame", "plot_arena_frames", "plot_covariance_blocks"]


def plot_frame(ax, pose, *, length: float = 0.3, name: str = "", color: str = "k",
               axis_names: tuple[str, str] = ("x", "y"), fontsize: float = 10):
    """Draw a planar frame at ``pose`` (its x and y axes as arrows, labelled).

    In a :func:`world_axes` view (y down) a z-down frame's axes appear with y
    to the right of x, as seen from above.
    """
    x, y, th = (float(v) for v in pose[:3])
    for k, (ang, lab) in enumerate(zip((th, th + np.pi / 2), axis_names)):
        dx, dy = length * np.cos(ang), length * np.sin(ang)
        ax.annotate("", xy=(x + dx, y + dy), xytext=(x, y),
                    arrowprops={"arrowstyle": "->", "color": color, "lw": 1.5 if k == 0 else 1.0})
        ax.text(x + 1.2 * dx, y + 1.2 * dy, f"{lab}$_{{{name}}}$" if name else lab,
                color=color, ha="center", va="center", fontsize=fontsize)


def _arrow(ax, origin, direction, length, label, color, *, label_at: float = 1.3,
           fontsize: float = 11):
    o = np.asarray(origin, dtype=float)
    d = np.asarray(direction, dtype=float)
    ax.annotate("", xy=o + length * d, xytext=o,
                arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.8})
    ax.text(*(o + label_at * length * d), label, color=color, ha="center", va="center",
            fontsize=fontsize)


def plot_arena_frames(world, pose, T_base_cam, *, zoom: float = 0.32, robot_radius: float = 0.175):
    """The three frames of chapter 00, seen from above (z down, y down the page).

    Left: the arena with the world frame N at its origin and the robot's body frame B
    at ``pose``. Right: a close-up of the robot, in the same orientation, with B and the
    camera's optical frame C (z_C forward, x_C to the robot's right; y_C points down,
    into the floor, so it is seen end-on). ``T_base_cam`` is ^B T_C (4x4).

    Returns
    -------
    matplotlib Figure
    """
    from ..models import compose_point

    pose = np.asarray(pose, dtype=float)
    T = np.asarray(T_base_cam, dtype=float)
    fig, (ax, close) = plt.subplots(1, 2, figsize=(9.0, 4.4), dpi=90,
                                    gridspec_kw={"width_ratios": [1.15, 1.0]})
    world_axes(ax, world, title="The report's arena from above (frame N)")
    plot_world(ax, world, label="markers")
    plot_frame(ax, [0.0, 0.0, 0.0], length=0.9, name="N")
    plot_robot(ax, pose, size=0.25)
    plot_frame(ax, pose, length=0.55, name="B", color="tab:green")
    c, s = np.cos(pose[2]), np.sin(pose[2])
    x_b, y_b = np.array([c, s]), np.array([-s, c])           # B's axes in N
    centre = pose[:2] + 0.3 * zoom * x_b                     # room for x_B's label ahead
    ax.add_patch(Rectangle((centre[0] - zoom, centre[1] - zoom), 2 * zoom, 2 * zoom, fill=False,
                           ec="tab:orange", lw=1.2, ls="--"))
    ax.annotate("close-up\n(right)", (centre[0] + zoom, centre[1] - zoom),
                textcoords="offset points", xytext=(4, -2), ha="left", va="top",
                color="tab:orange", fontsize=9)
    ax.legend(loc="lower left", fontsize=9)

    # close-up: same orientation as the arena, the robot's body and both frames
    close.add_patch(plt.Circle(pose[:2], robot_radius, fc="0.93", ec="0.5"))
    _arrow(close, pose[:2], x_b, 0.25, "$x_B$", "tab:green", label_at=1.2)
    _arrow(close, pose[:2], y_b, 0.25, "$y_B$", "tab:green", label_at=1.2)
    close.plot(*pose[:2], "x", color="tab:green", ms=8)
    cam = compose_point(pose, T[:2, 3])
    R2 = np.column_stack([x_b, y_b]) @ T[:2, :3]            # C's axes, projected on the floor
    _arrow(close, cam, R2[:, 2], 0.08, "$z_C$", "tab:purple", label_at=1.45)
    _arrow(close, cam, R2[:, 0], 0.08, "$x_C$", "tab:purple", label_at=1.45)
    close.plot(*cam, "o", color="tab:purple", ms=6)
    close.annotate("camera C\n($y_C$ into the floor)", cam, textcoords="offset points",
                   xytext=(16, 0), ha="left", va="center", color="tab:purple", fontsize=9)
    close.annotate("B's origin\n($z_B$ into the floor)", pose[:2], textcoords="offset points",
                   xytext=(12, 8), ha="left", va="bottom", color="tab:green", fontsize=9)
    close.set_xlim(centre[0] - zoom, centre[0] + zoom)
    close.set_ylim(centre[1] - zoom, centre[1] + zoom)
    close.set_aspect("equal")
    close.invert_yaxis()
    close.set_xlabel("x (m)")
    close.set_ylabel("y (m), downwards")
    close.grid(True, lw=0.4, alpha=0.5)
    close.set_title("Close-up: body frame B and camera frame C")
    for spine in close.spines.values():
        spine.set_edgecolor("tab:orange")
    fig.tight_layout()
    return fig


def plot_covariance_blocks(ax, P, n_landmarks: int, *, title: str = "|correlation|",
                           ids=None, colorbar: bool = False, tick_fontsize: float = 7):
    """Show a SLAM covariance as an image of |correlation| with the state's blocks outlined.

    ``ids``: the landmarks' ids in state order (``EKFSLAM.landmark_ids``); the
    ticks are then ``x31, y31, ...`` instead of ``x1, y1, ...`` (counting from 1).
    ``colorbar``: add a colour bar labelled "|correlation|". ``tick_fontsize``: the
    size of the tick labels (points). Returns the image.
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
    ax.set_xticks(range(P.shape[0]), labels, fontsize=tick_fontsize, rotation=90)
    ax.set_yticks(range(P.shape[0]), labels, fontsize=tick_fontsize)
    ax.set_title(title)
    if colorbar:
        ax.figure.colorbar(im, ax=ax, shrink=0.8, label="|correlation|")
    return im
