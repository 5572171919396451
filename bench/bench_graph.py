"""Benchmark: cost of one step of EKF SLAM and of iSAM2 against the map's size (prints numbers).

One simulated loop through random marker worlds of increasing size
(:func:`slamlib.course.studies_ch06.random_loop_run`, the same seed), driven through

- :class:`slamlib.ekf.EKFSLAM`: the time of one camera step, i.e. the
  predictions since the previous frame plus the update (O(n^2) in the state);
- :func:`slamlib.graph.smooth` ``(method="isam2")``: the time of one iSAM2
  update (new odometry and range-bearing factors, the estimate of the new pose
  and its marginal covariance), in the same process;

binned by the number of landmarks in the map at that step; then the batch
solve of the whole graph once (Levenberg-Marquardt and the marginals).
Medians per bin, in milliseconds. Numbers, never pass/fail: they depend on
the machine (and on what else it runs).

Run: ``python bench/bench_graph.py [--counts 16 64 256] [--quick]``.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from slamlib import graph
from slamlib.course.studies_ch06 import random_loop_run
from slamlib.ekf import EKFSLAM
from slamlib.runner import DEFAULT_P0, default_R, reading_covariances


def ekf_step_times(run) -> tuple[np.ndarray, np.ndarray]:
    """Seconds of each camera step of EKF SLAM (predictions since the last frame + update)
    and the landmarks in the map after it."""
    f = EKFSLAM(run.start_pose, DEFAULT_P0, run.Q(), default_R(run), wheel_base=run.wheel_base)
    sensor = run.sensor()
    secs, sizes, acc = [], [], 0.0
    for ev in run.events():
        t0 = time.perf_counter()
        if ev.kind == "predict":
            f.predict(ev.u, ev.dt)
            acc += time.perf_counter() - t0
            continue
        if len(ev.obs) == 0:
            continue
        R = reading_covariances(sensor, ev.obs.z)
        t0 = time.perf_counter()
        f.update(ev.obs.ids, ev.obs.z, R=R)
        secs.append(acc + time.perf_counter() - t0)
        sizes.append(f.n_landmarks)
        acc = 0.0
    return np.array(secs), np.array(sizes)


def isam2_step_times(run):
    tr = graph.smooth(run, "isam2")
    seen: set[int] = set()
    sizes = []
    for ids, _, _ in tr.problem.readings:
        seen.update(int(i) for i in ids)
        sizes.append(len(seen))
    return tr.step_seconds, np.array(sizes), tr


def extent_for(count: int) -> tuple[float, float, float, float]:
    """A world whose area grows with the count (the density of 48 markers in 6 m x 6 m)."""
    s = max(1.0, np.sqrt(count / 48.0))
    return (0.0, 6.0 * s, -3.0 * s, 3.0 * s)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--counts", type=int, nargs="+", default=[16, 64, 256])
    p.add_argument("--quick", action="store_true", help="the smallest two worlds only")
    a = p.parse_args(argv)
    counts = a.counts[:2] if a.quick else a.counts
    print(f"python {platform.python_version()}, {platform.machine()}; "
          f"medians over the steps of each bin, ms")
    print(f"{'world':>7} {'frames':>7} {'L':>9} {'steps':>6} {'EKF step':>9} {'iSAM2 step':>11}")
    for n in counts:
        world, run = random_loop_run(n, 1, extent=extent_for(n))
        e_s, e_L = ekf_step_times(run)
        i_s, i_L, tr = isam2_step_times(run)
        # bins of map size: quarters of the final map
        L_max = int(max(e_L.max(), i_L.max()))
        edges = np.unique(np.linspace(0, L_max, 5).round().astype(int))
        for lo, hi in zip(edges[:-1], edges[1:]):
            e_in = (e_L > lo) & (e_L <= hi)
            i_in = (i_L > lo) & (i_L <= hi)
            if not e_in.any() or not i_in.any():
                continue
            print(f"{n:>7} {len(e_s):>7} {f'{lo + 1}-{hi}':>9} {int(e_in.sum()):>6} "
                  f"{1e3 * np.median(e_s[e_in]):>9.3f} {1e3 * np.median(i_s[i_in]):>11.3f}")
        t0 = time.perf_counter()
        b = graph.smooth(run, "batch")
        tb = time.perf_counter() - t0
        print(f"{n:>7}  totals: EKF {e_s.sum():.2f} s, iSAM2 {i_s.sum():.2f} s, batch "
              f"(LM {b.iterations} iterations + marginals) {tb:.2f} s, "
              f"{tr.problem.n_poses} poses, {len(tr.landmark_ids)} landmarks")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
