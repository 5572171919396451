"""Chapter 10 (real robots): the exercise's checker and the chapter's helpers.

:func:`check_wheel_speeds_from_commands` checks a student's conversion of a
logged command ``(v, w_up)`` (forward speed, z-up yaw rate) into the wheel
speeds ``[V_R, V_L]`` the course's filters take (z-down: ``w = (V_L - V_R)/b``).
"""

from __future__ import annotations

import numpy as np

from .harness import call, name_of, not_ready, printer

__all__ = ["check_wheel_speeds_from_commands"]


def _reference(v: float, w_up: float, b: float) -> np.ndarray:
    # solve  (V_R + V_L)/2 = v  and  (V_L - V_R)/b = -w_up  as a linear system
    A = np.array([[0.5, 0.5], [-1.0 / b, 1.0 / b]])
    return np.linalg.solve(A, np.array([v, -w_up]))


def check_wheel_speeds_from_commands(fn, n_points: int = 12, seed: int = 10,
                                     verbose: bool = True) -> bool:
    """Check ``fn(v, w_up, b) -> [V_R, V_L]`` at ``n_points`` seeded commands (chapter 10).

    The reference solves ``(V_R + V_L)/2 = v``, ``(V_L - V_R)/b = -w_up`` as a
    2x2 linear system. Known mistakes are named: the z-up formula (the yaw
    rate not negated, equivalently the wheels swapped), ``b w`` instead of
    ``b w / 2`` (or ``w / b``), the pair returned as ``[V_L, V_R]``.
    """
    say = printer(verbose)
    name = name_of(fn)
    rng = np.random.default_rng(seed)
    cases = [(float(rng.uniform(-0.1, 0.3)), float(rng.uniform(-1.0, 1.0)),
              float(rng.choice([0.23, 0.26, 0.35]))) for _ in range(n_points)]
    for v, w, b in cases:
        out, problem = call(fn, v, w, b)
        if problem:
            say(not_ready(name, problem, "it"))
            return False
        try:
            got = np.asarray(out, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            say(f"{name}: expected a pair [V_R, V_L] of numbers, got {out!r}.")
            return False
        if got.shape != (2,):
            say(f"{name}: expected a pair [V_R, V_L], got {got.size} value(s).")
            return False
        ref = _reference(v, w, b)
        if np.allclose(got, ref, atol=1e-12, rtol=1e-9):
            continue
        where = f"at v = {v:.3f} m/s, w_up = {w:.3f} rad/s, b = {b} m"
        hints = {
            "the yaw rate is not negated: that is the z-up formula w = (V_R - V_L)/b. "
            "In the course's z-down frame w_down = -w_up = (V_L - V_R)/b": ref[::-1],
            "the difference of the wheel speeds is b w, so each wheel differs from v by "
            "b w / 2, not b w": v + (ref - v) * 2.0,
            "each wheel differs from v by b w / 2 (a speed), not w / (2 b)":
                v + (ref - v) / (b * b),
        }
        for hint, val in hints.items():
            if np.allclose(got, val, atol=1e-12, rtol=1e-9):
                say(f"{name}: wrong {where}: got [{got[0]:.4f}, {got[1]:.4f}], expected "
                    f"[{ref[0]:.4f}, {ref[1]:.4f}]. Hint: {hint}.")
                return False
        say(f"{name}: wrong {where}: got [{got[0]:.4f}, {got[1]:.4f}], expected "
            f"[V_R, V_L] = [{ref[0]:.4f}, {ref[1]:.4f}] (their mean is v, their difference "
            f"V_L - V_R is -b w_up).")
        return False
    say(f"{name}: correct. [V_R, V_L] match at {n_points} commands (wheel bases 0.23 to "
        f"0.35 m), and the filter's motion model gives back v and -w_up.")
    return True


# --------------------------------------------------------------------------- chapter helpers
def identify_from(logs):
    """Odometry calibration and reading noise identified from ``logs`` (pooled)."""
    from ..datasets import identify

    logs = list(logs)
    cal = identify.calibrate_odometry(logs)
    res = identify.ReadingResiduals.concatenate(identify.reading_residuals(lg) for lg in logs)
    return cal, identify.fit_reading_noise(res), res


def load_identified(folder, robot: int, cal, noise, wheel_base: float = 0.23):
    """Robot ``robot``'s log with the commands calibrated and the identified Q and R(rho)."""
    from ..datasets import mrclam

    return mrclam.load(folder, robot, unknown_barcodes="drop", wheel_base=wheel_base,
                       command_scale=(cal.scale_v, cal.scale_w), command_delay=cal.delay,
                       noise={"Q": cal.Q(wheel_base), **noise.params()})


def reading_statuses(trace) -> np.ndarray:
    """Every reading's status in the order of the log's readings (one update per frame)."""
    return np.array([s for _, rep in trace.reports for s in rep.status])


def plot_paths(ax, logs, world):
    """The robots' Vicon paths and the landmarks, seen from above (z-down)."""
    from . import plots

    plots.world_axes(ax)
    pts = np.vstack([world.positions] + [lg.truth[:, :2] for lg in logs.values()])
    lo, hi = pts.min(axis=0) - 0.3, pts.max(axis=0) + 0.3
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(hi[1], lo[1])                  # y downwards: z-down seen from above
    for r, lg in logs.items():
        ax.plot(lg.truth[:, 0], lg.truth[:, 1], lw=0.9, label=f"robot {r}")
        ax.plot(*lg.start_pose[:2], "o", color=ax.lines[-1].get_color(), ms=5)
    pos = world.positions
    ax.plot(pos[:, 0], pos[:, 1], "ks", ms=5, label="landmarks")
    for i, p in world.landmarks().items():
        ax.annotate(str(i), p, xytext=(3, 3), textcoords="offset points", fontsize=7)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return ax


def plot_yaw_rates(ax, log, cal, span: float = 40.0, start: float = 20.0):
    """Vicon's yaw rate against the logged command and the calibrated one (z-down)."""
    from ..datasets import identify

    raw = identify.odometry_windows(log, window=0.25)
    fit = identify.odometry_windows(log, window=0.25, delay=cal.delay)
    t = raw.t - log.enc_t[0]
    m = (t >= start) & (t <= start + span)
    ax.plot(t[m], raw.w_true[m], "k", lw=1.4, label="Vicon")
    ax.plot(t[m], raw.w_cmd[m], color="tab:red", lw=1, label="command as logged")
    tf = fit.t - log.enc_t[0]
    mf = (tf >= start) & (tf <= start + span)
    ax.plot(tf[mf], cal.scale_w * fit.w_cmd[mf], color="tab:blue", lw=1,
            label=f"x {cal.scale_w:.3f}, {cal.delay:.2f} s later")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("yaw rate, z-down (rad/s)")
    ax.legend(fontsize=8)
    ax.grid(True, lw=0.4, alpha=0.5)
    return ax


def plot_reading_residuals(axes, res, fit, textbook=(0.15, 0.03)):
    """Range residual against range with the fitted 2-sigma law, and the bearing residuals."""
    a0, a1 = axes
    ok = ~fit.outlier
    a0.plot(res.rho[ok], res.e_rho[ok], ".", ms=1.5, alpha=0.35, color="tab:blue",
            label="inliers")
    a0.plot(res.rho[~ok], res.e_rho[~ok], "x", ms=3, color="tab:red",
            label="outliers (range or bearing)")
    r = np.linspace(0.0, 8.0, 50)
    a0.plot(r, 2 * fit.sigma_range(r), "k", lw=1.2, label="identified $\\pm 2\\sigma(\\rho)$")
    a0.plot(r, -2 * fit.sigma_range(r), "k", lw=1.2)
    a0.axhline(2 * textbook[0], color="tab:orange", ls="--", lw=1.2,
               label=f"textbook $\\pm 2 \\times$ {textbook[0]} m")
    a0.axhline(-2 * textbook[0], color="tab:orange", ls="--", lw=1.2)
    mids = 0.5 * (fit.bins[1:] + fit.bins[:-1])
    a0.plot(mids, fit.bin_bias, "D", color="tab:green", ms=4, label="bin mean (bias)")
    a0.set_ylim(-1.2, 1.2)
    a0.set_xlabel("true range (m)")
    a0.set_ylabel("range residual (m)")
    a0.legend(fontsize=7, loc="lower left")
    a0.grid(True, lw=0.4, alpha=0.5)
    lim = max(0.15, float(np.max(np.abs(res.e_bearing))) * 1.05)
    edges = np.linspace(-lim, lim, 121)
    counts, _, _ = a1.hist(res.e_bearing, bins=edges, color="tab:blue", alpha=0.7,
                           label="all readings")
    g = np.linspace(-lim, lim, 801)
    dens = ok.sum() * (edges[1] - edges[0]) / (fit.sigma_bearing * np.sqrt(2 * np.pi)) * \
        np.exp(-0.5 * (g / fit.sigma_bearing) ** 2)
    keep = dens > 0.1
    a1.plot(g[keep], dens[keep], "k", lw=1,
            label=f"Gaussian, $\\sigma$ = {fit.sigma_bearing:.4f} rad")
    a1.axvline(2 * textbook[1], color="tab:orange", ls="--", lw=1.2,
               label=f"textbook $\\pm 2 \\times$ {textbook[1]} rad")
    a1.axvline(-2 * textbook[1], color="tab:orange", ls="--", lw=1.2)
    a1.set_yscale("log")
    a1.set_ylim(0.5, 3.0 * float(np.max(counts)))
    a1.set_xlabel("bearing residual (rad)")
    a1.set_ylabel("readings per bin")
    a1.legend(fontsize=7)
    return axes


def plot_slam_comparison(axes, log, traces, colors=("tab:red", "tab:blue")):
    """Top view of Vicon and SLAM estimates, and the position error against time."""
    from . import plots

    a0, a1 = axes
    plots.world_axes(a0, log.world(), margin=0.2)
    a0.plot(log.truth[:, 0], log.truth[:, 1], "k", lw=1.6, label="Vicon")
    pos = log.world().positions
    a0.plot(pos[:, 0], pos[:, 1], "ks", ms=4)
    for (name, tr), c in zip(traces.items(), colors):
        a0.plot(tr.x[:, 0], tr.x[:, 1], color=c, lw=1, label=name)
        lm = tr.filter.landmarks
        if lm:
            p = np.array(list(lm.values()))
            a0.plot(p[:, 0], p[:, 1], "+", color=c, ms=7)
        e = np.hypot(*tr.error[:, :2].T)
        a1.plot(tr.t - tr.t[0], e, color=c, lw=1, label=name)
        a1.plot(tr.t - tr.t[0], 2 * np.sqrt(tr.P[:, 0, 0] + tr.P[:, 1, 1]), color=c, lw=0.8,
                ls=":")
    a0.legend(fontsize=7, loc="upper right")
    a1.set_xlabel("time (s)")
    a1.set_ylabel("position error (m); dotted: 2 sigma")
    a1.legend(fontsize=8)
    a1.grid(True, lw=0.4, alpha=0.5)
    return axes
