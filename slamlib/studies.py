"""Studies over many simulated runs: Monte-Carlo NEES and the loop closure's gate (ch. 05, 06, 11).

One filter run says little about a filter's statistics: its errors at
neighbouring instants are strongly correlated, so a time average over one run
is close to one sample. This module runs many: ``tests/test_consistency.py``,
the chapters' stored studies (:mod:`slamlib.course`: chapter 06's in
``studies_ch06``, the marker-density sweep and the observability check among
them) and the figure script share it.

- :func:`monte_carlo` / :func:`monte_carlo_nees`: re-simulate a recorded
  scenario with independent seeds, run the map-based EKF and/or EKF SLAM on
  each, and sample the pose NEES (and the heading's normalised error alone) on
  a fixed time grid. :meth:`NEESStudy.average` is the Monte-Carlo average to
  compare with :func:`slamlib.metrics.chi2_band` ``(3, N)``.
- :func:`reobservation`: in one SLAM trace, the first reading of the first
  mapped landmark after its longest absence (the loop closure), its squared
  Mahalanobis distance against the gate, and when (if ever) a reading of that
  landmark was accepted again.

Everything is seeded; the same arguments give the same numbers bit for bit.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from . import runner
from .metrics import chi2_band, pose_error
from .metrics import nees as _nees
from .runs import Run
from .validate import as_covariance, as_positive, as_seed

__all__ = ["NEESStudy", "monte_carlo", "monte_carlo_nees", "sample_trace", "Reobservation",
           "reobservation", "map_jobs"]

_METHODS = ("localization", "slam", "fej", "ideal", "ideal_init")


# --------------------------------------------------------------------------- Monte-Carlo NEES
@dataclass
class NEESStudy:
    """Pose NEES of one filter over N seeded runs, sampled on a common time grid.

    Attributes
    ----------
    scenario : str
        The scenario re-simulated (:data:`slamlib.sim.SCENARIOS`).
    method : str
        ``"localization"`` (map-based EKF), ``"slam"``, ``"fej"``, ``"ideal"`` or
        ``"ideal_init"`` (the ideal filter with its landmarks' initialisation linearised at
        the truth too).
    seeds : tuple of int
        One seed per run.
    t : numpy.ndarray (T,)
        The time grid (s).
    nees : numpy.ndarray (N, T)
        Pose NEES ``e^T P^-1 e`` (3 degrees of freedom) of each run at each time.
    nees_heading : numpy.ndarray (N, T)
        The heading's normalised error ``e_theta^2 / P_theta_theta`` (1 degree of freedom).
    ate : numpy.ndarray (N,)
        Each run's position ATE (m).
    reobservations : tuple of Reobservation
        SLAM filters only: each run's loop closure on its first landmark (:func:`reobservation`).
    """

    scenario: str
    method: str
    seeds: tuple
    t: np.ndarray
    nees: np.ndarray
    nees_heading: np.ndarray
    ate: np.ndarray
    reobservations: tuple = ()

    @property
    def n_runs(self) -> int:
        return int(self.nees.shape[0])

    def average(self, heading: bool = False) -> np.ndarray:
        """The NEES averaged over the runs at each time (shape (T,))."""
        return np.mean(self.nees_heading if heading else self.nees, axis=0)

    def band(self, prob: float = 0.95, heading: bool = False) -> tuple[float, float]:
        """The two-sided ``prob`` band of that average for a consistent filter."""
        return chi2_band(1 if heading else 3, self.n_runs, prob)

    def run_means(self, heading: bool = False) -> np.ndarray:
        """Each run's NEES averaged over time (shape (N,))."""
        return np.mean(self.nees_heading if heading else self.nees, axis=1)


def sample_trace(trace: runner.Trace, t_grid) -> tuple[np.ndarray, np.ndarray]:
    """Pose NEES and heading NEES of ``trace`` at the times ``t_grid``.

    At each grid time the state after the last event at or before it is used
    (the filter's estimate holds until the next event), so predictions and
    updates at the same instant are both applied.
    """
    t_grid = np.asarray(t_grid, dtype=float)
    k = np.searchsorted(trace.t, t_grid + 1e-9, side="right") - 1
    if np.any(k < 0):
        raise ValueError("t_grid: expected times at or after the trace's start")
    e = pose_error(trace.x[k], trace.truth[k])
    P = trace.P[k]
    return np.asarray(_nees(e, P)), e[:, 2] ** 2 / P[:, 2, 2]


#: Filter names of :func:`monte_carlo` -> the runner of :mod:`slamlib.runner`.
_RUNNERS = {"localization": ("localization", {}), "slam": ("slam", {}),
            "fej": ("fej_slam", {}), "ideal": ("ideal_slam", {}),
            "ideal_init": ("ideal_slam", {"landmark_init": "truth"})}


