"""Benchmark: a Monte-Carlo of the arena loop against a plain dense EKF SLAM (numbers only).

Issue 9, point 1: ``slamlib.studies.monte_carlo_nees("arena_loop", "slam", seeds)``
(simulate each seed, run EKF SLAM on it, sample the pose NEES on the time
grid) should take no longer than a plain dense numpy EKF SLAM *filtering the
same runs alone* (the runs simulated beforehand, not timed): full ``F``, full
``H``, ``K = P H^T S^-1``, ``P <- (I - K H) P``, written as a student would
write it from the textbook, with no input checks and no recording beyond the
final state. Both are timed in this process, one after the other, as
process CPU time (the machine is shared; wall time is printed too), and the
ratio is printed. The Monte-Carlo is also timed with ``workers=2`` (a process
pool over both cores; wall time, since the work is in the children).

Run: ``python bench/bench_monte_carlo.py [--runs 100] [--chapters]``;
``--chapters`` also executes every notebook once (nbclient) and prints its
execution time (the course's bar: each chapter's Run All <= 20 s).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

from slamlib import runner, sim, studies
from slamlib.metrics import chi2_band
from slamlib.runner import DEFAULT_P0

ROOT = Path(__file__).resolve().parents[1]


# --------------------------------------------------------------------------- the baseline
def dense_slam(run, gate: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """A plain dense EKF SLAM over ``run`` (textbook matrices, no checks); final (x, P)."""
    b = run.wheel_base
    sensor = run.sensor()
    Q = run.Q()
    thr = -2.0 * np.log1p(-gate)
    u_all, dt_all = run.controls()
    x = run.start_pose.copy()
    P = DEFAULT_P0.copy()
    slot: dict[int, int] = {}
    frames = run.frames()
    t_enc = run.enc_t[1:]
    j = 0
    for k in range(dt_all.size + 1):
        # camera frames captured at or before this encoder time (predictions first)
        t_now = t_enc[k] if k < dt_all.size else np.inf
        while j < len(frames) and frames[j].t < t_now:
            f = frames[j]
            j += 1
            n = x.size
            acc_rows, acc_H, acc_R, acc_y = [], [], [], []
            new = []
            for mid, z in zip(f.ids, f.z):
                Ri = sensor.R(z[0])
                if int(mid) not in slot:
                    new.append((int(mid), z, Ri))
                    continue
                s = slot[int(mid)]
                dx, dy = x[s] - x[0], x[s + 1] - x[1]
                q = dx * dx + dy * dy
                r = np.sqrt(q)
                h = np.array([r, np.arctan2(dy, dx) - x[2]])
                H = np.zeros((2, n))
                H[:, :3] = [[-dx / r, -dy / r, 0.0], [dy / q, -dx / q, -1.0]]
                H[:, s:s + 2] = [[dx / r, dy / r], [-dy / q, dx / q]]
                y = z - h
                y[1] = (y[1] + np.pi) % (2 * np.pi) - np.pi
                S = H @ P @ H.T + Ri
                if y @ np.linalg.solve(S, y) < thr:
                    acc_rows.append(s)
                    acc_H.append(H)
                    acc_R.append(Ri)
                    acc_y.append(y)
            if acc_H:
                H = np.vstack(acc_H)
                m = len(acc_H)
                Rb = np.zeros((2 * m, 2 * m))
                for i, Ri in enumerate(acc_R):
                    Rb[2 * i:2 * i + 2, 2 * i:2 * i + 2] = Ri
                S = H @ P @ H.T + Rb
                K = P @ H.T @ np.linalg.inv(S)
                x = x + K @ np.concatenate(acc_y)
                x[2] = (x[2] + np.pi) % (2 * np.pi) - np.pi
                P = (np.eye(n) - K @ H) @ P
                P = 0.5 * (P + P.T)
            for mid, z, Ri in new:
                if mid in slot:
                    continue
                n = x.size
                a = x[2] + z[1]
                m_xy = np.array([x[0] + z[0] * np.cos(a), x[1] + z[0] * np.sin(a)])
                J1 = np.array([[1.0, 0.0, -z[0] * np.sin(a)], [0.0, 1.0, z[0] * np.cos(a)]])
                J2 = np.array([[np.cos(a), -z[0] * np.sin(a)], [np.sin(a), z[0] * np.cos(a)]])
                Gx = np.zeros((n + 2, n))
                Gx[:n, :n] = np.eye(n)
                Gx[n:, :3] = J1
                Gz = np.zeros((n + 2, 2))
                Gz[n:] = J2
                P = Gx @ P @ Gx.T + Gz @ Ri @ Gz.T
                x = np.concatenate([x, m_xy])
                slot[mid] = n
        if k == dt_all.size:
            break
        u, dt = u_all[k], dt_all[k]
        v, w = 0.5 * (u[0] + u[1]), (u[1] - u[0]) / b
        c, s_ = np.cos(x[2]), np.sin(x[2])
        n = x.size
        F = np.eye(n)
        F[0, 2], F[1, 2] = -v * s_ * dt, v * c * dt
        Fw = np.zeros((n, 2))
        Fw[:3] = [[0.5 * c * dt, 0.5 * c * dt], [0.5 * s_ * dt, 0.5 * s_ * dt], [-dt / b, dt / b]]
        x = x.copy()
        x[0] += v * c * dt
        x[1] += v * s_ * dt
        x[2] = (x[2] + w * dt + np.pi) % (2 * np.pi) - np.pi
        P = F @ P @ F.T + Fw @ Q @ Fw.T
    return x, P


def timed(func):
    w0, c0 = time.perf_counter(), time.process_time()
    out = func()
    return out, time.perf_counter() - w0, time.process_time() - c0


def chapter_times() -> list[tuple[str, float]]:
    """Execute every notebook once in a scratch copy (nbclient); seconds per chapter."""
    import nbformat
    from nbclient import NotebookClient

    out = []
    env_backend = os.environ.pop("MPLBACKEND", None)
    try:
        for path in sorted((ROOT / "notebooks").glob("*.ipynb")):
            nb = nbformat.read(path, as_version=4)
            client = NotebookClient(nb, timeout=600, kernel_name="python3",
                                    resources={"metadata": {"path": str(path.parent)}})
            t0 = time.perf_counter()
            try:
                client.execute()
                out.append((path.name, time.perf_counter() - t0))
            except Exception as exc:  # a benchmark reports, it does not fail
                out.append((f"{path.name} (failed: {type(exc).__name__})",
                            time.perf_counter() - t0))
    finally:
        if env_backend is not None:
            os.environ["MPLBACKEND"] = env_backend
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--chapters", action="store_true", help="also time every notebook")
    args = ap.parse_args(argv)
    seeds = range(1000, 1000 + args.runs)
    print(f"numpy {np.__version__}, python {platform.python_version()}, "
          f"{os.cpu_count()} cpus, load average {os.getloadavg()[0]:.1f}")
    # the compiled functions (the simulator's loop, the EKF's @compiled steps) load from
    # numba's cache, or compile on a fresh clone: once per process, before anything is timed
    _, w_jit, _ = timed(lambda: runner.slam(sim.scenario("arena_loop", seed=1), max_time=1.0))
    print(f"the compiled functions loaded (or compiled) in {w_jit:.2f} s, not counted")
    runs, w_sim, c_sim = timed(lambda: [sim.scenario("arena_loop", seed=s) for s in seeds])
    _, w_dense, c_dense = timed(lambda: [dense_slam(r) for r in runs])
    _, w_filt, c_filt = timed(lambda: [runner.slam(r) for r in runs])
    st1, w_mc, c_mc = timed(lambda: studies.monte_carlo_nees("arena_loop", "slam", seeds))
    st2, w_mc2, _ = timed(lambda: studies.monte_carlo_nees("arena_loop", "slam", seeds,
                                                           workers=2))
    same = bool(np.array_equal(st1.nees, st2.nees) and np.array_equal(st1.ate, st2.ate))
    lo, hi = chi2_band(3, st1.n_runs)
    print(f"\n{args.runs} seeded runs of the arena loop "
          f"(average NEES {st1.average().mean():.2f}, band {lo:.2f}-{hi:.2f})")
    print(f"{'':58s} {'CPU s':>7s} {'wall s':>7s}")
    print(f"{'plain dense EKF SLAM, filtering only (the baseline)':58s} {c_dense:7.2f} "
          f"{w_dense:7.2f}")
    print(f"{'monte_carlo_nees: simulate + EKF SLAM + NEES, 1 process':58s} {c_mc:7.2f} "
          f"{w_mc:7.2f}")
    print(f"{'monte_carlo_nees, workers=2':58s} {'':>7s} {w_mc2:7.2f}")
    print("where the Monte-Carlo's time goes (the same runs, one process):")
    print(f"{'  simulate the runs (sim.scenario)':58s} {c_sim:7.2f} {w_sim:7.2f}")
    print(f"{'  EKF SLAM over them with its trace (runner.slam)':58s} {c_filt:7.2f} "
          f"{w_filt:7.2f}")
    print(f"{'  the two timed apart, together (the Monte-Carlo adds NEES,':58s} "
          f"{c_sim + c_filt:7.2f}")
    print("   ATE and loop closures to them: what it takes beyond their sum is the rest)")
    print(f"ratio Monte-Carlo / baseline: {c_mc / c_dense:.2f} (CPU, 1 process), "
          f"{w_mc2 / w_dense:.2f} (wall, 2 workers; goal <= 1, ideally 0.25)")
    print(f"1 and 2 workers give identical numbers: {same}")
    if args.chapters:
        print("\nchapter execution times (nbclient, one run each):")
        for name, sec in chapter_times():
            print(f"  {name:45s} {sec:6.1f} s")


if __name__ == "__main__":
    main()
