"""Plotting helpers shared by the chapters, so that a chapter shows only its teaching code.

Top views follow one rule: the world frame N is z-down (x forward, y to the
right), so a picture of the world *seen from above* puts x to the right and
y **downwards** on the screen (:func:`world_axes` inverts the y axis and fixes
an equal aspect). Then a positive (clockwise) rotation looks clockwise and a
left turn looks like a left turn.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Ellipse

__all__ = ["FIGSIZE", "DPI", "world_axes", "plot_world", "plot_covariance_ellipse",
           "plot_trajectory", "plot_robot", "plot_pose_errors", "covariance_ellipse_params",
           "plot_frame", "plot_covariance_blocks", "plot_trace", "plot_trace_errors",
           "plot_detection_scene"]

#: Default size (inches) and resolution of the course's figures (small PNGs in the notebooks).
FIGSIZE = (6.4, 4.8)
DPI = 80

TRUTH_STYLE = {"color": "tab:red", "lw": 1.6, "label": "ground truth"}
ESTIMATE_STYLE = {"color": "tab:blue", "lw": 1.4, "label": "estimate"}


def world_axes(ax=None, world=None, *, margin: float = 0.3, title: str | None = None):
    """Prepare a top view: x right, y down (z-down world seen from above), equal aspect.

    Parameters
    ----------
    ax : matplotlib Axes, optional
        A new figure of size :data:`FIGSIZE` if None.
    world : World, optional
        If given, the limits are the world's bounds plus ``margin``.

    Returns
    -------
    matplotlib Axes
    """
    if ax is None:
        _, ax = plt.subplots(figsize=FIGSIZE, dpi=DPI)
    # fixed limits (a world's bounds) need the box to adjust; free limits adjust the data range
    ax.set_aspect("equal", adjustable="box" if world is not None else "datalim")
    if world is not None:
        xmin, xmax, ymin, ymax = world.bounds
        ax.set_xlim(xmin - margin, xmax + margin)
        ax.set_ylim(ymin - margin, ymax + margin)
    if not ax.yaxis_inverted():
        ax.invert_yaxis()
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m), downwards: seen from above")
    ax.grid(True, lw=0.4, alpha=0.5)
    if title:
        ax.set_title(title)
    return ax


def plot_world(ax, world, *, ids: bool = True, facing: bool = True, color: str = "k",
               label: str | None = "markers (truth)", facing_length: float = 0.25,
               label_spread: float = 0.3):
    """Draw the markers as stars, with their ids and (optionally) their facing direction.

    An id is written up and to the right of its star, except when another marker
    lies within ``label_spread`` (m) to its right: then it goes to the left, so
    that the ids of two close markers do not run into each other.
    """
    p = world.positions
    ax.plot(p[:, 0], p[:, 1], "*", color=color, ms=9, label=label, zorder=4)
    if facing:
        for m in world.markers:
            ax.plot([m.x, m.x + facing_length * np.cos(m.yaw)],
                    [m.y, m.y + facing_length * np.sin(m.yaw)], "-", color=color, lw=0.8,
                    alpha=0.6)
    if ids:
        xy = np.array([[m.x, m.y] for m in world.markers], dtype=float).reshape(-1, 2)
        for i, m in enumerate(world.markers):
            d = np.hypot(xy[:, 0] - m.x, xy[:, 1] - m.y)
            d[i] = np.inf
            close = (d < label_spread) & ((xy[:, 0] > m.x)
                                          | ((xy[:, 0] == m.x) & (np.arange(len(d)) > i)))
            left = bool(np.any(close))
            ax.annotate(str(m.id), (m.x, m.y), textcoords="offset points",
                        xytext=(-4, 4) if left else (4, 4), ha="right" if left else "left",
                        fontsize=8, color=color)
    return ax


def covariance_ellipse_params(cov, nsigma: float = 2.0) -> tuple[float, float, float]:
    """Width, height and angle (degrees) of the ``nsigma`` ellipse of a 2x2 covariance."""
    cov = np.asarray(cov, dtype=float)[:2, :2]
    vals, vecs = np.linalg.eigh(0.5 * (cov + cov.T))
    vals = np.clip(vals, 0.0, None)
    angle = np.degrees(np.arctan2(vecs[1, 1], vecs[0, 1]))
    return 2.0 * nsigma * np.sqrt(vals[1]), 2.0 * nsigma * np.sqrt(vals[0]), float(angle)


def plot_covariance_ellipse(ax, mean, cov, nsigma: float = 2.0, *, color: str = "gold",
                            alpha: float = 0.35, fill: bool = True, **kwargs):
    """Draw the ``nsigma`` uncertainty ellipse of the position block of ``cov`` at ``mean``.

    ``cov`` may be the 3x3 pose covariance (its x-y block is used). In data
    coordinates, so it is right on an inverted y axis too.
    """
    w, h, angle = covariance_ellipse_params(cov, nsigma)
    e = Ellipse(xy=(float(mean[0]), float(mean[1])), width=w, height=h, angle=angle,
                facecolor=color if fill else "none", edgecolor=color,
                alpha=alpha, **kwargs)
    ax.add_patch(e)
    return e


def plot_robot(ax, pose, *, size: float = 0.15, color: str = "tab:green", **kwargs):
    """A triangle at ``pose`` pointing along the heading."""
    x, y, th = (float(v) for v in pose[:3])
    c, s = np.cos(th), np.sin(th)
    pts = np.array([[size, 0.0], [-0.5 * size, 0.5 * size], [-0.5 * size, -0.5 * size]])
    world = np.column_stack([x + c * pts[:, 0] - s * pts[:, 1], y + s * pts[:, 0] + c * pts[:, 1]])
    patch = plt.Polygon(world, closed=True, color=color, **kwargs)
    ax.add_patch(patch)
    return patch


def plot_trajectory(ax, poses, *, style: dict | None = None, **kwargs):
    """Draw the path of poses ``(n, 3)`` (or points ``(n, 2)``); ``style`` merged with kwargs."""
    poses = np.asarray(poses, dtype=float)
    opts = {**(style or {}), **kwargs}
    (line,) = ax.plot(poses[:, 0], poses[:, 1], **opts)
    return line


def plot_pose_errors(t, errors, sigmas=None, *, nsigma: float = 2.0, axes=None,
                     label: str = "error", color: str = "tab:blue", title: str | None = None):
    """Errors in x, y and theta against time, with the ``+-nsigma`` bands of the filter.

    Parameters
    ----------
    t : array_like (n,)
    errors : array_like (n, 3)
        Estimate minus truth (theta wrapped).
    sigmas : array_like (n, 3), optional
        Standard deviations from the covariance's diagonal.

    Returns
    -------
    (Figure, array of 3 Axes)
    """
    t = np.asarray(t, dtype=float)
    errors = np.asarray(errors, dtype=float)
    if axes is None:
        fig, axes = plt.subplots(3, 1, sharex=True, figsize=(6.4, 4.8), dpi=DPI)
    else:
        fig = axes[0].figure
    names = ["x error (m)", "y error (m)", "theta error (rad)"]
    for i, ax in enumerate(axes):
        ax.plot(t, errors[:, i], color=color, lw=1.0, label=label)
        if sigmas is not None:
            s = nsigma * np.asarray(sigmas, dtype=float)[:, i]
            ax.fill_between(t, -s, s, color="gold", alpha=0.35,
                            label=f"$\\pm{nsigma:g}\\sigma$")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(names[i], fontsize=8)
        ax.grid(True, lw=0.4, alpha=0.5)
    axes[-1].set_xlabel("t (s)")
    axes[0].legend(loc="upper left", fontsize=8)
    if title:
        axes[0].set_title(title)
    return fig, axes


# --------------------------------------------------------------------------- frames (chapter 00)
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


# ------------------------------------------------------------------------- filter runs (Figs. 4-8)
def plot_trace(ax, trace, world=None, *, ellipse_every: float = 5.0, nsigma: float = 2.0,
               show_map: bool = True, title: str | None = None, legend_outside: bool = False,
               estimate_label: str = "estimate"):
    """Top view of a filter run: truth (red), estimate (blue), ``nsigma`` pose ellipses
    every ``ellipse_every`` seconds, the true markers (stars) and, for SLAM, the mapped
    landmarks (plus signs) with their ellipses. The report's Figs. 4, 5 and 7.

    Parameters
    ----------
    ax : matplotlib Axes
        Prepared with :func:`world_axes` (done here if it is not yet inverted).
    trace : slamlib.experiments.Trace
    world : World, optional
        The true markers to draw.
    legend_outside : bool
        Put the legend to the right of the axes instead of inside.
    estimate_label : str
        The estimate's legend entry.
    """
    if not ax.yaxis_inverted():
        world_axes(ax, world)
    if world is not None:
        plot_world(ax, world, facing=False)
    plot_trajectory(ax, trace.truth, style=TRUTH_STYLE)
    plot_trajectory(ax, trace.x, style=ESTIMATE_STYLE, label=estimate_label)
    next_t = trace.t[0]
    first = True
    for k in range(trace.t.size):
        if trace.t[k] >= next_t:
            plot_covariance_ellipse(ax, trace.x[k], trace.P[k], nsigma,
                                    label=f"{nsigma:g}-sigma pose ellipse" if first else None)
            first = False
            next_t = trace.t[k] + ellipse_every
    lms = getattr(trace.filter, "landmarks", None)
    if show_map and lms and hasattr(trace.filter, "landmark_cov"):
        pts = np.array(list(lms.values()))
        ax.plot(pts[:, 0], pts[:, 1], "+", color="tab:blue", ms=10, mew=2,
                label="mapped landmarks", zorder=5)
        for i in lms:
            plot_covariance_ellipse(ax, lms[i], trace.filter.landmark_cov(i), nsigma,
                                    color="tab:blue", alpha=0.25)
    ax.plot(*trace.truth[0, :2], "o", color="k", ms=5, label="start")
    if legend_outside:
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
    else:
        ax.legend(loc="best", fontsize=7)
    if title:
        ax.set_title(title)
    return ax


def plot_trace_errors(trace, *, nsigma: float = 2.0, axes=None, title: str | None = None):
    """x, y, theta errors of a filter run with its ``nsigma`` bands (the report's Figs. 6, 8)."""
    return plot_pose_errors(trace.t, trace.error, trace.sigma, nsigma=nsigma, axes=axes,
                            title=title)


# ============================================================================ chapter 02 (vision)
# Added by the vision chapter: the camera mount (the report's Fig. 2), a camera frame with
# its detections (Fig. 3) and the error study of the camera pipeline.
__all__ += ["plot_camera_mount", "plot_camera_view", "plot_error_study"]


def _axis_arrow(ax, origin, direction, label, color, length=0.1):
    o = np.asarray(origin, dtype=float)
    e = o + length * np.asarray(direction, dtype=float)
    ax.annotate("", xy=e, xytext=o, arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.6})
    ax.annotate(label, e, textcoords="offset points", xytext=(3, 3), color=color, fontsize=9)


