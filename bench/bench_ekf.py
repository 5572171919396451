"""Benchmark: EKF SLAM on the blocks against the dense textbook filter and the memory floor.

For maps of 100, 1000 and 3000 landmarks (state size n = 3 + 2N), in one
process, it times

- one ``predict``,
- one ``update`` with m = 2 and m = 10 re-observed landmarks (all accepted),

for :class:`slamlib.ekf.EKFSLAM` (predict on the robot's rows, O(n); the joint
update a rank-2m correction of P in blocks of rows, O(n^2 m)) and for the dense
textbook filter of ``tests/dense_ekf.py`` (full F, H, G, the Joseph form: O(n^3)),
next to the floor: one pass over P (``np.copyto`` of an n x n array into
another, one read and one write of each entry, as an in-place update must do at
least). The bars (issue 23): an update at most 3 times the floor (goal 1.5), and
at least 20 times faster than the dense filter. It also measures, with
:mod:`tracemalloc`, the peak memory the update and the predict allocate, next to
P's own size (no n x n temporary). ``bench/README.md`` explains the numbers.

Each time is the minimum over several repeats of a loop long enough to be
timed (as ``timeit`` does), after a warm-up; a dense call longer than a second
is timed once. The dense filter is run up to ``--dense-max`` landmarks (3000 by
default: one dense update there is a few 6003^3 products, a minute on a small
machine).

Run: ``python bench/bench_ekf.py [--sizes 100 1000 3000] [--quick]
[--dense-max 3000] [--blas-threads 1]``.
Numbers, never pass/fail: they depend on the machine, its load and its BLAS.
On a small (2-core) virtual machine, OpenBLAS's threads can cost more to wake
up than they save; ``--blas-threads 1`` shows the single-thread times (it sets
``OPENBLAS_NUM_THREADS`` and friends before numpy is imported).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
import timeit
import tracemalloc
from functools import partial

if "--blas-threads" in sys.argv[:-1]:          # must happen before numpy is imported
    _threads = sys.argv[sys.argv.index("--blas-threads") + 1]
    for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[_var] = _threads

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from dense_ekf import DenseEKF  # noqa: E402  (the tests' independent reference)

from slamlib.ekf import EKFSLAM  # noqa: E402
from slamlib.models import observe  # noqa: E402

Q = np.diag([0.02, 0.02]) ** 2
R = np.diag([0.05, 0.02]) ** 2


def build_filters(n_landmarks: int, seed: int = 0) -> tuple[EKFSLAM, DenseEKF, np.ndarray]:
    """A filter with N landmarks and a correlated P, and a dense twin with the same state.

    The map is built with EKFSLAM (adding 1000 landmarks one at a time to the
    dense filter would cost minutes), then a few predict/update cycles correlate
    everything; the dense twin is given a copy of the state.
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
    dense = DenseEKF(x0, np.diag([1e-4, 1e-4, 1e-5]), Q, R)
    dense.x, dense.P, dense.ids = fast.x, fast.P, fast.landmark_ids
    dense.slot = {i: fast.landmark_index(i) for i in dense.ids}
    return fast, dense, L


def best_time(func, repeat: int = 5, min_total: float = 0.05,
              once_over: float | None = None) -> float:
    """Seconds per call: min over ``repeat`` runs of a loop of at least ``min_total`` s.

    The warm-up call is timed too; when it alone takes more than ``once_over`` seconds
    (the dense filter's large maps), it is the answer.
    """
    t0 = time.perf_counter()
    func()                                          # warm-up
    first = time.perf_counter() - t0
    if once_over is not None and first > once_over:
        return first
    timer = timeit.Timer(func)
    number = 1
    while True:
        t = timer.timeit(number)
        if t >= min_total or number >= 1 << 20:
            break
        number *= max(2, int(min_total / max(t, 1e-9)))
    return min(timer.repeat(repeat=repeat, number=number)) / number


def peak_bytes(func) -> int:
    """Peak of the memory that one call of ``func`` allocates (tracemalloc; numpy reports to it)."""
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        func()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def readings(f: EKFSLAM, m: int) -> tuple[np.ndarray, np.ndarray]:
    """m readings of mapped landmarks, consistent with the estimate (so all are accepted)."""
    ids = np.arange(m)
    z = np.array([observe(f.pose, f.landmark(int(i))) for i in ids]) + 1e-3
    return ids, z


def fmt(seconds: float) -> str:
    if seconds != seconds:                          # NaN: not measured
        return "-"
    if seconds < 1e-3:
        return f"{seconds * 1e6:.0f} us"
    if seconds < 1.0:
        return f"{seconds * 1e3:.2f} ms"
    return f"{seconds:.2f} s"


def mb(nbytes: float) -> str:
    return f"{nbytes / 2**20:.1f} MB" if nbytes >= 2**20 else f"{nbytes / 2**10:.0f} kB"


