"""Chapter 02's figures: the camera mount (the report's Fig. 2), a camera frame with its
detections (Fig. 3), the error study of the camera pipeline and its autocorrelation.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from .plots import DPI, plot_robot, plot_world, world_axes

__all__ = ["plot_camera_mount", "plot_camera_view", "plot_detections", "plot_error_study",
           "plot_detection_scene", "plot_error_autocorrelation"]


def _axis_arrow(ax, origin, direction, label, color, length=0.1):
    o = np.asarray(origin, dtype=float)
    e = o + length * np.asarray(direction, dtype=float)
    ax.annotate("", xy=e, xytext=o, arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.6})
    ax.annotate(label, e, textcoords="offset points", xytext=(3, 3), color=color, fontsize=11)

def plot_camera_mount(camera=None, *, robot_radius: float = 0.175, marker_height: float = 0.15,
                      axes=None):
    """The camera frame C against the robot frame B: top view and side view (report's Fig. 2).

    Top view: x_B to the right, y_B downwards (z-down seen from above). Side
    view: x_B to the right, z_B downwards, the floor ``base_height`` below B.
    """
    from ..vision import default_camera

    cam = default_camera() if camera is None else camera
    T = cam.T_base_cam
    R, t = T[:3, :3], T[:3, 3]
    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(9.0, 4.0), dpi=DPI,
                               gridspec_kw={"width_ratios": [1.0, 1.3]})
    top, side = axes
    # top view (x_B, y_B)
    top.add_patch(plt.Circle((0, 0), robot_radius, fc="0.9", ec="0.4"))
    _axis_arrow(top, (0, 0), (1, 0), "", "tab:red")
    top.annotate("$x_B$", (0.05, 0), textcoords="offset points", xytext=(0, -3), ha="center",
                 va="top", color="tab:red", fontsize=11)   # below its arrow, clear of the camera
    _axis_arrow(top, (0, 0), (0, 1), "$y_B$", "tab:green")
    top.plot(0, 0, "kx")
    top.annotate("$z_B$ into the page", (0, 0), textcoords="offset points", xytext=(-4, 8),
                 ha="right", fontsize=9)
    top.add_patch(plt.Rectangle((t[0] - 0.045, t[1] - 0.02), 0.045, 0.04, fc="0.75", ec="0.4",
                                lw=0.8))                    # the camera box, lens at C
    _axis_arrow(top, t[:2], R[:2, 2], "$z_C$", "tab:blue", 0.08)
    _axis_arrow(top, t[:2], R[:2, 0], "$x_C$", "tab:purple", 0.08)
    top.plot(*t[:2], "o", color="tab:blue", ms=5)
    top.set_title("top view: B (robot) and C (camera)")
    top.set_xlim(-0.22, 0.3)
    top.set_ylim(-0.22, 0.22)
    top.set_aspect("equal")
    top.invert_yaxis()
    top.set_xlabel("$x_B$ (m)")
    top.set_ylabel("$y_B$ (m), downwards")
    top.grid(True, lw=0.4, alpha=0.5)
    # side view (x_B, z_B), z down
    h = cam.base_height
    side.axhline(h, color="0.3", lw=2)
    side.annotate("floor", (0.42, h), textcoords="offset points", xytext=(-2, 3), ha="right",
                  fontsize=9)
    body_top = h - 0.11
    side.add_patch(plt.Rectangle((-robot_radius, body_top), 2 * robot_radius, 0.1,
                                 fc="0.9", ec="0.4"))
    # the camera: a box whose lens (front face) is at C's origin, on a mast standing on the body
    box_l, box_h, mast_w = 0.045, 0.03, 0.012
    box_bottom = t[2] + box_h / 2                  # z down: the box's underside
    side.add_patch(plt.Rectangle((t[0] - box_l / 2 - mast_w / 2, box_bottom), mast_w,
                                 body_top - box_bottom, fc="0.75", ec="0.4", lw=0.8))
    side.add_patch(plt.Rectangle((t[0] - box_l, t[2] - box_h / 2), box_l, box_h,
                                 fc="0.75", ec="0.4", lw=0.8))
    side.annotate("camera", (t[0] - box_l / 2, t[2] - box_h / 2), textcoords="offset points",
                  xytext=(0, 2), ha="center", va="bottom", fontsize=9, color="0.3")
    _axis_arrow(side, (0, 0), (1, 0), "$x_B$", "tab:red")
    _axis_arrow(side, (0, 0), (0, 1), "$z_B$", "tab:green")
    _axis_arrow(side, t[[0, 2]], R[[0, 2], 2], "$z_C$", "tab:blue", 0.08)
    _axis_arrow(side, t[[0, 2]], R[[0, 2], 1], "$y_C$", "tab:orange", 0.08)
    side.plot(t[0], t[2], "o", color="tab:blue", ms=5)
    side.axhline(h - marker_height, color="tab:gray", ls=":", lw=1)
    side.annotate(f"marker centres\n({marker_height:.2f} m up)", (-0.21, h - marker_height),
                  textcoords="offset points", xytext=(0, 3), fontsize=9, color="tab:gray")
    side.set_title(f"side view: camera {cam.camera_height:.3f} m above the floor")
    side.set_xlim(-0.22, 0.42)
    side.set_ylim(-0.06, h + 0.03)
    side.set_aspect("equal")
    side.invert_yaxis()
    side.set_xlabel("$x_B$ (m)")
    side.set_ylabel("$z_B$ (m), downwards")
    side.grid(True, lw=0.4, alpha=0.5)
    return axes

def plot_camera_view(ax, image, *, title: str | None = None):
    """Show a camera frame (grayscale, or BGR as OpenCV draws) with pixel axes."""
    img = np.asarray(image)
    if img.ndim == 3:
        img = img[..., ::-1]                       # BGR -> RGB
        ax.imshow(img)
    else:
        ax.imshow(img, cmap="gray", vmin=0, vmax=255)
    ax.set_xlabel("u (px)")
    ax.set_ylabel("v (px)")
    if title:
        ax.set_title(title)
    return ax

def plot_detections(ax, gray, det, camera, marker_length: float, *, title: str | None = None,
                    fontsize: float = 10):
    """A camera frame with the detected outlines and pose axes (drawn by OpenCV) and each
    marker's id written above it in the figure's font, so that it stays readable when the
    picture is shown small."""
    from ..vision import draw_detections

    plot_camera_view(ax, draw_detections(gray, det, camera, marker_length, ids=False),
                     title=title)
    _label_ids(ax, det, fontsize)
    return ax


def _label_ids(ax, det, fontsize: float):
    for i, c in zip(det.ids, det.corners):
        c = np.asarray(c, dtype=float)
        ax.annotate(f"{int(i)}", (c[:, 0].mean(), c[:, 1].min()), textcoords="offset points",
                    xytext=(0, 3), ha="center", va="bottom", fontsize=fontsize, color="tab:blue",
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none",
                          "alpha": 0.85})


def plot_error_study(study, model=None, *, axes=None, error_bars: bool = True):
    """Four panels of an :class:`slamlib.vision.ErrorStudy`: detection rate, range bias,
    range noise and bearing noise against distance, one line per viewing angle; the fitted
    :class:`slamlib.vision.NoiseModel` dashed (and named in each panel's legend) if given.

    ``error_bars``: the standard error of each mean (bias) and of each standard
    deviation (``s / sqrt(2 (n - 1))``), from the number of detected samples per cell.
    """
    if axes is None:
        _, axes = plt.subplots(2, 2, figsize=(9.0, 6.4), dpi=DPI, sharex=True)
    ax_det, ax_bias, ax_std, ax_b = np.ravel(axes)
    d = study.distances
    rate, bias, std = study.detection_rate(), study.range_bias(), study.range_std()
    bstd = study.bearing_std()
    n = np.zeros_like(rate)
    for i in range(d.size):
        for j in range(study.angles.size):
            n[i, j] = np.count_nonzero(study.detected & (study.cell[:, 0] == i)
                                       & (study.cell[:, 1] == j))
    with np.errstate(divide="ignore", invalid="ignore"):
        se_mean = np.where(n >= 2, 1.0 / np.sqrt(n), np.nan)
        se_std = np.where(n >= 2, 1.0 / np.sqrt(2.0 * (n - 1.0)), np.nan)
    # spread the lines a little along x so that error bars do not overlap
    shift = 0.03 * (d.max() - d.min()) / max(study.angles.size, 1)
    for j, a in enumerate(study.angles):
        lab = f"{np.degrees(a):.0f} deg"
        x = d + (j - 0.5 * (study.angles.size - 1)) * shift
        ax_det.plot(d, rate[:, j], "o-", ms=3, label=lab)
        for ax, y, se in ((ax_bias, 100 * bias[:, j], 100 * std[:, j] * se_mean[:, j]),
                          (ax_std, 100 * std[:, j], 100 * std[:, j] * se_std[:, j]),
                          (ax_b, np.degrees(bstd[:, j]), np.degrees(bstd[:, j]) * se_std[:, j])):
            if error_bars:
                ax.errorbar(x, y, yerr=se, fmt="o-", ms=3, capsize=2, elinewidth=0.8, label=lab)
            else:
                ax.plot(d, y, "o-", ms=3, label=lab)
    if model is not None:
        r = np.linspace(0, d.max(), 100)
        c3 = getattr(model, "bias_coef3", 0.0)
        fit = f"fit {100 * model.bias_coef:.2f} $\\rho^2$"
        if c3:
            fit += f" + {100 * c3:.3f} $\\rho^3$"
        ax_bias.plot(r, 100 * model.range_bias(r), "k--", lw=1.2,
                     label=fit + " (cm, $\\rho$ in m)")
        ax_std.plot(r, 100 * model.sigma_range(r), "k--", lw=1.2,
                    label="fitted $\\sigma_\\rho$ (after the bias correction)")
        ax_b.axhline(np.degrees(model.sigma_bearing), color="k", ls="--", lw=1.2,
                     label="fitted $\\sigma_\\beta$")
        ax_std.legend(handles=ax_std.get_lines()[-1:], fontsize=9, loc="upper left")
        ax_b.legend(handles=ax_b.get_lines()[-1:], fontsize=9, loc="upper left")
    ax_det.set_ylabel("detection rate")
    ax_det.set_ylim(-0.05, 1.05)
    ax_bias.set_ylabel("range bias (cm)")
    ax_std.set_ylabel("range std (cm)")
    ax_b.set_ylabel("bearing std (deg)")
    for ax in (ax_std, ax_b):
        ax.set_xlabel("true range (m)")
    for ax in (ax_det, ax_bias, ax_std, ax_b):
        ax.grid(True, lw=0.4, alpha=0.5)
    ax_det.legend(fontsize=9, title="viewing angle", title_fontsize=9)
    if model is not None:
        ax_bias.legend(handles=ax_bias.get_lines()[-1:], fontsize=9, loc="upper left")
    return axes

def plot_detection_scene(world, pose, camera, *, rng=None, zoom=None, title=None):
    """The report's Fig. 3: the camera's rendered view from ``pose`` with the detected
    markers, their ids and pose axes drawn, beside a top view with the field of view.

    ``zoom = (u0, u1, v0, v1)``: also show that part of the image (pixels)
    magnified in an inset over the upper part of the view. ``title``: a title
    over the whole figure.

    Returns
    -------
    (Figure, slamlib.vision.Detections)
    """
    from ..models import compose_point
    from ..vision import detect_markers, draw_detections, render_view

    pose = np.asarray(pose, dtype=float)
    gray = render_view(world, pose, camera, rng=rng)
    det = detect_markers(gray, camera, world.marker_length, world.dictionary)
    fig = plt.figure(figsize=(11, 4.4), dpi=DPI)
    top = 0.85 if title else 0.92          # room for the figure's title
    ax_img = fig.add_axes([0.02, 0.1, 0.58, top - 0.1])
    drawn = draw_detections(gray, det, camera, world.marker_length, ids=False)
    plot_camera_view(ax_img, drawn, title="camera view, detections and marker axes")
    if zoom is not None:
        u0, u1, v0, v1 = (int(round(v)) for v in zoom)
        inset = ax_img.inset_axes([0.02, 0.5, 0.96, 0.47])
        inset.imshow(drawn[v0:v1, u0:u1, ::-1], extent=(u0 - 0.5, u1 - 0.5, v1 - 0.5, v0 - 0.5))
        inset.set_xlim(u0 - 0.5, u1 - 0.5)
        inset.set_ylim(v1 - 0.5, v0 - 0.5)
        inset.set_xticks([])
        inset.set_yticks([])
        _label_ids(inset, det, 10)
        ax_img.indicate_inset_zoom(inset, edgecolor="tab:orange")
    else:
        _label_ids(ax_img, det, 10)
    ax_top = fig.add_axes([0.64, 0.1, 0.34, top - 0.1])
    world_axes(ax_top, world)
    plot_world(ax_top, world, facing=True)
    plot_robot(ax_top, pose, size=0.25)
    cam_xy = compose_point(pose, camera.T_base_cam[:2, 3])
    for side in (-1, 1):
        a = pose[2] + side * camera.hfov / 2
        ax_top.plot([cam_xy[0], cam_xy[0] + 4 * np.cos(a)],
                    [cam_xy[1], cam_xy[1] + 4 * np.sin(a)], "g--", lw=0.8)
    ax_top.set_title("top view (y down), field of view")
    if title:
        fig.suptitle(title)
    return fig, det

def plot_error_autocorrelation(lags_s, corr, *, labels=("range", "bearing"), ax=None,
                               title: str | None = None):
    """Correlation of the normalised reading errors against the lag between frames (s)."""
    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 3.0), dpi=DPI)
    corr = np.asarray(corr, dtype=float)
    ax.axhline(0.0, color="k", lw=0.8)
    for j, (label, mk) in enumerate(zip(labels, ("o-", "s-"))):
        ax.plot(lags_s, corr[:, j], mk, ms=4, label=label)
    ax.set_xlabel("lag between the two frames (s)")
    ax.set_ylabel("correlation of the errors")
    ax.set_ylim(-0.1, 1.0)
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(fontsize=9)
    if title:
        ax.set_title(title, fontsize=10)
    return ax
