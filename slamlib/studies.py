"""Studies over many simulated runs: Monte-Carlo NEES, marker density, loop-closure gate (ch. 06).

One filter run says little about a filter's statistics: its errors at
neighbouring instants are strongly correlated, so a time average over one run
is close to one sample. The report's discussion (section VII) makes three
claims that need many runs to be checked; this module runs them, and
``tests/test_consistency.py``, ``tests/test_studies.py``, chapter 06 and the
figure script share it.

- :func:`monte_carlo` / :func:`monte_carlo_nees`: re-simulate a recorded
  scenario with independent seeds, run the map-based EKF and/or EKF SLAM on
  each, and sample the pose NEES (and the heading's normalised error alone) on
  a fixed time grid. :meth:`NEESStudy.average` is the Monte-Carlo average to
  compare with :func:`slamlib.metrics.chi2_band` ``(3, N)``.
- :func:`density_sweep`: EKF SLAM in random marker worlds of one extent and
  increasing marker counts, over several seeds: ATE, final error, map RMSE.
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

from . import runner as ex
from .metrics import chi2_band, pose_error
from .metrics import nees as _nees
from .runs import Run
from .validate import as_covariance

__all__ = ["NEESStudy", "monte_carlo", "monte_carlo_nees", "sample_trace", "DensityRow",
           "random_loop_run", "density_sweep", "Reobservation", "reobservation",
           "LandmarkPlacement", "landmark_placement", "DENSITY_EXTENT"]

_METHODS = ("localization", "slam", "fej", "ideal")


# --------------------------------------------------------------------------- Monte-Carlo NEES
@dataclass
class NEESStudy:
    """Pose NEES of one filter over N seeded runs, sampled on a common time grid.

    Attributes
    ----------
    scenario : str
        The scenario re-simulated (:data:`slamlib.sim.SCENARIOS`).
    method : str
        ``"localization"`` (map-based EKF), ``"slam"``, ``"fej"`` or ``"ideal"``.
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


def sample_trace(trace: ex.Trace, t_grid) -> tuple[np.ndarray, np.ndarray]:
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
_RUNNERS = {"localization": "localization", "slam": "slam", "fej": "fej_slam",
            "ideal": "ideal_slam"}


