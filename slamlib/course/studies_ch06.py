"""Chapter 06's studies: marker density, the stored Monte-Carlo studies, observability.

- :func:`density_sweep`: EKF SLAM in random marker worlds of one extent and
  increasing marker counts, over several seeds: ATE, final error, map RMSE,
  where each landmark was put (:func:`landmark_placement`).
- :data:`CH06_STUDIES`: the 100-seed studies of :func:`slamlib.studies.monte_carlo`
  that ``make studies`` (``tools/make_studies.py``) stores in
  ``data/studies/ch06_consistency.json``; :func:`load_ch06_studies`, :func:`run_study`,
  :func:`summarise` and :func:`summary_numbers` read, recompute and tabulate them.
- :data:`GATE_STUDY` and :func:`gate_readings`: every gated reading of the
  true markers, per filter, slip and seed: how many the 0.95 gate rejects, at
  what pose NEES, before and after the loop closure; stored by
  ``make gate-study`` in ``data/studies/ch06_gate.json`` (:func:`load_gate_study`).
- :func:`robust_summary`: a column of per-seed values as chapter 06 quotes it
  (mean, median, BCa bootstrap interval, the largest run and the mean without it).
- :func:`observability`: the rank of the observability matrix a filter's own
  linearisation builds (EKF SLAM against First-Estimates Jacobians).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from .. import runner
from ..metrics import SeedSpread, chi2_band, chi2_quantile, seed_spread
from ..runs import Run
from ..studies import NEESStudy, map_jobs, monte_carlo
from .stored import load_stored

__all__ = ["DENSITY_EXTENT", "random_loop_run", "DensityRow", "density_sweep",
           "LandmarkPlacement", "landmark_placement", "CH06_STUDIES", "CH06_SEEDS",
           "load_ch06_studies", "nominal_Q", "run_study", "summarise", "summary_numbers",
           "Observability", "observability", "GATE_STUDY", "GATE_METHODS", "gate_readings",
           "load_gate_study", "RobustSummary", "robust_summary", "column_summary", "gate_rates",
           "band_shares", "motion_chain"]


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
    from ..sensors import AnalyticMarkerSensor
    from ..sim import KobukiParams, WaypointController, loop_waypoints, simulate
    from ..worlds import random_world

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
    return map_jobs(_density_row, jobs, int(workers))


def _density_row(job: tuple) -> DensityRow:
    n, s, extent, sigma_wheel, gate = job
    world, run = random_loop_run(n, s, extent=extent, sigma_wheel=sigma_wheel)
    tr = runner.slam(run, gate=gate)
    m = tr.metrics(world)
    return DensityRow(n, s, m["ate_xy"], m["final_xy_error"], m.get("map_rmse", float("nan")),
                      int(m["landmarks"]), m["mean_nees"], tuple(landmark_placement(tr, world)))


@dataclass
class LandmarkPlacement:
    """Where one landmark was put when it was mapped, and where it ended up (m)."""

    marker_id: int
    t_added: float
    pose_error: float
    heading_error: float
    error_added: float
    error_final: float


def landmark_placement(trace: runner.Trace, world) -> list[LandmarkPlacement]:
    """For every landmark of a SLAM ``trace``: the robot's position and heading error when
    the landmark was added, the landmark's error then, and its error at the end.

    The landmark's first estimate is recomputed from the trace: the inverse
    observation (:func:`slamlib.models.inverse_observe`) of its first reading
    from the pose after that update, which is what :class:`~slamlib.ekf.EKFSLAM`
    does. Ids not in ``world`` (misreads) are left out.
    """
    from ..models import inverse_observe

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
    "arena_0.10": ("arena_loop", 0.10, "matched", 0.95, ("slam", "fej", "ideal",
                   "ideal_init")),
    "arena_0.14": ("arena_loop", 0.14, "matched", 0.95, ("slam", "fej", "ideal",
                   "ideal_init")),
    "arena_0.10_nominalQ": ("arena_loop", 0.10, "nominal", 0.95, ("slam", "fej", "ideal")),
    "arena_0.14_nominalQ": ("arena_loop", 0.14, "nominal", 0.95, ("slam", "fej", "ideal")),
    "arena_0.14_gate0.99999": ("arena_loop", 0.14, "matched", 0.99999, ("slam", "fej")),
    "arena_0.14_nominalQ_gate0.99999": ("arena_loop", 0.14, "nominal", 0.99999, ("slam",)),
    "laps_0.02": ("arena_laps", 0.02, "matched", 0.95, ("slam", "fej", "ideal")),
    "laps_0.10": ("arena_laps", 0.10, "matched", 0.95, ("slam", "fej", "ideal",
                  "ideal_init")),
}
#: The seeds of chapter 06's studies.
CH06_SEEDS = tuple(range(1000, 1100))


def load_ch06_studies(path=None) -> dict:
    """The stored studies of :data:`CH06_STUDIES` (``data/studies/ch06_consistency.json``)."""
    from ..worlds import DATA_DIR

    return load_stored(DATA_DIR / "studies" / "ch06_consistency.json" if path is None else path,
                       "studies")


def nominal_Q(scenario_name: str = "arena_loop", seed: int = 1000) -> np.ndarray:
    """The wheel-speed covariance of the nominal slip (sigma_wheel = 0.02) of a scenario."""
    from ..sim import scenario

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
        the rotation unobservable. The landmarks are states of their own here:
        their initialisation is left out.
    rotation_init : numpy.ndarray
        The same with the initialisation link in the chain: a landmark's error
        is what its initialisation made of the pose's, ``J1 Phi(k_0, 0)`` (``k_0``:
        when it was mapped), so each reading sees ``|(H_pose Phi(k, 0) + H_landmark
        J1 Phi(k_0, 0)) N_0| / |H_k|`` of a rotation ``N_0`` of the start pose.
    translation : numpy.ndarray
        The same as ``rotation`` for a translation of everything along x (zero for every
        filter).
    n_state : int
        The state size at the end.
    """

    singular_values: np.ndarray
    rotation: np.ndarray
    rotation_init: np.ndarray
    translation: np.ndarray
    n_state: int

    def null_dimension(self, tol: float = 1e-9) -> int:
        """Directions the linearised system cannot observe (singular values below ``tol``)."""
        return int(np.sum(self.singular_values < tol))