def ratio(a: float, b: float, digits: int = 1) -> str:
    if a != a or b != b:
        return "-"
    return f"{a / b:.{digits}f}x" if a / b >= 0.1 else f"{a / b:.3f}x"


def table(cols: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(c), *(len(r[i]) for r in rows)) for i, c in enumerate(cols)]
    lines = [" | ".join(c.rjust(w) for c, w in zip(cols, widths)),
             "-+-".join("-" * w for w in widths)]
    lines += [" | ".join(v.rjust(w) for v, w in zip(r, widths)) for r in rows]
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 3000])
    ap.add_argument("--ms", type=int, nargs="+", default=[2, 10])
    ap.add_argument("--dense-max", type=int, default=3000,
                    help="largest map (landmarks) on which the dense filter is run")
    ap.add_argument("--quick", action="store_true", help="fewer repeats")
    ap.add_argument("--blas-threads", type=int, default=None,
                    help="BLAS threads (set before numpy is imported)")
    args = ap.parse_args(argv)
    repeat = 3 if args.quick else 5
    nan = float("nan")

    print(f"numpy {np.__version__}, python {platform.python_version()}, "
          f"{os.cpu_count()} cpus, {platform.machine()}, "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    print("times per call (min of repeats); floor = np.copyto of P (one read and one write "
          "of P);\nx floor = EKFSLAM / floor (bar <= 3, goal 1.5); dense/fast = how many times "
          "faster EKFSLAM\nis than the dense textbook filter (bar >= 20)\n")
    tcols = ["N", "n", "P", "floor", "predict", "x floor", "dense", "dense/fast"]
    for m in args.ms:
        tcols += [f"update m={m}", "x floor", "dense", "dense/fast"]
    mcols = ["N", "n", "P", "predict peak", "/ P"]
    for m in args.ms:
        mcols += [f"update m={m} peak", "/ P", "dense peak", "/ P"]
    trows, mrows, skipped = [], [], []
    for N in args.sizes:
        fast, dense, _ = build_filters(N)
        run_dense = N <= args.dense_max
        if not run_dense:
            skipped.append(N)
        n = fast.state_size
        P = fast.P
        P_bytes = P.nbytes
        buf = np.ones_like(P)                       # touched: no page faults in the timing
        t_floor = best_time(partial(np.copyto, buf, P), repeat)
        del P, buf
        u = np.array([0.3, 0.31])
        t_pf = best_time(partial(fast.predict, u, 0.1), repeat)
        peak_pf = peak_bytes(partial(fast.predict, u, 0.1))
        t_pd = (best_time(partial(dense.predict, u, 0.1), max(2, repeat - 2), min_total=0.2,
                          once_over=1.0) if run_dense else nan)
        dense.x, dense.P = fast.x, fast.P               # the same state again for the update
        trow = [str(N), str(n), mb(P_bytes), fmt(t_floor), fmt(t_pf), ratio(t_pf, t_floor),
                fmt(t_pd), ratio(t_pd, t_pf, 0)]
        mrow = [str(N), str(n), mb(P_bytes), mb(peak_pf), f"{peak_pf / P_bytes:.4f}"]
        for m in args.ms:
            m_eff = min(m, N)
            ids, z = readings(fast, m_eff)
            rep = fast.update(ids, z)
            assert rep.n_accepted == m_eff, rep.table()
            t_uf = best_time(partial(fast.update, ids, z), repeat)
            peak_uf = peak_bytes(partial(fast.update, ids, z))
            t_ud, peak_ud = nan, nan
            if run_dense:
                t_ud = best_time(partial(dense.update, ids, z), max(2, repeat - 2),
                                 min_total=0.2, once_over=1.0)
                peak_ud = peak_bytes(partial(dense.update, ids, z)) if n < 3000 else nan
            trow += [fmt(t_uf), ratio(t_uf, t_floor), fmt(t_ud), ratio(t_ud, t_uf, 0)]
            mrow += [mb(peak_uf), f"{peak_uf / P_bytes:.4f}",
                     "-" if peak_ud != peak_ud else mb(peak_ud),
                     "-" if peak_ud != peak_ud else f"{peak_ud / P_bytes:.1f}"]
        trows.append(trow)
        mrows.append(mrow)
        print(f"  measured N = {N}", file=sys.stderr, flush=True)
        del fast, dense

    print(table(tcols, trows))
    print("\npeak memory allocated by one call (tracemalloc), next to P's size\n")
    print(table(mcols, mrows))
    if skipped:
        print(f"\ndense filter not run at N = {', '.join(map(str, skipped))} (--dense-max "
              f"{args.dense_max}): its n^3 products take minutes and several times P's memory")


if __name__ == "__main__":
    main()