def _run_method(run: Run, method: str, gate, Q=None):
    if method not in _METHODS:
        raise ValueError(f"method: expected one of {_METHODS}, got {method!r}")
    return getattr(ex, _RUNNERS[method])(run, gate=gate, Q=Q)


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
    last = end if t_end is None else t_end
    t = np.arange(1, int(np.floor(last / step + 1e-9)) + 1) * step
    out = {}
    for m in methods:
        tr = _run_method(run, m, gate, Q)
        a, b = sample_trace(tr, t)
        out[m] = (a, b, ex.ate(tr.x, tr.truth).position,
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
    methods : sequence of {"localization", "slam", "fej", "ideal"}
        The filters (all see the same simulated runs): the map-based EKF, EKF
        SLAM, First-Estimates-Jacobian EKF SLAM (:class:`slamlib.ekf.FEJEKFSLAM`)
        and the ideal EKF SLAM linearised at the truth
        (:class:`slamlib.ekf.IdealEKFSLAM`, a simulation-only diagnostic).
    seeds : iterable of int
        One independent run per seed.
    step : float
        Spacing (s) of the time grid on which the NEES is sampled.
    t_end : float, optional
        Last grid time; default the end of the shortest run (runs end when the
        path is done, a few encoder periods apart).
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
    seeds = tuple(int(s) for s in seeds)
    if not seeds:
        raise ValueError("seeds: expected at least one seed")
    if not step > 0:
        raise ValueError(f"step: expected a positive time step, got {step}")
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers: expected a positive integer, got {workers!r}")
    Q = None if Q is None else as_covariance("Q", Q, 2)
    t_end = None if t_end is None else float(t_end)
    jobs = [(scenario_name, s, methods, float(step), t_end, sigma_wheel, gate, Q,
             sensor_overrides) for s in seeds]
    results = _map(_one_seed, jobs, int(workers))
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


def _map(func, jobs: list, workers: int) -> list:
    """``[func(j) for j in jobs]``, in order, in this process or in a pool of ``workers``."""
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


# --------------------------------------------------------------------------- marker density
#: The random worlds of the density sweep: :func:`slamlib.worlds.random_world`'s default extent.
DENSITY_EXTENT = (0.0, 6.0, -3.0, 3.0)


def random_loop_run(count: int, seed: int, *, extent=DENSITY_EXTENT, sigma_wheel: float = 0.02,
                    margin: float = 1.0) -> tuple:
    """A loop through a random world of ``count`` markers (world and motion from ``seed``).

    Returns ``(world, run)``: the world is not a file of ``data/worlds``, so
    ``run.world()`` cannot load it; use the one returned.

    The world is :func:`slamlib.worlds.random_world` ``(extent, count, seed=seed)``;
    the path is the ellipse of :func:`slamlib.sim.loop_waypoints` (``margin``
    from the border, a little more than one lap), started on the ellipse
    heading along it, as in the recorded ``random_loop``; the analytic sensor.
    """
    from .sensors import AnalyticMarkerSensor
    from .sim import KobukiParams, WaypointController, loop_waypoints, simulate
    from .worlds import random_world

    world = random_world(extent=extent, count=count, seed=seed)
    wp = loop_waypoints(world.bounds, margin=margin)
    start = np.array([wp[0, 0], wp[0, 1], -np.pi / 2])     # on the ellipse, heading -y
    run = simulate(world, WaypointController(wp[1:]), sensor=AnalyticMarkerSensor(),
                   seed=seed, params=KobukiParams(sigma_wheel=sigma_wheel), start_pose=start,
                   name=f"random_{count}_seed{seed}")
    return world, run


@dataclass
class DensityRow:
    """One EKF SLAM run of the density sweep."""

    count: int
    seed: int
    ate: float
    final_error: float
    map_rmse: float
    landmarks: int
    mean_nees: float
    placements: tuple = ()


def density_sweep(counts: Sequence[int] = (4, 8, 16, 32), seeds: Iterable[int] = range(5), *,
                  extent=DENSITY_EXTENT, sigma_wheel: float = 0.02,
                  gate: float | None = 0.95, workers: int = 1) -> list[DensityRow]:
    """EKF SLAM on :func:`random_loop_run` for every marker count and seed.

    Returns one :class:`DensityRow` per (count, seed), counts outermost, with
    the run's :func:`landmark_placement`. ``map_rmse`` is NaN when no landmark
    was mapped. ``workers`` processes share the runs (the same rows for any
    number of workers).
    """
    seeds = tuple(int(s) for s in seeds)
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers: expected a positive integer, got {workers!r}")
    jobs = [(int(n), s, extent, sigma_wheel, gate) for n in counts for s in seeds]
    return _map(_density_row, jobs, int(workers))


def _density_row(job: tuple) -> DensityRow:
    n, s, extent, sigma_wheel, gate = job
    world, run = random_loop_run(n, s, extent=extent, sigma_wheel=sigma_wheel)
    tr = ex.slam(run, gate=gate)
    m = tr.metrics(world)
    return DensityRow(n, s, m["ate_xy"], m["final_xy_error"], m.get("map_rmse", float("nan")),
                      int(m["landmarks"]), m["mean_nees"], tuple(landmark_placement(tr, world)))


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


def reobservation(trace: ex.Trace, marker_id: int | None = None) -> Reobservation:
    """Find the loop closure of a SLAM ``trace`` on ``marker_id`` (default: the first mapped).

    The absence is measured on the readings the filter received (its update
    reports), whatever it did with them, so a rejected re-observation is found
    as well as an accepted one.
    """
    if marker_id is None:
        if not trace.filter.landmark_ids:
            raise ValueError("trace: the filter mapped no landmark")
        marker_id = int(trace.filter.landmark_ids[0])
    seen = [(t, rep, int(np.flatnonzero(rep.ids == marker_id)[0]))
            for t, rep in trace.reports if np.any(rep.ids == marker_id)]
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
@dataclass
class LandmarkPlacement:
    """Where one landmark was put when it was mapped, and where it ended up (m)."""

    marker_id: int
    t_added: float
    pose_error: float
    heading_error: float
    error_added: float
    error_final: float


def landmark_placement(trace: ex.Trace, world) -> list[LandmarkPlacement]:
    """For every landmark of a SLAM ``trace``: the robot's position and heading error when
    the landmark was added, the landmark's error then, and its error at the end.

    The landmark's first estimate is recomputed from the trace: the inverse
    observation (:func:`slamlib.models.inverse_observe`) of its first reading
    from the pose after that update, which is what :class:`~slamlib.ekf.EKFSLAM`
    does. Ids not in ``world`` (misreads) are left out.
    """
    from .models import inverse_observe

    true = world.landmarks()
    final = trace.filter.landmarks
    out = []
    upd = np.flatnonzero(trace.kind == "update")
    for (t, rep), k in zip(trace.reports, upd):
        for i in np.flatnonzero(rep.new):
            mid = int(rep.ids[i])
            if mid not in true:
                continue
            p0 = inverse_observe(trace.x[k], rep.z[i])
            e = trace.error[k]
            out.append(LandmarkPlacement(mid, float(t), float(np.hypot(e[0], e[1])),
                                         float(e[2]), float(np.hypot(*(p0 - true[mid]))),
                                         float(np.hypot(*(final[mid] - true[mid])))))
    return out


# --------------------------------------------------------------------------- chapter 06's table
#: The Monte-Carlo studies of chapter 06, stored in ``data/studies/ch06_consistency.json`` by
#: ``make studies`` (``tools/make_studies.py``): key -> (scenario, sigma_wheel, filter's Q,
#: gate, methods). ``"nominal"`` Q is the one of sigma_wheel = 0.02 (the filter does not
#: know the slip); ``"matched"`` follows the run.
CH06_STUDIES = {
    "arena_0.02": ("arena_loop", 0.02, "matched", 0.95, ("slam", "fej", "ideal")),
    "arena_0.10": ("arena_loop", 0.10, "matched", 0.95, ("slam", "fej", "ideal")),
    "arena_0.14": ("arena_loop", 0.14, "matched", 0.95, ("slam", "fej", "ideal")),
    "arena_0.10_nominalQ": ("arena_loop", 0.10, "nominal", 0.95, ("slam", "fej", "ideal")),
    "arena_0.14_nominalQ": ("arena_loop", 0.14, "nominal", 0.95, ("slam", "fej", "ideal")),
    "arena_0.14_gate0.99999": ("arena_loop", 0.14, "matched", 0.99999, ("slam", "fej")),
    "arena_0.14_nominalQ_gate0.99999": ("arena_loop", 0.14, "nominal", 0.99999, ("slam",)),
    "laps_0.02": ("arena_laps", 0.02, "matched", 0.95, ("slam", "fej", "ideal")),
    "laps_0.10": ("arena_laps", 0.10, "matched", 0.95, ("slam", "fej", "ideal")),
}
#: The seeds of chapter 06's studies.
CH06_SEEDS = tuple(range(1000, 1100))


def load_ch06_studies(path=None) -> dict:
    """The stored studies of :data:`CH06_STUDIES` (``data/studies/ch06_consistency.json``)."""
    import json
    from pathlib import Path

    from .worlds import DATA_DIR

    p = Path(path) if path is not None else DATA_DIR / "studies" / "ch06_consistency.json"
    if not p.is_file():
        raise ValueError(f"path: {p} does not exist; run `make studies` to make it")
    return json.loads(p.read_text(encoding="utf-8"))


def nominal_Q(scenario_name: str = "arena_loop", seed: int = 1000) -> np.ndarray:
    """The wheel-speed covariance of the nominal slip (sigma_wheel = 0.02) of a scenario."""
    from .sim import scenario

    return scenario(scenario_name, seed=seed, sigma_wheel=0.02).Q()


def run_study(key: str, seeds: Iterable[int] = CH06_SEEDS, workers: int = 1
              ) -> dict[str, NEESStudy]:
    """One study of :data:`CH06_STUDIES` over ``seeds``: ``{method: NEESStudy}``."""
    scenario_name, sigma, q, gate, methods = CH06_STUDIES[key]
    Q = nominal_Q(scenario_name) if q == "nominal" else None
    return monte_carlo(scenario_name, methods, seeds, sigma_wheel=sigma, gate=gate, Q=Q,
                       workers=workers)


def summarise(study: NEESStudy) -> dict:
    """What chapter 06 keeps of a study (JSON-ready): the averages and each run's numbers.

    ``avg`` and ``avg_heading`` are the Monte-Carlo averages on the time grid
    ``t``; ``runs`` has, per seed, the run's time-mean pose and heading NEES,
    its NEES at the last grid time, its ATE and its loop closure
    (:class:`Reobservation`: ``d2``, ``status``, ``closed``, ``nees_before``).
    """
    runs = []
    for i, seed in enumerate(study.seeds):
        r = study.reobservations[i] if study.reobservations else None
        runs.append({
            "seed": int(seed), "mean_nees": float(np.mean(study.nees[i])),
            "mean_nees_heading": float(np.mean(study.nees_heading[i])),
            "final_nees": float(study.nees[i, -1]), "ate": float(study.ate[i]),
            "closure_d2": None if r is None else _finite_or_none(r.d2),
            "closure_status": None if r is None else r.status,
            "closed": None if r is None else bool(r.closed),
            "nees_before_closure": None if r is None else _finite_or_none(r.nees_before),
        })
    return {"method": study.method, "t": study.t.tolist(), "avg": study.average().tolist(),
            "avg_heading": study.average(heading=True).tolist(), "runs": runs}


def _finite_or_none(v: float):
    return float(v) if np.isfinite(v) else None


# --------------------------------------------------------------------------- observability
@dataclass
class Observability:
    """The linearised system a SLAM filter used over a stretch of a run (chapter 06).

    Attributes
    ----------
    singular_values : numpy.ndarray
        Of the observability matrix ``O`` (rows ``H_k Phi(k, 0)`` of every fused
        reading, columns the state at the end, landmarks in state order), in
        decreasing order, divided by the largest.
    rotation : numpy.ndarray
        ``|H_k Phi(k, 0) N_rot|`` for every fused reading (N_rot: a rotation of
        the robot's start pose and of every landmark's first estimate about the
        origin), divided by ``|H_k|``: zero when the filter's linearisation keeps
        the rotation unobservable.
    translation : numpy.ndarray
        The same for a translation of everything along x (zero for every filter).
    n_state : int
        The state size at the end.
    """

    singular_values: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    n_state: int

    def null_dimension(self, tol: float = 1e-9) -> int:
        """Directions the linearised system cannot observe (singular values below ``tol``)."""
        return int(np.sum(self.singular_values < tol))


def observability(filter_cls, run: Run, t_end: float = 20.0, **kwargs) -> Observability:
    """Record the Jacobians a SLAM filter (``EKFSLAM``, ``FEJEKFSLAM``) uses on ``run`` up to
    ``t_end`` and build its observability matrix (chapter 06's numerical check).

    ``Phi(k, 0)`` is the product of the robot's ``A`` since the start (landmarks
    do not move); ``H_k`` are the Jacobians the filter fused with (for FEJ its
    first-estimate ones). Only the landmarks that were fused at least once
    are kept (a landmark seen only when it was added constrains nothing).
    """
    filt = ex.make_filter(filter_cls, run, Q=kwargs.get("Q"), gate=kwargs.get("gate", 0.95))
    phi = [np.eye(3)]
    rows = []                                   # (Phi so far, slots, Hp, Hl)
    predict_cov, fuse = filt._predict_cov, filt._fuse
    jac = getattr(filt, "_linearisation_jacobians", None)

    def spy_predict(A, W):
        phi.append(A @ phi[-1])
        predict_cov(A, W)

    def spy_fuse(slots, Hp, Hl, y, R):
        Hp_u, Hl_u = jac(slots, Hp, Hl) if jac is not None else (Hp, Hl)
        rows.append((phi[-1].copy(), slots.copy(), Hp_u.copy(), Hl_u.copy()))
        return fuse(slots, Hp, Hl, y, R)

    first: dict[int, np.ndarray] = {}          # slot -> where the landmark was put
    add = filt._add_landmark

    def spy_add(marker_id, z, R):
        add(marker_id, z, R)
        slot = filt.landmark_index(marker_id)
        first[slot] = filt._x[slot:slot + 2].copy()

    filt._predict_cov, filt._fuse, filt._add_landmark = spy_predict, spy_fuse, spy_add
    ex.run_filter(run, filt, max_time=t_end)
    fused = sorted({int(s) for _, slots, _, _ in rows for s in slots})
    col = {s: 3 + 2 * j for j, s in enumerate(fused)}
    n = 3 + 2 * len(fused)
    O, rot, tra = [], [], []
    x0 = run.start_pose
    for Phi, slots, Hp, Hl in rows:
        for j, s in enumerate(slots):
            H = np.zeros((2, n))
            H[:, :3] = Hp[j] @ Phi
            H[:, col[int(s)]:col[int(s)] + 2] = Hl[j]
            O.append(H)
            m0 = first[int(s)]
            n_rot = np.zeros(n)
            n_rot[:3] = [-x0[1], x0[0], 1.0]
            n_rot[col[int(s)]:col[int(s)] + 2] = [-m0[1], m0[0]]
            n_tra = np.zeros(n)
            n_tra[0] = 1.0
            n_tra[col[int(s)]] = 1.0
            scale = np.linalg.norm(H)
            rot.append(np.linalg.norm(H @ n_rot) / scale)
            tra.append(np.linalg.norm(H @ n_tra) / scale)
    O = np.vstack(O)
    sv = np.linalg.svd(O, compute_uv=False)
    return Observability(sv / sv[0], np.array(rot), np.array(tra), n)



def summary_numbers(summary: dict, prob: float = 0.95) -> dict:
    """The numbers chapter 06 tabulates from one stored study of one filter (:func:`summarise`).

    ``avg_mean`` is the time mean of the Monte-Carlo average pose NEES,
    ``avg_final`` the average at the last grid time, ``inside`` the share of
    grid times at which the average lies in the per-instant band
    ``chi2_band(3, N, prob)`` (``band``), ``heading_mean`` the time mean of the
    average heading NEES, ``ate`` the mean ATE (m); for the SLAM filters
    ``closed`` is the share of runs whose loop closure was accepted (at once or
    later), ``first_rejected`` the share whose first re-observation was
    rejected, ``nees_before`` the mean and ``nees_before_median`` the median
    pose NEES just before that first re-observation, ``d2_median`` its median
    squared Mahalanobis distance.
    """
    runs = summary["runs"]
    n = len(runs)
    avg = np.asarray(summary["avg"], dtype=float)
    lo, hi = chi2_band(3, n, prob)
    out = {"n_runs": n, "band": (lo, hi), "avg_mean": float(avg.mean()),
           "avg_final": float(avg[-1]), "inside": float(np.mean((avg > lo) & (avg < hi))),
           "heading_mean": float(np.mean(summary["avg_heading"])),
           "ate": float(np.mean([r["ate"] for r in runs]))}
    if runs and runs[0]["closed"] is not None:
        nb = np.array([np.nan if r["nees_before_closure"] is None else r["nees_before_closure"]
                       for r in runs])
        d2 = np.array([np.nan if r["closure_d2"] is None else r["closure_d2"] for r in runs])
        out.update(closed=float(np.mean([r["closed"] for r in runs])),
                   first_rejected=float(np.mean([r["closure_status"] == "rejected"
                                                 for r in runs])),
                   nees_before=float(np.nanmean(nb)), nees_before_median=float(np.nanmedian(nb)),
                   d2_median=float(np.nanmedian(d2)))
    return out