def _run_method(run: Run, method: str, gate, Q=None):
    if method not in _METHODS:
        raise ValueError(f"method: expected one of {_METHODS}, got {method!r}")
    name, options = _RUNNERS[method]
    return getattr(runner, name)(run, gate=gate, Q=Q, **options)


def _one_seed(job: tuple) -> tuple:
    """Simulate one seed, run every filter, sample the NEES (one task of :func:`monte_carlo`).

    Returns the run's end time and, per method, the sampled pose and heading
    NEES on the grid ``step, 2 step, ...`` up to ``t_end`` (or the run's own
    end), the ATE and (SLAM filters) the loop closure. The grid of a shorter
    end is a prefix of a longer one's, so the caller can cut every run to the
    common end without recomputing anything: the numbers do not depend on
    which process ran which seed.
    """
    from .sim import scenario

    scenario_name, seed, methods, step, t_end, sigma_wheel, gate, Q, sensor_overrides = job
    run = scenario(scenario_name, seed=seed, sigma_wheel=sigma_wheel, **sensor_overrides)
    end = float(run.enc_t[-1])
    if t_end is not None and t_end > end + 1e-9:
        raise ValueError(f"t_end: {t_end:g} s is past the end of seed {seed}'s run ({end:g} s): "
                         f"the grid must lie within every run (default: the shortest run's end)")
    last = end if t_end is None else t_end
    t = np.arange(1, int(np.floor(last / step + 1e-9)) + 1) * step
    out = {}
    for m in methods:
        tr = _run_method(run, m, gate, Q)
        a, b = sample_trace(tr, t)
        out[m] = (a, b, runner.ate(tr.x, tr.truth).position,
                  reobservation(tr) if m != "localization" else None)
    return end, out


def monte_carlo(scenario_name: str, methods: Sequence[str] = ("localization", "slam"),
                seeds: Iterable[int] = range(1000, 1020), *, step: float = 0.5,
                t_end: float | None = None, sigma_wheel: float | None = None,
                gate: float | None = 0.95, Q=None, workers: int = 1,
                **sensor_overrides) -> dict[str, NEESStudy]:
    """Re-simulate ``scenario_name`` once per seed and run each filter of ``methods`` on it.

    Parameters
    ----------
    scenario_name : str
        A key of :data:`slamlib.sim.SCENARIOS` (``"arena_loop"``...).
    methods : sequence of {"localization", "slam", "fej", "ideal", "ideal_init"}
        The filters (all see the same simulated runs): the map-based EKF, EKF
        SLAM, First-Estimates-Jacobian EKF SLAM (:class:`slamlib.ekf.FEJEKFSLAM`)
        and the ideal EKF SLAM linearised at the truth
        (:class:`slamlib.ekf.IdealEKFSLAM`, a simulation-only diagnostic), its
        new landmarks initialised at the estimate (``"ideal"``) or linearised
        about the truth too (``"ideal_init"``, ``landmark_init="truth"``).
    seeds : iterable of int
        One independent run per seed.
    step : float
        Spacing (s) of the time grid on which the NEES is sampled.
    t_end : float, optional
        Last grid time; default the end of the shortest run (runs end when the
        path is done, a few encoder periods apart). A time past a run's end is
        refused (the grid would repeat its last state).
    sigma_wheel, gate, **sensor_overrides
        Passed to :func:`slamlib.sim.scenario` (the filter's Q follows the
        simulated ``sigma_wheel``) and to the filter.
    Q : array_like (2, 2), optional
        The filters' wheel-speed covariance instead of the run's own (a filter
        that does not know the slip, chapter 06).
    workers : int
        Processes sharing the seeds (1: this process). The numbers are the
        same bit for bit for any number of workers (``tests/test_studies.py``).

    Returns
    -------
    dict method -> NEESStudy
    """
    methods = (methods,) if isinstance(methods, str) else tuple(methods)
    for m in methods:
        if m not in _METHODS:
            raise ValueError(f"methods: expected names from {_METHODS}, got {m!r}")
    seeds = tuple(as_seed(f"seeds[{i}]", s) for i, s in enumerate(seeds))
    if not seeds:
        raise ValueError("seeds: expected at least one seed")
    step = as_positive("step", step)
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers: expected a positive integer, got {workers!r}")
    Q = None if Q is None else as_covariance("Q", Q, 2)
    t_end = None if t_end is None else as_positive("t_end", t_end)
    jobs = [(scenario_name, s, methods, float(step), t_end, sigma_wheel, gate, Q,
             sensor_overrides) for s in seeds]
    results = map_jobs(_one_seed, jobs, int(workers))
    end = min(e for e, _ in results) if t_end is None else t_end
    t = np.arange(1, int(np.floor(end / step + 1e-9)) + 1) * step
    T = t.size
    out = {}
    for m in methods:
        per = [r[m] for _, r in results]
        reobs = tuple(p[3] for p in per) if m != "localization" else ()
        out[m] = NEESStudy(scenario_name, m, seeds, t, np.array([p[0][:T] for p in per]),
                           np.array([p[1][:T] for p in per]), np.array([p[2] for p in per]),
                           reobs)
    return out


