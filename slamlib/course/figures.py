"""Every figure of the report and of the course as files: ``python -m slamlib.course.figures OUT``.

``make figures`` calls this. Each figure is written as PNG and PDF under the
report's numbering (``fig4_prediction_only.png``...) or a ``course_`` name,
from the recorded runs in ``data/runs`` and fixed seeds, so the files are the
same byte for byte on every run with the same library versions. A table of
each filter run's metrics is printed at the end.

The figures are drawn by the same functions the chapters call
(:mod:`slamlib.course.plots`, the chapters' ``plots_chNN``, :mod:`slamlib.runner`);
nothing here computes anything a chapter does not.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .. import runner  # noqa: E402
from ..runs import load_run  # noqa: E402
from . import (  # noqa: E402
    plots,
    plots_ch02,
    plots_ch05,
    plots_ch06,
    plots_ch07,
    plots_ch08,
    studies_ch06,  # noqa: E402
)

__all__ = ["FIGURES", "make_figures", "save_figure", "main"]

#: Metadata that would change from run to run is left out of the files.
PNG_METADATA = {"Software": None}
PDF_METADATA = {"CreationDate": None, "ModDate": None, "Producer": None, "Creator": None}


def save_figure(fig, out: Path, name: str, dpi: int = 150) -> list[Path]:
    """Write ``fig`` as ``name.png`` and ``name.pdf`` in ``out``, reproducibly."""
    out.mkdir(parents=True, exist_ok=True)
    png, pdf = out / f"{name}.png", out / f"{name}.pdf"
    fig.savefig(png, dpi=dpi, metadata=PNG_METADATA)
    fig.savefig(pdf, metadata=PDF_METADATA)
    plt.close(fig)
    return [png, pdf]


class _Context:
    """Runs and traces computed once and shared by the figures that need them."""

    def __init__(self):
        self._cache: dict = {}
        self.metrics: list[tuple[str, dict]] = []

    def get(self, key: str, make: Callable):
        if key not in self._cache:
            self._cache[key] = make()
        return self._cache[key]

    def run(self, name: str):
        return self.get(f"run:{name}", lambda: load_run(name))

    def trace(self, label: str, run_name: str, method: str, **kw):
        def make():
            run = self.run(run_name)
            tr = getattr(runner, method)(run, **kw)
            self.metrics.append((label, tr.metrics(run.world())))
            return tr
        return self.get(f"trace:{label}", make)


# --------------------------------------------------------------------------- the report's figures
def fig2_camera_to_robot(ctx: _Context):
    from ..vision import default_camera
    axes = plots_ch02.plot_camera_mount(default_camera())
    fig = np.ravel(axes)[0].figure
    fig.suptitle("Fig. 2: the camera frame C and the robot frame B")
    fig.tight_layout()
    return fig


def fig3_feature_detection(ctx: _Context):
    from ..vision import default_camera
    world = ctx.run("arena_loop").world()
    fig, _ = plots_ch02.plot_detection_scene(world, world.start_pose, default_camera(),
                                           rng=np.random.default_rng(2))
    fig.axes[0].set_title("Fig. 3: the camera's view from the start pose, markers detected")
    return fig


def course_vision_error_study(ctx: _Context):
    from .. import vision
    study = vision.error_study(distances=(0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0),
                               angles_deg=(0.0, 15.0, 30.0, 45.0, 60.0, 75.0), samples=20,
                               seed=1)
    model = vision.fit_noise_model(study, max_angle_deg=60)
    axes = plots_ch02.plot_error_study(study, model)
    fig = np.ravel(axes)[0].figure
    fig.suptitle("Camera pipeline against ground truth (0.15 m markers, 640x480, f = 525 px)")
    fig.tight_layout()
    return fig


def fig4_prediction_only(ctx: _Context):
    run = ctx.run("arena_loop")
    tr = ctx.trace("arena_loop: dead reckoning", "arena_loop", "dead_reckoning")
    ax = plots.world_axes(world=run.world())
    plots.plot_trace(ax, tr, run.world(), title="Fig. 4: prediction only (dead reckoning)")
    return ax.figure


def fig5_map_based_ekf(ctx: _Context):
    run = ctx.run("arena_loop")
    tr = ctx.trace("arena_loop: map-based EKF", "arena_loop", "localization")
    ax = plots.world_axes(world=run.world())
    plots.plot_trace(ax, tr, run.world(), title="Fig. 5: map-based EKF")
    return ax.figure


def fig6_map_based_ekf_errors(ctx: _Context):
    tr = ctx.trace("arena_loop: map-based EKF", "arena_loop", "localization")
    fig, _ = plots.plot_trace_errors(tr, title="Fig. 6: map-based EKF errors, 2-sigma bounds")
    return fig


def fig7_slam(ctx: _Context):
    run = ctx.run("arena_loop")
    tr = ctx.trace("arena_loop: EKF SLAM", "arena_loop", "slam")
    ax = plots.world_axes(world=run.world())
    plots.plot_trace(ax, tr, run.world(), title="Fig. 7: EKF SLAM with gating")
    return ax.figure


def fig8_slam_errors(ctx: _Context):
    tr = ctx.trace("arena_loop: EKF SLAM", "arena_loop", "slam")
    fig, _ = plots.plot_trace_errors(tr, title="Fig. 8: EKF SLAM errors, 2-sigma bounds")
    return fig


# --------------------------------------------------------------------------- the course's own
def _gating_label(gate: float | None) -> str:
    return "no gating" if gate is None else f"chi-square gate {gate:g}"


def _misreads_slam(ctx: _Context, gate: float | None):
    return ctx.trace(f"arena_loop_misreads: SLAM, {_gating_label(gate)}", "arena_loop_misreads",
                     "slam", gate=gate)


def course_gating_misreads(ctx: _Context):
    run = ctx.run("arena_loop_misreads")
    world = run.world()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.6), dpi=plots.DPI)
    for ax, gate in zip(axes, (None, 0.95)):
        tr = _misreads_slam(ctx, gate)
        label = _gating_label(gate)
        plots.world_axes(ax, world)
        plots.plot_trace(ax, tr, world, ellipse_every=1e9, show_map=True,
                            title=f"misread ids, {label}: ATE {tr.metrics()['ate_xy']:.2f} m")
    fig.tight_layout()
    return fig


def course_gating_errors(ctx: _Context):
    fig, ax = plt.subplots(figsize=(6.4, 3.2), dpi=plots.DPI)
    for gate, color in ((None, "tab:red"), (0.95, "tab:blue")):
        tr = _misreads_slam(ctx, gate)
        ax.plot(tr.t, np.hypot(tr.error[:, 0], tr.error[:, 1]), color=color,
                label=_gating_label(gate))
    ax.set_xlabel("t (s)")
    ax.set_ylabel("position error (m)")
    ax.set_title("SLAM with misread ids: position error")
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend()
    fig.tight_layout()
    return fig


def course_random_world_slam(ctx: _Context):
    run = ctx.run("random_loop")
    tr = ctx.trace("random_loop: EKF SLAM", "random_loop", "slam")
    ax = plots.world_axes(world=run.world())
    plots.plot_trace(ax, tr, run.world(), title="EKF SLAM in a random marker world")
    return ax.figure


def course_nees_monte_carlo(ctx: _Context):
    from .. import studies
    mc = ctx.get("mc:arena_loop", lambda: studies.monte_carlo(
        "arena_loop", ("localization", "slam"), range(1000, 1020), step=0.5))
    fig, _ = plots_ch05.plot_nees_monte_carlo(
        mc, title="Monte-Carlo NEES, arena_loop, 20 seeded runs (chapter 06)")
    return fig


def course_nees_fej(ctx: _Context):
    """Chapter 06: EKF SLAM, the ideal EKF and FEJ over 100 seeds (stored by ``make studies``)."""
    stored = studies_ch06.load_ch06_studies()
    names = {"slam": "EKF SLAM", "fej": "FEJ EKF SLAM",
             "ideal": "ideal (Jacobians at the truth, landmarks initialised at the estimate)",
             "ideal_init": "ideal, landmarks initialised at the truth too"}
    fig, axes = plt.subplots(2, 2, figsize=(11, 6.4), dpi=plots.DPI)
    for row, (key, title) in zip(axes, (("arena_0.10", "arena loop, sigma_wheel 0.10 m/s"),
                                        ("laps_0.10", "three laps, sigma_wheel 0.10 m/s"))):
        ms = stored["studies"][key]["methods"]
        curves = {names[m]: (np.array(s["t"]), np.array(s["avg"]), np.array(s["avg_heading"]))
                  for m, s in ms.items()}
        plots_ch06.plot_nees_averages(curves, len(stored["seeds"]), axes=row)
        row[0].set_title(title, fontsize=9)
    fig.tight_layout()
    return fig


def course_camera_delay(ctx: _Context):
    """Chapter 08: 0.3 s late frames fused on arrival (left) and at their capture time
    (right), and the errors of both against the latency (bottom)."""
    from .. import delay

    latency = 0.3
    run = delay.delayed_run(latency)
    world = run.world()
    fig, axes = plt.subplots(2, 2, figsize=(10, 8.4), dpi=plots.DPI,
                             gridspec_kw={"height_ratios": [1.25, 1]})
    for ax, method in zip(axes[0], ("naive", "fixed")):
        tr = delay.run_method(run, method, "slam")
        m = tr.metrics(world)
        ctx.metrics.append((f"arena_loop, camera {latency:g} s late: SLAM, {method}", m))
        plots.world_axes(ax, world)
        plots.plot_trace(ax, tr, world, ellipse_every=1e9,
                            title=f"{latency:g} s late frames, {method}: ATE {m['ate_xy']:.2f} m, "
                                  f"map {m['map_rmse']:.2f} m")
    rows = delay.latency_study((0.0, 0.1, 0.2, 0.3, 0.5), kind="slam")
    plots_ch08.plot_latency_study(rows, ("ate_xy", "map_rmse"), axes=axes[1], legend_panel=1,
                                legend_loc="upper left")
    fig.suptitle("EKF SLAM with a late camera (arena loop)")
    fig.tight_layout()
    return fig


def _exploration(ctx: _Context):
    from ..explore import Explorer, exploration_world, explore

    def make():
        world = exploration_world(seed=5)
        ex = explore(world, seed=5, duration=180.0, explorer=Explorer(sigma_return=0.1))
        ctx.metrics.append(("random_15_seed5: exploration, return rule 0.1 m",
                            ex.trace.metrics(world)))
        return world, ex
    return ctx.get("exploration", make)


def course_exploration(ctx: _Context):
    world, ex = _exploration(ctx)
    fig, ax = plt.subplots(figsize=(9.0, 6.2), dpi=plots.DPI)
    plots.world_axes(ax, world)
    plots_ch07.plot_exploration(ax, ex, world,
                              title="Exploration steered by the SLAM estimate (chapter 07)")
    fig.tight_layout()
    return fig


def course_exploration_history(ctx: _Context):
    _, ex = _exploration(ctx)
    fig, _ = plots_ch07.plot_exploration_history(
        ex, title="Exploration: coverage, map and position error, returns shaded")
    return fig


#: name -> function(ctx) -> Figure, in the order they are made.
FIGURES: dict[str, Callable] = {
    "fig2_camera_to_robot": fig2_camera_to_robot,
    "fig3_feature_detection": fig3_feature_detection,
    "fig4_prediction_only": fig4_prediction_only,
    "fig5_map_based_ekf": fig5_map_based_ekf,
    "fig6_map_based_ekf_errors": fig6_map_based_ekf_errors,
    "fig7_slam": fig7_slam,
    "fig8_slam_errors": fig8_slam_errors,
    "course_gating_misreads": course_gating_misreads,
    "course_gating_errors": course_gating_errors,
    "course_random_world_slam": course_random_world_slam,
    "course_vision_error_study": course_vision_error_study,
    "course_nees_monte_carlo": course_nees_monte_carlo,
    "course_nees_fej": course_nees_fej,
    "course_camera_delay": course_camera_delay,
    "course_exploration": course_exploration,
    "course_exploration_history": course_exploration_history,
}


def metrics_table(rows: list[tuple[str, dict]]) -> str:
    """The printed table: one line per filter run."""
    head = (f"{'run':<48} {'ATE xy (m)':>10} {'ATE th (rad)':>12} {'mean NEES':>10} "
            f"{'landmarks':>9} {'map RMSE (m)':>12}")
    lines = [head, "-" * len(head)]
    for label, m in rows:
        lm = f"{m['landmarks']:.0f}" if "landmarks" in m else "-"
        me = f"{m['map_rmse']:.3f}" if "map_rmse" in m else "-"
        lines.append(f"{label:<48} {m['ate_xy']:>10.3f} {m['ate_theta']:>12.4f} "
                     f"{m['mean_nees']:>10.2f} {lm:>9} {me:>12}")
    return "\n".join(lines)


def make_figures(out: Path, only: list[str] | None = None) -> list[tuple[str, dict]]:
    """Write the figures (all, or those named in ``only``) into ``out``; return the metrics."""
    names = list(FIGURES) if not only else only
    unknown = [n for n in names if n not in FIGURES]
    if unknown:
        raise ValueError(f"only: unknown figure(s) {unknown}; known: {list(FIGURES)}")
    plt.rcParams.update({"figure.dpi": plots.DPI, "savefig.bbox": "standard"})
    ctx = _Context()
    for name in names:
        files = save_figure(FIGURES[name](ctx), out, name)
        print(f"wrote {files[0]} and .pdf")
    return ctx.metrics


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m slamlib.course.figures",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("out", type=Path, help="output folder (created)")
    ap.add_argument("--only", nargs="*", help="figure names (default: all)")
    args = ap.parse_args(argv)
    rows = make_figures(args.out, args.only)
    if rows:
        print()
        print(metrics_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
