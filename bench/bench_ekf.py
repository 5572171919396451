"""Benchmark: the structured EKF SLAM against the dense textbook one (prints numbers only).

For maps of 10, 100, 500 and 1000 landmarks (state size n = 3 + 2N), times

- one ``predict``,
- one ``update`` with m = 2 and m = 10 re-observed landmarks (all accepted),

for :class:`slamlib.ekf.EKFSLAM` (structured: predict O(n), update O(n^2 m))
and :class:`slamlib.ekf_dense.DenseEKFSLAM` (textbook: full F, H, I - K H,
O(n^3)), in the same process, next to the floor: one pass over P
(``np.copyto`` of an n x n array). Each time is the minimum over several
repeats of a loop long enough to be timed (as ``timeit`` does), after a warm-up.

Run: ``python bench/bench_ekf.py [--sizes 10 100 500 1000] [--quick] [--blas-threads 1]``.
Numbers, never pass/fail: they depend on the machine and its BLAS. On a
small (2-core) virtual machine, OpenBLAS's threads cost more to wake up than
they save on these sizes; ``--blas-threads 1`` shows the single-thread times
(it sets ``OPENBLAS_NUM_THREADS`` and friends before numpy is imported).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import timeit
from functools import partial

if "--blas-threads" in sys.argv[:-1]:          # must happen before numpy is imported
    _threads = sys.argv[sys.argv.index("--blas-threads") + 1]
    for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[_var] = _threads

import numpy as np  # noqa: E402

from slamlib.ekf import EKFSLAM  # noqa: E402
from slamlib.ekf_dense import DenseEKFSLAM  # noqa: E402
from slamlib.models import observe  # noqa: E402

Q = np.diag([0.02, 0.02]) ** 2
R = np.diag([0.05, 0.02]) ** 2


def build_filters(n_landmarks: int, seed: int = 0) -> tuple[EKFSLAM, DenseEKFSLAM, np.ndarray]:
    """A fast filter with N landmarks and a correlated P, and a dense twin with the same state.

    The map is built with the fast filter (adding 1000 landmarks one at a time
    to the dense filter would cost minutes), then a few predict/update cycles
    correlate everything; the dense twin is given a copy of the state.
    """
    rng = np.random.default_rng(seed)
    L = rng.uniform(-10.0, 10.0, (n_landmarks, 2))
    x0 = np.array([0.0, 0.0, 0.3])
    fast = EKFSLAM(x0, np.diag([1e-4, 1e-4, 1e-5]), Q, R, capacity=n_landmarks)
    ids = np.arange(n_landmarks)
    z = np.array([observe(x0, p) for p in L]) + rng.normal(0.0, [0.05, 0.02], (n_landmarks, 2))
    fast.update(ids, z)
    for _ in range(5):
        fast.predict([0.3, 0.32], 0.1)
        sel = rng.choice(n_landmarks, min(5, n_landmarks), replace=False)
        fast.update(ids[sel], np.array([observe(fast.pose, L[i]) for i in sel]))
    dense = DenseEKFSLAM(x0, np.diag([1e-4, 1e-4, 1e-5]), Q, R)
    # copy the state (private attributes: this is a benchmark, not an example)
    dense._x, dense._P, dense._n = fast._x.copy(), fast._P.copy(), fast._n
    dense._ids, dense._slot = list(fast._ids), dict(fast._slot)
    return fast, dense, L


def best_time(func, repeat: int = 5, min_total: float = 0.05) -> float:
    """Seconds per call: min over ``repeat`` runs of a loop of at least ``min_total`` s."""
    func()                                          # warm-up
    timer = timeit.Timer(func)
    number = 1
    while True:
        t = timer.timeit(number)
        if t >= min_total or number >= 1 << 20:
            break
        number *= max(2, int(min_total / max(t, 1e-9)))
    return min(timer.repeat(repeat=repeat, number=number)) / number


def readings(f, L: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """m readings of mapped landmarks, consistent with the estimate (so all are accepted)."""
    ids = np.arange(m)
    z = np.array([observe(f.pose, f.landmark(int(i))) for i in ids]) + 1e-3
    return ids, z


def fmt(seconds: float) -> str:
    if seconds < 1e-3:
        return f"{seconds * 1e6:7.0f} us"
    if seconds < 1.0:
        return f"{seconds * 1e3:7.2f} ms"
    return f"{seconds:7.2f} s "


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[10, 100, 500, 1000])
    ap.add_argument("--ms", type=int, nargs="+", default=[2, 10])
    ap.add_argument("--quick", action="store_true", help="fewer repeats")
    ap.add_argument("--blas-threads", type=int, default=None,
                    help="BLAS threads (set before numpy is imported)")
    args = ap.parse_args(argv)
    repeat = 3 if args.quick else 5

    print(f"numpy {np.__version__}, python {platform.python_version()}, "
          f"{os.cpu_count()} cpus, {platform.machine()}, "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    print("times per call (min of repeats); ratio = dense / fast; floor = np.copyto of P\n")
    cols = ["N", "n", "floor"] + ["predict fast", "dense", "ratio"]
    for m in args.ms:
        cols += [f"update m={m} fast", "dense", "ratio", "fast/floor"]
    rows = []
    for N in args.sizes:
        fast, dense, L = build_filters(N)
        n = fast.state_size
        P = fast.P
        buf = np.empty_like(P)
        t_floor = best_time(partial(np.copyto, buf, P), repeat)
        u = np.array([0.3, 0.31])
        t_pf = best_time(partial(fast.predict, u, 0.1), repeat)
        t_pd = best_time(partial(dense.predict, u, 0.1), max(2, repeat - 2), min_total=0.2)
        row = [str(N), str(n), fmt(t_floor), fmt(t_pf), fmt(t_pd), f"{t_pd / t_pf:7.0f}x"]
        for m in args.ms:
            m_eff = min(m, N)
            ids, z = readings(fast, L, m_eff)
            rep = fast.update(ids, z)
            assert rep.n_accepted == m_eff, rep.table()
            t_uf = best_time(partial(fast.update, ids, z), repeat)
            ids, z = readings(dense, L, m_eff)
            t_ud = best_time(partial(dense.update, ids, z), max(2, repeat - 2),
                             min_total=0.2)
            row += [fmt(t_uf), fmt(t_ud), f"{t_ud / t_uf:7.0f}x", f"{t_uf / t_floor:7.1f}x"]
        rows.append(row)
        print(f"  measured N = {row[0].strip()}", file=sys.stderr, flush=True)

    widths = [max(len(c), *(len(r[i]) for r in rows)) for i, c in enumerate(cols)]
    print()
    print(" | ".join(c.rjust(w) for c, w in zip(cols, widths)))
    print("-+-".join("-" * w for w in widths))
    for r in rows:
        print(" | ".join(v.rjust(w) for v, w in zip(r, widths)))


if __name__ == "__main__":
    main()