def observability(filter_cls, run: Run, t_end: float = 20.0, options: dict | None = None,
                  Q=None, gate: float | None = 0.95) -> Observability:
    """Record the Jacobians a SLAM filter (``EKFSLAM``, ``FEJEKFSLAM``, ``LinearisedEKFSLAM``
    with ``options``) uses on ``run`` up to ``t_end`` and build its observability matrix
    (chapter 06's numerical check).

    ``Phi(k, 0)`` is the product of the robot's ``A`` since the start (landmarks
    do not move); ``H_k`` are the Jacobians the filter fused with (for FEJ its
    first-estimate ones); ``J1`` those of each landmark's initialisation. Only the
    landmarks that were fused at least once are kept (a landmark seen only when
    it was added constrains nothing).
    """
    filt = runner.make_filter(filter_cls, run, Q=Q, gate=gate, **(options or {}))
    phi = [np.eye(3)]
    rows = []                                   # (Phi so far, slots, Hp, Hl)
    first: dict[int, np.ndarray] = {}          # slot -> where the landmark was put
    init: dict[int, np.ndarray] = {}           # slot -> J1 Phi(k_0, 0) of its initialisation
    last: dict = {}
    jacobians, update = filt.jacobians, filt.update

    def spy_jacobians(link, **kw):              # the filter's one linearisation hook
        out = jacobians(link, **kw)
        if link == "motion":
            phi.append(out[0] @ phi[-1])
        elif link == "observation":
            last["H"] = out[1:]                 # the gated readings' Jacobians, in order
        elif link == "initialisation":          # each new landmark's J1 Phi(k_0, 0)
            last["init"] = {int(i): J1 @ phi[-1] for i, J1 in zip(kw["ids"], out[1])}
        return out

    def spy_update(ids, z, R=None):
        rep = update(ids, z, R)
        gated = [i for i, s in enumerate(rep.status)
                 if s in ("accepted", "rejected", "degenerate")]
        acc = [q for q, i in enumerate(gated) if rep.accepted[i]]
        if acc:
            slots = np.array([filt.landmark_index(int(rep.ids[gated[q]])) for q in acc])
            rows.append((phi[-1].copy(), slots, last["H"][0][acc], last["H"][1][acc]))
        for i in np.flatnonzero(rep.new):
            mid = int(rep.ids[i])
            first[filt.landmark_index(mid)] = filt.landmark(mid)
            init[filt.landmark_index(mid)] = last["init"][mid]
        return rep

    filt.jacobians, filt.update = spy_jacobians, spy_update
    runner.run_filter(run, filt, max_time=t_end, use_run_Q_steps=Q is None)
    fused = sorted({int(s) for _, slots, _, _ in rows for s in slots})
    col = {s: 3 + 2 * j for j, s in enumerate(fused)}
    n = 3 + 2 * len(fused)
    O, rot, rot_init, tra = [], [], [], []
    x0 = run.start_pose
    n0 = np.array([-x0[1], x0[0], 1.0])
    for Phi, slots, Hp, Hl in rows:
        for j, s in enumerate(slots):
            H = np.zeros((2, n))
            H[:, :3] = Hp[j] @ Phi
            H[:, col[int(s)]:col[int(s)] + 2] = Hl[j]
            O.append(H)
            m0 = first[int(s)]
            n_rot = np.zeros(n)
            n_rot[:3] = n0
            n_rot[col[int(s)]:col[int(s)] + 2] = [-m0[1], m0[0]]
            n_tra = np.zeros(n)
            n_tra[0] = 1.0
            n_tra[col[int(s)]] = 1.0
            scale = np.linalg.norm(H)
            rot.append(np.linalg.norm(H @ n_rot) / scale)
            rot_init.append(np.linalg.norm((Hp[j] @ Phi + Hl[j] @ init[int(s)]) @ n0) / scale)
            tra.append(np.linalg.norm(H @ n_tra) / scale)
    O = np.vstack(O)
    sv = np.linalg.svd(O, compute_uv=False)
    return Observability(sv / sv[0], np.array(rot), np.array(rot_init), np.array(tra), n)