def map_jobs(func, jobs: list, workers: int = 1) -> list:
    """``[func(j) for j in jobs]``, in order, in this process or in a pool of ``workers``.

    The studies' one way to share seeds between processes: ``func`` must be a
    module-level function of one job, so that the answer does not depend on
    which process ran which job (nor on ``workers``).
    """
    if workers == 1 or len(jobs) < 2:
        return [func(j) for j in jobs]
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    chunk = max(1, len(jobs) // (4 * workers))
    with ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=ctx) as pool:
        return list(pool.map(func, jobs, chunksize=chunk))


def monte_carlo_nees(scenario_name: str, method: str = "slam",
                     seeds: Iterable[int] = range(1000, 1020), **kwargs) -> NEESStudy:
    """:func:`monte_carlo` for one filter: ``study.t`` and ``study.average()`` are the curve."""
    return monte_carlo(scenario_name, (method,), seeds, **kwargs)[method]


# --------------------------------------------------------------------------- loop closure
@dataclass
class Reobservation:
    """The loop closure of a SLAM trace, seen from its first landmark.

    Attributes
    ----------
    marker_id : int
        The first landmark the filter mapped.
    t_last, t_again : float
        When it was read last before its longest absence, and read again (s).
        NaN if it was never read again.
    d2 : float
        ``y^T S^-1 y`` of that first reading again (NaN if it was not gated).
    threshold : float
        The gate.
    status : str
        What the filter did with that reading (``"accepted"``, ``"rejected"``...).
    t_accepted : float
        The first time after ``t_last`` a reading of it was accepted (NaN: never).
    n_rejected : int
        How many of its readings after ``t_last`` were rejected before that.
    nees_before : float
        The pose NEES just before that reading was processed (is the filter
        overconfident when the gate decides?).
    """

    marker_id: int
    t_last: float
    t_again: float
    d2: float
    threshold: float
    status: str
    t_accepted: float
    n_rejected: int
    nees_before: float = float("nan")

    @property
    def rejected(self) -> bool:
        return self.status == "rejected"

    @property
    def closed(self) -> bool:
        """True if a reading of the first landmark was accepted after its absence."""
        return bool(np.isfinite(self.t_accepted))


def reobservation(trace: runner.Trace, marker_id: int | None = None) -> Reobservation:
    """Find the loop closure of a SLAM ``trace`` on ``marker_id`` (default: the first mapped).

    The absence is measured on the readings the filter received (its update
    reports), whatever it did with them, so a rejected re-observation is found
    as well as an accepted one.
    """
    if marker_id is None:
        if not trace.filter.landmark_ids:
            raise ValueError("trace: the filter mapped no landmark")
        marker_id = int(trace.filter.landmark_ids[0])
    seen = []                                           # (time, report, its reading's index)
    for t, rep in trace.reports:
        read = rep.ids.tolist()
        if marker_id in read:
            seen.append((t, rep, read.index(marker_id)))
    nan = float("nan")
    if len(seen) < 2:
        return Reobservation(marker_id, seen[0][0] if seen else nan, nan, nan, nan, "never",
                             nan, 0)
    times = np.array([t for t, _, _ in seen])
    g = int(np.argmax(np.diff(times)))
    t_last, (t_again, rep, i) = float(times[g]), seen[g + 1]
    later = seen[g + 1:]
    t_acc, n_rej = nan, 0
    for t, r, j in later:
        if r.status[j] == "accepted":
            t_acc = float(t)
            break
        n_rej += r.status[j] == "rejected"
    # the trace records the state after every event: the one before this update is the prior
    k = int(np.flatnonzero((trace.kind == "update") & (trace.t == t_again))[0])
    nees_before = float(_nees(pose_error(trace.x[k - 1], trace.truth[k]), trace.P[k - 1]))
    return Reobservation(marker_id, t_last, float(t_again), float(rep.d2[i]),
                         float(rep.threshold), str(rep.status[i]), t_acc, int(n_rej),
                         nees_before)


# --------------------------------------------------------------------------- landmark placement