def plot_camera_mount(camera=None, *, robot_radius: float = 0.175, marker_height: float = 0.15,
                      axes=None):
    """The camera frame C against the robot frame B: top view and side view (report's Fig. 2).

    Top view: x_B to the right, y_B downwards (z-down seen from above). Side
    view: x_B to the right, z_B downwards, the floor ``base_height`` below B.
    """
    from .vision import default_camera

    cam = default_camera() if camera is None else camera
    T = cam.T_base_cam
    R, t = T[:3, :3], T[:3, 3]
    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(9.0, 4.0), dpi=DPI)
    top, side = axes
    # top view (x_B, y_B)
    top.add_patch(plt.Circle((0, 0), robot_radius, fc="0.9", ec="0.4"))
    _axis_arrow(top, (0, 0), (1, 0), "$x_B$", "tab:red")
    _axis_arrow(top, (0, 0), (0, 1), "$y_B$", "tab:green")
    top.plot(0, 0, "kx")
    top.annotate("$z_B$ into the page", (0, 0), textcoords="offset points", xytext=(-60, -14),
                 fontsize=8)
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
    side.annotate("floor", (-0.2, h), textcoords="offset points", xytext=(0, -12), fontsize=8)
    side.add_patch(plt.Rectangle((-robot_radius, h - 0.11), 2 * robot_radius, 0.1,
                                 fc="0.9", ec="0.4"))
    _axis_arrow(side, (0, 0), (1, 0), "$x_B$", "tab:red")
    _axis_arrow(side, (0, 0), (0, 1), "$z_B$", "tab:green")
    _axis_arrow(side, t[[0, 2]], R[[0, 2], 2], "$z_C$", "tab:blue", 0.08)
    _axis_arrow(side, t[[0, 2]], R[[0, 2], 1], "$y_C$", "tab:orange", 0.08)
    side.plot(t[0], t[2], "o", color="tab:blue", ms=5)
    side.axhline(h - marker_height, color="tab:gray", ls=":", lw=1)
    side.annotate(f"marker centres\n({marker_height:.2f} m up)", (-0.21, h - marker_height),
                  textcoords="offset points", xytext=(0, 3), fontsize=7, color="tab:gray")
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
        ax_std.legend(handles=ax_std.get_lines()[-1:], fontsize=7, loc="upper left")
        ax_b.legend(handles=ax_b.get_lines()[-1:], fontsize=7, loc="upper left")
    ax_det.set_ylabel("detection rate")
    ax_det.set_ylim(-0.05, 1.05)
    ax_bias.set_ylabel("range bias (cm)")
    ax_std.set_ylabel("range std (cm)")
    ax_b.set_ylabel("bearing std (deg)")
    for ax in (ax_std, ax_b):
        ax.set_xlabel("true range (m)")
    for ax in (ax_det, ax_bias, ax_std, ax_b):
        ax.grid(True, lw=0.4, alpha=0.5)
    ax_det.legend(fontsize=7, title="viewing angle", title_fontsize=7)
    if model is not None:
        ax_bias.legend(handles=ax_bias.get_lines()[-1:], fontsize=7, loc="upper left")
    return axes