def motion_chain(filter_cls, run: Run, t_end: float = 20.0, options: dict | None = None
                 ) -> tuple[np.ndarray, np.ndarray, int]:
    """The robot's motion Jacobians a SLAM filter used on ``run`` up to ``t_end``, multiplied in
    order (updates between them), and the one Jacobian of the whole interval built from the
    filter's propagated poses (chapter 06, step 5): ``(product, whole, count)``.

    ``whole`` is ``[[1, 0, -(y_b - y_a)], [0, 1, x_b - x_a], [0, 0, 1]]`` with ``a`` the
    propagated pose before the first prediction and ``b`` after the last (``propagated_pose``,
    :class:`slamlib.ekf.LinearisedEKFSLAM`): FEJ's product equals it to round-off, EKF SLAM's
    does not (its steps start at updated poses).
    """
    filt = runner.make_filter(filter_cls, run, **(options or {}))
    if not hasattr(filt, "propagated_pose"):
        raise ValueError(f"filter_cls: expected a LinearisedEKFSLAM (it keeps the propagated "
                         f"poses), got {filter_cls.__name__}")
    product, count = [np.eye(3)], [0]
    jacobians = filt.jacobians

    def spy_jacobians(link, **kw):               # the filter's one linearisation hook
        out = jacobians(link, **kw)
        if link == "motion":                     # (A, W) of each prediction
            product[0] = out[0] @ product[0]     # Phi = A_k ... A_0
            count[0] += 1
        return out

    start = np.array(filt.propagated_pose, dtype=float)
    filt.jacobians = spy_jacobians
    runner.run_filter(run, filt, max_time=t_end)
    d = np.asarray(filt.propagated_pose, dtype=float) - start
    whole = np.array([[1.0, 0.0, -d[1]], [0.0, 1.0, d[0]], [0.0, 0.0, 1.0]])
    return product[0], whole, count[0]


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


