"""Benchmark: per-frame association time without ids, NN and JCBB (prints numbers only).

For maps of N = 10, 100 and 1000 landmarks (uniform in a 20 m x 20 m square,
so that denser maps put more landmarks in each reading's gate) and frames of
k = 2, 4, 8 and 16 readings of the landmarks nearest the robot, times one
``update(None, z)`` of :class:`slamlib.ekf.EKFSLAM` with ``association="nn"``
and ``"jcbb"``, next to the same update with the ids given
(``association="ids"``, the look-up: the baseline, in the same process). The
difference is the association's cost. Also printed: the mean number of
landmarks inside a reading's gate, and the nodes JCBB visited.

Each time is the minimum over several repeats, each on a fresh copy of the
filter (an update shrinks the gates). The filters' pose has drifted (large Q)
so that gates are wide and, in the denser maps, hold several landmarks.
Run: ``python bench/bench_association.py [--quick]``.
Numbers, never pass/fail. On a small shared machine, OpenBLAS's threads make the
joint update (the same for all three) slow and noisy from N = 100 and k = 8
on; ``OPENBLAS_NUM_THREADS=1 python bench/bench_association.py`` shows the
single-thread times (as ``bench_ekf.py --blas-threads 1``).
"""

from __future__ import annotations

import argparse
import copy
import platform
import time

import numpy as np

from slamlib.ekf import EKFSLAM
from slamlib.models import observe

Q = np.diag([0.3, 0.3]) ** 2                             # a kidnapping-sized drift (below)
R = np.diag([0.03, np.radians(1.0)]) ** 2
P0 = np.diag([0.05**2, 0.05**2, np.radians(1.0) ** 2])   # the pose uncertain: wide gates


def build(n_landmarks: int, association: str, seed: int = 0):
    """A filter that mapped N landmarks from the start pose, and their true positions."""
    rng = np.random.default_rng(seed)
    L = rng.uniform(-10.0, 10.0, (n_landmarks, 2))
    x0 = np.zeros(3)
    f = EKFSLAM(x0, P0, Q, R, capacity=n_landmarks, association=association)
    z = np.array([observe(x0, p) for p in L]) + rng.normal(0.0, [0.03, 0.017], (n_landmarks, 2))
    f.update(None if association != "ids" else np.arange(n_landmarks), z)
    for _ in range(10):                                   # the pose drifts: wide gates
        f.predict([0.0, 0.0], 0.1)
    return f, L


def frame(L: np.ndarray, k: int, seed: int = 1):
    """k readings of the landmarks nearest the robot (true pose at the origin)."""
    rng = np.random.default_rng(seed)
    near = np.argsort(np.hypot(L[:, 0], L[:, 1]))[:k]
    z = np.array([observe(np.zeros(3), L[j]) for j in near])
    return near, z + rng.normal(0.0, [0.03, 0.017], (k, 2))


def best_time(f: EKFSLAM, ids, z, repeat: int) -> tuple[float, EKFSLAM]:
    """Minimum time of one update on fresh copies of ``f`` (an update shrinks the gates)."""
    best, g = float("inf"), None
    for _ in range(repeat):
        g = copy.deepcopy(f)
        t0 = time.perf_counter()
        g.update(ids, z)
        best = min(best, time.perf_counter() - t0)
    return best, g


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer sizes and repeats")
    args = ap.parse_args()
    sizes = (10, 100) if args.quick else (10, 100, 1000)
    ks = (2, 4, 8) if args.quick else (2, 4, 8, 16)
    repeat = 5 if args.quick else 15
    print(f"association per frame, update(None, z) vs update(ids, z); numpy {np.__version__}, "
          f"{platform.processor() or platform.machine()}")
    print(f"{'N':>5} {'k':>3} {'in gate':>8} {'ids ms':>8} {'nn ms':>8} {'jcbb ms':>8} "
          f"{'nn-ids':>8} {'jcbb-ids':>9} {'nodes':>6}")
    for N in sizes:
        filt = {m: build(N, m)[0] for m in ("ids", "nn", "jcbb")}
        L = build(N, "ids")[1]
        for k in ks:
            if k > N:
                continue
            near, z = frame(L, k)
            times, after = {}, {}
            for m, f in filt.items():
                t, after[m] = best_time(f, near if m == "ids" else None, z, repeat)
                times[m] = 1e3 * t
            in_gate = float(np.mean(after["nn"].last_association["in_gate"]))
            res = after["jcbb"].last_association["jcbb"]
            nodes = 0 if res is None else res.nodes
            print(f"{N:>5} {k:>3} {in_gate:>8.2f} {times['ids']:>8.3f} {times['nn']:>8.3f} "
                  f"{times['jcbb']:>8.3f} {times['nn'] - times['ids']:>8.3f} "
                  f"{times['jcbb'] - times['ids']:>9.3f} {nodes:>6d}")


if __name__ == "__main__":
    main()