# ------------------------------------------------------------------ consistency bands (chapter 03)
# Added by the chapter on the map-based EKF (NIS and NEES against chi-square bands).
__all__ += ["chi2_band_per_sample", "plot_chi2_series"]


def chi2_band_per_sample(dof, prob: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided ``prob`` band of ONE chi-square sample with ``dof`` degrees of freedom.

    ``(chi2.ppf((1-prob)/2, dof), chi2.ppf((1+prob)/2, dof))``, elementwise for an
    array of ``dof`` (e.g. a joint NIS with 2m degrees of freedom, m varying).
    """
    from scipy.stats import chi2

    dof = np.asarray(dof, dtype=float)
    if not 0.0 < prob < 1.0:
        raise ValueError(f"prob: expected a probability in (0, 1), got {prob}")
    if np.any(dof <= 0) or not np.all(np.isfinite(dof)):
        raise ValueError("dof: expected positive degrees of freedom")
    return chi2.ppf(0.5 * (1.0 - prob), dof), chi2.ppf(0.5 * (1.0 + prob), dof)


def plot_chi2_series(ax, t, values, dof, *, prob: float = 0.95, per_dof: bool = False,
                     label: str = "value", color: str = "tab:blue", ms: float = 3.0,
                     band_label: str | None = None) -> float:
    """Chi-square distributed values (NIS, NEES, d2) against time, with the ``prob`` band.

    Each value is one sample of a chi-square with its ``dof`` (a scalar or one
    per value). The band of a single sample (:func:`chi2_band_per_sample`) is
    drawn in gold, values outside it in red; with ``per_dof`` the values and
    the band are divided by ``dof`` (so that updates with different numbers of
    readings share one axis). The y axis is logarithmic.

    Returns
    -------
    float
        The fraction of the values outside the band (``1 - prob`` expected for
        independent samples of a consistent filter).
    """
    t = np.asarray(t, dtype=float)
    v = np.asarray(values, dtype=float)
    d = np.broadcast_to(np.asarray(dof, dtype=float), v.shape)
    if t.shape != v.shape:
        raise ValueError(f"t, values: expected equal shapes, got {t.shape} and {v.shape}")
    lo, hi = chi2_band_per_sample(d, prob)
    scale = d if per_dof else np.ones_like(d)
    out = (v < lo) | (v > hi)
    ax.fill_between(t, lo / scale, hi / scale, step="mid", color="gold", alpha=0.45, lw=0,
                    label=band_label or f"{100 * prob:g}% band of one sample")
    ax.plot(t[~out], v[~out] / scale[~out], ".", ms=ms, color=color, label=label)
    ax.plot(t[out], v[out] / scale[out], ".", ms=ms + 1, color="tab:red",
            label=f"outside ({np.mean(out):.1%})")
    ax.set_yscale("log")
    ax.grid(True, lw=0.4, alpha=0.5)
    return float(np.mean(out)) if v.size else float("nan")


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
    from .models import compose_point
    from .vision import detect_markers, draw_detections, render_view

    pose = np.asarray(pose, dtype=float)
    gray = render_view(world, pose, camera, rng=rng)
    det = detect_markers(gray, camera, world.marker_length, world.dictionary)
    fig = plt.figure(figsize=(11, 4.4), dpi=DPI)
    top = 0.85 if title else 0.92          # room for the figure's title
    ax_img = fig.add_axes([0.02, 0.1, 0.58, top - 0.1])
    drawn = draw_detections(gray, det, camera, world.marker_length)
    plot_camera_view(ax_img, drawn, title="camera view, detections and marker axes")
    if zoom is not None:
        u0, u1, v0, v1 = (int(round(v)) for v in zoom)
        inset = ax_img.inset_axes([0.02, 0.5, 0.96, 0.47])
        inset.imshow(drawn[v0:v1, u0:u1, ::-1], extent=(u0 - 0.5, u1 - 0.5, v1 - 0.5, v0 - 0.5))
        inset.set_xticks([])
        inset.set_yticks([])
        ax_img.indicate_inset_zoom(inset, edgecolor="tab:orange")
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


# ------------------------------------------------------------ Monte-Carlo NEES (chapter 06)
# Added by the chapter on what the report discussed (consistency over many runs).
__all__ += ["plot_nees_monte_carlo"]


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
    from .metrics import chi2_band

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
             "ideal": "ideal EKF SLAM"}
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
        ax.legend(fontsize=7, loc="upper left")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig, axes


# --------------------------------------------------------------------------- chapter 08
__all__ += ["plot_latency_study", "LATENCY_METHOD_STYLES"]

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
        axes[legend_panel].legend(fontsize=7, loc=legend_loc)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig, axes


# --------------------------------------------------------------------------- chapter 05
# Added by the chapter on EKF SLAM with gating: where a wrong map entry is, the errors of
# several runs side by side, and the NEES of one run against many.
__all__ += ["plot_map_errors", "plot_error_comparison", "plot_nees_per_run"]


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
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=7)
    return misplaced, spurious


def plot_error_comparison(traces, *, colors=("tab:red", "tab:blue", "tab:green", "tab:purple"),
                          marks=None, mark_label: str = "", axes=None,
                          position_ylim=(1e-3, 10.0)):
    """Position error (log scale) and heading error of several runs against time (chapter 05).

    Parameters
    ----------
    traces : dict name -> Trace
        One line per run (:mod:`slamlib.experiments`).
    marks : array_like of float, optional
        Times to tick at the bottom of the position panel (e.g. misread readings).
    mark_label : str
        Legend label of the ticks.
    axes : two Axes (sharing x), optional

    Returns
    -------
    (Figure, axes)
    """
    if axes is None:
        fig, axes = plt.subplots(2, 1, sharex=True, figsize=(8, 4.8), dpi=DPI)
    fig = axes[0].figure
    for (name, tr), color in zip(traces.items(), colors):
        axes[0].semilogy(tr.t, np.hypot(tr.error[:, 0], tr.error[:, 1]), color=color, lw=1,
                         label=name)
        axes[1].plot(tr.t, np.degrees(tr.error[:, 2]), color=color, lw=1, label=name)
    lo, hi = position_ylim
    if marks is not None and len(marks):
        marks = np.asarray(marks, dtype=float)
        axes[0].plot(marks, np.full(marks.size, 2.0 * lo), "|", color="k", ms=8,
                     label=mark_label or None)
    axes[0].set_ylabel("position error (m)")
    axes[0].set_ylim(lo, hi)
    axes[1].set_ylabel("heading error (deg)")
    axes[1].set_xlabel("t (s)")
    axes[0].legend(fontsize=8, loc="upper left", ncol=3)
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
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
        ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    return fig, axes


# --------------------------------------------------------------------------- chapters 03, 04
# Added by the chapters on the map-based EKF (a zoomed top view, the d^2 histogram against
# its chi-square density) and on the inverse observation (a Monte-Carlo cloud against its
# linearised Gaussian).
__all__ += ["plot_trace_zoom", "plot_d2_histogram", "plot_inverse_cloud"]


def plot_trace_zoom(ax, az, trace, box, *, ellipse_every: float = 0.5,
                    title: str | None = None):
    """A zoomed top view of a filter run next to the whole one (chapter 03, Fig. 5).

    Draws the zoom area ``box = (x_from, x_to, y_from, y_to)`` (m) as a dashed
    rectangle on ``ax`` (a top view already drawn, e.g. with :func:`plot_trace`)
    and the run on ``az`` limited to that box, with pose ellipses every
    ``ellipse_every`` seconds, y down and no legend (the big view has it).
    """
    x0, x1, y0, y1 = box
    ax.add_patch(plt.Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ls="--", lw=0.8,
                               color="k"))
    world_axes(az, title=title or f"zoom (dashed box): ellipses every {ellipse_every:g} s")
    plot_trace(az, trace, ellipse_every=ellipse_every)
    az.set_aspect("equal", adjustable="box")
    az.set_xlim(x0, x1)
    az.set_ylim(y1, y0)                                # y down
    legend = az.get_legend()
    if legend is not None:
        legend.remove()
    return az


def plot_d2_histogram(ax, d2, *, dof: int = 2, threshold: float | None = None,
                      clip: float = 20.0, n_bins: int = 40, color: str = "tab:blue",
                      label: str = "d² of the readings"):
    """Histogram of squared Mahalanobis distances against the chi-square density (chapter 03).

    Values at or above ``clip`` are counted in the last bin (so an over-confident
    filter's tail stays visible); ``threshold`` draws the gate as a dashed line.
    NaN values (readings that were not gated) are ignored.

    Returns
    -------
    float
        The fraction of the values at or above ``clip`` (the last bin's overflow).
    """
    from scipy.stats import chi2

    d2 = np.asarray(d2, dtype=float)
    d2 = d2[np.isfinite(d2)]
    bins = np.linspace(0.0, clip, n_bins + 1)
    ax.hist(np.minimum(d2, np.nextafter(clip, 0.0)), bins=bins, density=True, color=color,
            alpha=0.6, label=label)
    s = np.linspace(0.01, clip, 300)
    ax.plot(s, chi2.pdf(s, dof), "k", lw=1.2, label=f"chi-square, {dof} dof")
    if threshold is not None and np.isfinite(threshold):
        ax.axvline(threshold, color="k", ls="--", lw=0.8, label=f"gate {threshold:.2f}")
    ax.set_xlabel(f"d² (last bin: {clip:g} and above)")
    ax.set_ylabel("density")
    ax.legend(fontsize=7)
    return float(np.mean(d2 >= clip)) if d2.size else float("nan")


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
    ax.legend(fontsize=7, loc=legend_loc)
    return ax


# ======================================================================= chapter 07 (exploration)
# Added by the exploration chapter: the coverage grid, a closed-loop exploration seen from above,
# and its history (coverage, landmarks, position error) against time.
__all__ += ["plot_coverage", "plot_exploration", "plot_exploration_history"]

RETURN_STYLE = {"color": "tab:orange", "lw": 0, "marker": ".", "ms": 3,
                "label": "estimate while returning"}


def plot_coverage(ax, grid, *, color: str = "tab:green", alpha: float = 0.18,
                  label: str | None = "cells seen"):
    """Shade the seen cells of a :class:`slamlib.explore.CoverageGrid` on a top view."""
    from matplotlib.colors import ListedColormap

    xmin, xmax, ymin, ymax = grid.bounds
    rows, cols = grid.shape
    extent = (xmin, xmin + cols * grid.cell, ymin, ymin + rows * grid.cell)
    inverted = ax.yaxis_inverted()
    img = np.ma.masked_where(~grid.seen, np.ones(grid.shape))
    ax.imshow(img, origin="lower", extent=extent, cmap=ListedColormap([color]), alpha=alpha,
              interpolation="nearest", aspect="equal", zorder=0)
    if inverted and not ax.yaxis_inverted():          # imshow re-orders the y limits
        ax.invert_yaxis()
    if label:
        ax.fill([], [], color=color, alpha=alpha, label=label)     # the legend's entry
    return ax


def plot_exploration(ax, exploration, world=None, *, ellipse_every: float = 20.0,
                     nsigma: float = 2.0, title: str | None = None, legend_outside: bool = True):
    """Top view of a closed-loop exploration (chapter 07).

    The seen cells (shaded), truth (red) and estimate (blue, orange dots while
    returning to a landmark) with ``nsigma`` pose ellipses, the true markers
    (stars, a ring around the anchors of the returns) and the mapped landmarks.

    Parameters
    ----------
    exploration : slamlib.explore.Exploration
    world : World, optional
    """
    if not ax.yaxis_inverted():
        world_axes(ax, world)
    pol = exploration.policy
    if getattr(pol, "grid", None) is not None:
        plot_coverage(ax, pol.grid)
        if world is not None:
            world_axes(ax, world)
    tr = exploration.trace
    plot_trace(ax, tr, world, ellipse_every=ellipse_every, nsigma=nsigma,
               legend_outside=legend_outside)
    returns = getattr(pol, "returns", [])
    if returns:
        mask = np.zeros(tr.t.size, dtype=bool)
        for t0, t1, *_ in returns:
            mask |= (tr.t >= t0) & (tr.t <= t1)
        ax.plot(tr.x[mask, 0], tr.x[mask, 1], zorder=3, **RETURN_STYLE)
        if world is not None:
            anchors = sorted({r[2] for r in returns if r[2] in set(world.ids.tolist())})
            pts = np.array([world.marker(i).position for i in anchors]).reshape(-1, 2)
            ax.plot(pts[:, 0], pts[:, 1], "o", mfc="none", mec="tab:orange", ms=14, mew=1.5,
                    label="anchor of a return", zorder=5)
    ax.plot(*tr.truth[-1, :2], "s", color="k", ms=5, label="end (truth)")
    if legend_outside:
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
    else:
        ax.legend(loc="best", fontsize=7)
    if title:
        ax.set_title(title)
    return ax


def plot_exploration_history(exploration, *, nsigma: float = 2.0, axes=None,
                             title: str | None = None):
    """Coverage, mapped landmarks and position error (with its ``nsigma`` bound) against time.

    The returns to a landmark are shaded. ``sigma_xy = sqrt(P_xx + P_yy)``.

    Returns
    -------
    (Figure, axes)
    """
    from matplotlib.ticker import MaxNLocator

    h = exploration.history()
    own = axes is None
    if own:
        fig, axes = plt.subplots(3, 1, figsize=(7.2, 6.0), dpi=DPI, sharex=True)
    fig = axes[0].figure
    axes[0].plot(h["t"], 100 * h["coverage"], color="tab:green")
    axes[0].set_ylabel("coverage (%)")
    axes[0].set_ylim(0, 100)
    axes[1].step(h["t"], h["landmarks"], where="post", color="tab:blue")
    axes[1].set_ylabel("landmarks mapped")
    axes[1].yaxis.set_major_locator(MaxNLocator(nbins=5, integer=True))
    axes[2].plot(h["t"], h["error_xy"], color="tab:red", label="position error (truth)")
    axes[2].plot(h["t"], nsigma * h["sigma_xy"], "--", color="tab:blue",
                 label=f"{nsigma:g} sigma_xy (filter)")
    axes[2].set_ylabel("position (m)")
    axes[2].set_xlabel("t (s)")
    axes[2].set_ylim(bottom=0)
    first = True
    for t0, t1, *_ in getattr(exploration.policy, "returns", []):
        for ax in axes:
            ax.axvspan(t0, t1, color="tab:orange", alpha=0.2,
                       label="return to a landmark" if (first and ax is axes[2]) else None)
        first = False
    sr = getattr(exploration.policy, "sigma_return", None)
    if sr is not None:
        axes[2].axhline(nsigma * sr, color="tab:orange", lw=0.8, ls=":",
                        label=f"{nsigma:g} x return threshold")
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
    axes[2].legend(fontsize=7, loc="upper left")
    if title:
        axes[0].set_title(title)
    if own:
        fig.tight_layout()
    return fig, axes


def plot_nees_averages(curves, n_runs: int, *, axes=None, prob: float = 0.95,
                       title: str | None = None,
                       colors=("tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange")):
    """Monte-Carlo average NEES curves against their band (chapter 06, stored studies).

    Parameters
    ----------
    curves : dict label -> (t, average pose NEES, average heading NEES)
        One curve per filter (arrays of the same length T), e.g. from
        :func:`slamlib.studies.summarise`'s ``t``, ``avg``, ``avg_heading``.
    n_runs : int
        Runs in each average (the band is :func:`slamlib.metrics.chi2_band`
        ``(dof, n_runs, prob)``, valid at each instant).
    axes : two Axes, optional

    Returns
    -------
    (Figure, axes)
    """
    from .metrics import chi2_band

    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(11, 3.4), dpi=DPI)
    fig = axes[0].figure
    for ax, k, dof, name in ((axes[0], 1, 3, "pose NEES"), (axes[1], 2, 1, "heading NEES")):
        lo, hi = chi2_band(dof, n_runs, prob)
        t_all = np.concatenate([np.asarray(c[0]) for c in curves.values()])
        ax.fill_between([t_all.min(), t_all.max()], lo, hi, color="gold", alpha=0.45, lw=0,
                        label=f"{100 * prob:g}% band, average of {n_runs} runs")
        ax.axhline(dof, color="k", lw=0.8, ls=":")
        for (label, c), col in zip(curves.items(), colors):
            ax.plot(c[0], c[k], color=col, lw=1.2, label=label)
        ax.set_yscale("log")
        ax.set_xlabel("t (s)")
        ax.set_ylabel(f"average {name}")
        ax.grid(True, lw=0.4, alpha=0.5, which="both")
    axes[0].legend(fontsize=7, loc="upper left")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig, axes