def band_shares(avg, n_runs: int, *, shift: float = 0.0, dof: int = 3, prob: float = 0.95
                ) -> dict:
    """Where a Monte-Carlo average NEES curve lies against the band of one instant.

    ``avg`` is the average over ``n_runs`` runs at each grid time; the band is
    ``chi2_band(dof, n_runs, prob)``. Returns the shares of grid times
    ``below``, ``inside`` and ``above`` it (a point on an edge counts as
    inside), for the curve raised by ``shift`` (``shift=0``: as measured; a
    shift shows how fragile the share inside is when the curve runs along an
    edge).
    """
    a = np.asarray(avg, dtype=float)
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)):
        raise ValueError("avg: expected a non-empty 1-d array of finite numbers, "
                         f"got shape {a.shape}")
    if isinstance(n_runs, bool) or not isinstance(n_runs, (int, np.integer)) or n_runs < 1:
        raise ValueError(f"n_runs: expected a positive integer, got {n_runs!r}")
    lo, hi = chi2_band(dof, int(n_runs), prob)
    a = a + float(shift)
    below, above = float(np.mean(a < lo)), float(np.mean(a > hi))
    return {"below": below, "inside": 1.0 - below - above, "above": above, "band": (lo, hi)}


# --------------------------------------------------------------------------- the gate's readings
#: Chapter 06's study of every gated reading (``make gate-study``): the arena loop, matched Q,
#: gate 0.95, the seeds :data:`CH06_SEEDS`, at these slips.
GATE_STUDY = {"scenario": "arena_loop", "sigmas": (0.02, 0.10, 0.14), "gate": 0.95,
              "t_end": 58.5}
#: The filters of the gate study: ``"ideal_estimate"`` is the ideal EKF with EKF SLAM's
#: innovation ``z - h(x)`` (``IdealEKFSLAM(..., innovation="estimate")``), its landmarks still
#: initialised at the estimate: not Huang et al.'s ideal EKF (``landmark_init="truth"`` too).
GATE_METHODS = ("slam", "fej", "ideal", "ideal_estimate")


def _gate_trace(run: Run, method: str, gate: float):
    if method == "ideal_estimate":
        return runner.ideal_slam(run, innovation="estimate", gate=gate)
    from ..studies import _run_method

    return _run_method(run, method, gate)


def gate_readings(job: tuple) -> dict:
    """One seed of the gate study: ``job = (scenario, seed, sigma_wheel, gate, t_end, methods)``.

    For each filter, over every reading of an already-mapped (true) marker:
    ``gated`` and ``rejected`` counts, ``d2_sum`` (sum of their ``y^T S^-1 y``),
    the same counts for the readings whose prior pose NEES was below
    ``chi2_3(0.95) = 7.81`` (``gated_low``, ``rejected_low``: a pose that looks
    consistent), and for the readings before the loop closure
    (``gated_before``, ``rejected_before``: earlier than the first landmark's
    re-observation, :func:`slamlib.studies.reobservation`); then the loop
    closure (``closure_status``, ``closed``), the pose NEES at ``t_end``
    (``final_nees``) and its mean on the grid ``0.5, 1.0, ..., t_end``
    (``mean_nees``), as in :data:`CH06_STUDIES`. The prior NEES of a reading is
    the trace's NEES after the event before its update.
    """
    from ..sim import scenario
    from ..studies import reobservation, sample_trace

    name, seed, sigma, gate, t_end, methods = job
    grid = np.arange(1, int(round(t_end / 0.5)) + 1) * 0.5
    run = scenario(name, seed=seed, sigma_wheel=sigma)
    low = chi2_quantile(0.95, 3)
    out = {"seed": int(seed)}
    for m in methods:
        tr = _gate_trace(run, m, gate)
        nees = tr.nees
        reob = reobservation(tr)
        t_close = reob.t_again if np.isfinite(reob.t_again) else np.inf
        upd = np.flatnonzero(tr.kind == "update")
        c = dict.fromkeys(("gated", "rejected", "gated_low", "rejected_low", "gated_before",
                           "rejected_before"), 0)
        d2_sum = 0.0
        for (t, rep), k in zip(tr.reports, upd):
            old = ~np.asarray(rep.new, dtype=bool) & np.isfinite(rep.d2)
            if not old.any():
                continue
            rej = old & ~np.asarray(rep.accepted, dtype=bool)
            n, r = int(old.sum()), int(rej.sum())
            d2_sum += float(np.sum(rep.d2[old]))
            c["gated"] += n
            c["rejected"] += r
            if nees[k - 1] < low:
                c["gated_low"] += n
                c["rejected_low"] += r
            if t < t_close:
                c["gated_before"] += n
                c["rejected_before"] += r
        on_grid, _ = sample_trace(tr, grid)
        out[m] = {**c, "d2_sum": d2_sum, "closure_status": reob.status,
                  "closed": bool(reob.closed), "final_nees": float(on_grid[-1]),
                  "mean_nees": float(np.mean(on_grid))}
    return out


def run_gate_study(seeds: Iterable[int] = CH06_SEEDS, workers: int = 1) -> dict:
    """The gate study over ``seeds``: ``{sigma (str): [gate_readings of each seed]}``."""
    out = {}
    for sigma in GATE_STUDY["sigmas"]:
        jobs = [(GATE_STUDY["scenario"], int(s), sigma, GATE_STUDY["gate"], GATE_STUDY["t_end"],
                 GATE_METHODS) for s in seeds]
        out[f"{sigma:.2f}"] = map_jobs(gate_readings, jobs, int(workers))
    return out


def load_gate_study(path=None) -> dict:
    """The stored gate study (``data/studies/ch06_gate.json``, ``make gate-study``)."""
    from ..worlds import DATA_DIR

    return load_stored(DATA_DIR / "studies" / "ch06_gate.json" if path is None else path,
                       "gate-study")


# --------------------------------------------------------------------------- quoting a mean
#: A column of per-seed values as chapter 06 quotes it (:func:`robust_summary`).
RobustSummary = SeedSpread


def robust_summary(values, seeds, level: float = 0.95) -> SeedSpread:
    """Mean, median and BCa bootstrap interval (:func:`slamlib.metrics.seed_spread`, seed 0) of
    ``values``, with the seed of the largest value and the mean without it. Where one run
    carries the mean, even the BCa interval under-covers on the upper side
    (:func:`slamlib.metrics.mean_interval`)."""
    return seed_spread(values, seeds, level=level, method="BCa")


def column_summary(summary: dict, field: str = "mean_nees") -> RobustSummary:
    """:func:`robust_summary` of one per-run field of a stored study (:func:`summarise`)."""
    runs = summary["runs"]
    return robust_summary([r[field] for r in runs], [r["seed"] for r in runs])


def gate_rates(runs: Sequence[dict], method: str) -> dict:
    """Pooled rates of the gate study's runs (:func:`gate_readings`) for one filter.

    ``per_run`` gated readings per run; ``rejected`` the share of all gated
    readings of true markers that the gate rejected; ``mean_d2`` their mean
    ``y^T S^-1 y`` (2 for a consistent filter: chi-square with 2 degrees of
    freedom); ``rejected_low`` the share rejected among the readings whose prior
    pose NEES was below 7.81, ``low`` the share of readings with such a prior;
    ``rejected_before`` / ``rejected_after`` before and from the loop closure;
    ``first_rejected`` how many runs' loop-closure reading was rejected.
    """
    c = {k: sum(r[method][k] for r in runs) for k in
         ("gated", "rejected", "gated_low", "rejected_low", "gated_before", "rejected_before")}
    d2 = sum(r[method]["d2_sum"] for r in runs)
    after = c["gated"] - c["gated_before"]

    def share(a, b):
        return a / b if b else float("nan")

    return {"per_run": c["gated"] / len(runs), "rejected": share(c["rejected"], c["gated"]),
            "mean_d2": share(d2, c["gated"]),
            "low": share(c["gated_low"], c["gated"]),
            "rejected_low": share(c["rejected_low"], c["gated_low"]),
            "rejected_before": share(c["rejected_before"], c["gated_before"]),
            "rejected_after": share(c["rejected"] - c["rejected_before"], after),
            "first_rejected": int(sum(r[method]["closure_status"] == "rejected" for r in runs)),
            "n_runs": len(runs)}
