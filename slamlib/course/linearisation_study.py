"""Chapter 06's one-factor ablation of EKF SLAM's linearisation points (issue 20).

EKF SLAM linearises four links of its chain (the motion, a mapped landmark's
observation, a new landmark's initialisation, the innovation); each can be
moved on its own with :class:`slamlib.ekf.LinearisedEKFSLAM`. This study runs
the variants of :data:`METHODS` on the same 100 seeded runs of chapter 06's
loop (``arena_loop``, the filter's Q matched to the slip, the 0.95 gate) at
two slips, and four of them once more without the gate (:data:`UNGATED`: how
much of what is left is the gate's censoring). ``make linearisation-study``
(``tools/make_linearisation_study.py``) stores it in
``data/studies/ch06_linearisation.json``, bit for bit for any number of workers;
``tests/test_linearisation_study.py`` recomputes a sample.

Per run and filter it keeps the pose and heading NEES at :data:`INSTANTS`
(around marker 61, mapped at about 36 s after a stretch with no marker in view)
and at the end, the time means of both and of the squared pose NEES (for the
run's effective number of independent instants, :func:`t_eff`), the loop
closure (:func:`slamlib.studies.reobservation`) and the gated and rejected
readings of mapped markers; per filter, the Monte-Carlo averages on the grid.
:func:`ablation_rows` tabulates it.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from .. import runner
from ..ekf import LinearisedEKFSLAM
from ..studies import map_jobs, reobservation, sample_trace
from .stored import load_stored

__all__ = ["METHODS", "UNGATED", "STUDY", "INSTANTS", "LABELS", "run_seed", "run_study",
           "load", "ablation_rows", "t_eff", "method_links"]

#: The filters of the ablation (study method name -> the links moved from the estimate).
METHODS = {
    "ekf": {},
    "ekf_init_truth": {"initialisation": "truth"},
    "ekf_obs_first": {"observation": "first"},
    "ekf_motion_first": {"motion": "first"},
    "fej": {"motion": "first", "observation": "first"},
    "ideal": {"motion": "truth", "observation": "truth", "innovation": "truth"},
    "ideal_init": {"motion": "truth", "observation": "truth", "initialisation": "truth",
                   "innovation": "truth"},
    "huang": {"motion": "truth", "observation": "truth", "initialisation": "truth"},
    "ideal_innov_est": {"motion": "truth", "observation": "truth"},
}
#: What each filter is, in the chapter's words.
LABELS = {
    "ekf": "EKF SLAM (every link at the estimate)",
    "ekf_init_truth": "EKF SLAM, initialisation at the truth",
    "ekf_obs_first": "EKF SLAM, observation at first estimates",
    "ekf_motion_first": "EKF SLAM, motion at propagated poses",
    "fej": "FEJ (motion and observation first)",
    "ideal": "ideal, initialisation at the estimate",
    "ideal_init": "ideal, all four links at the truth",
    "huang": "Huang's ideal EKF (innovation at the estimate)",
    "ideal_innov_est": "ideal, innovation and initialisation at the estimate",
}
#: The filters run a second time without the gate (name + "_nogate").
UNGATED = ("ekf", "fej", "ideal_init", "huang")
#: The study: scenario, slips (m/s, the filter's Q matched), gate, grid step and end (s), seeds.
STUDY = {"scenario": "arena_loop", "sigmas": (0.10, 0.14), "gate": 0.95, "step": 0.5,
         "t_end": 58.5, "seeds": tuple(range(1000, 1100))}
#: The instants (s) at which each run's NEES is kept: marker 61 is mapped at about 36 s.
INSTANTS = (36.0, 37.0, 38.0, 39.0, 40.0)


def method_links(method: str) -> tuple[dict, float | None]:
    """``(links, gate)`` of a study method: ``"fej"`` or ``"fej_nogate"``..."""
    base, ungated = (method[:-7], True) if method.endswith("_nogate") else (method, False)
    if base not in METHODS or (ungated and base not in UNGATED):
        names = list(METHODS) + [f"{m}_nogate" for m in UNGATED]
        raise ValueError(f"method: expected one of {names}, got {method!r}")
    return METHODS[base], None if ungated else STUDY["gate"]


def _methods() -> tuple[str, ...]:
    return tuple(METHODS) + tuple(f"{m}_nogate" for m in UNGATED)


def run_seed(job: tuple) -> dict:
    """One seed of the study, ``job = (sigma_wheel, seed, methods)``: per method, the run's
    numbers (see the module docstring) and its NEES on the grid (for the averages)."""
    from ..sim import scenario

    sigma, seed, methods = job
    run = scenario(STUDY["scenario"], seed=int(seed), sigma_wheel=sigma)
    truth = {"truth": runner.truth_function(run), "landmarks": run.world().landmarks(),
             "t0": float(run.enc_t[0])}
    step, t_end = STUDY["step"], STUDY["t_end"]
    grid = np.arange(1, int(round(t_end / step)) + 1) * step
    at = np.searchsorted(grid, INSTANTS)
    out = {}
    for m in methods:
        links, gate = method_links(m)
        filt = runner.make_filter(LinearisedEKFSLAM, run, gate=gate, **links, **truth)
        tr = runner.run_filter(run, filt)
        nees, heading = sample_trace(tr, grid)
        gated = rejected = 0
        for _, rep in tr.reports:
            old = ~np.asarray(rep.new, dtype=bool) & np.isfinite(rep.d2)
            gated += int(old.sum())
            rejected += int((old & ~np.asarray(rep.accepted, dtype=bool)).sum())
        reob = reobservation(tr)
        out[m] = {"run": {
            "seed": int(seed), "nees_at": nees[at].tolist(), "heading_at": heading[at].tolist(),
            "final_nees": float(nees[-1]), "final_heading": float(heading[-1]),
            "mean_nees": float(np.mean(nees)), "mean_heading": float(np.mean(heading)),
            "mean_sq_nees": float(np.mean(nees ** 2)), "closed": bool(reob.closed),
            "closure_status": reob.status, "gated": gated, "rejected": rejected},
            "nees": nees, "heading": heading}
    return out


def run_study(seeds: Iterable[int] = STUDY["seeds"], workers: int = 1,
              sigmas: Iterable[float] = STUDY["sigmas"], methods=None) -> dict:
    """The study over ``seeds``: ``{sigma (str): {method: {"avg", "avg_heading", "runs"}}}``.

    The same numbers, bit for bit, for any ``workers`` (one job per seed, in order).
    """
    methods = _methods() if methods is None else tuple(methods)
    for m in methods:
        method_links(m)
    seeds = tuple(int(s) for s in seeds)
    out = {}
    for sigma in sigmas:
        res = map_jobs(run_seed, [(float(sigma), s, methods) for s in seeds], int(workers))
        out[f"{sigma:.2f}"] = {m: {
            "avg": np.mean([r[m]["nees"] for r in res], axis=0).tolist(),
            "avg_heading": np.mean([r[m]["heading"] for r in res], axis=0).tolist(),
            "runs": [r[m]["run"] for r in res]} for m in methods}
    return out


def load(path=None) -> dict:
    """The stored study (``data/studies/ch06_linearisation.json``, ``make linearisation-study``)."""
    from ..worlds import DATA_DIR

    return load_stored(DATA_DIR / "studies" / "ch06_linearisation.json" if path is None else path,
                       "linearisation-study")


def t_eff(summary: dict) -> float:
    """:func:`slamlib.metrics.effective_instants` (chapter 05's T_eff) of one filter of the stored
    study, from what it keeps: the variance of one instant across the runs, averaged over the
    instants, is ``N/(N-1)`` (mean of the runs' ``mean_sq_nees`` - time mean of ``avg^2``)."""
    runs = summary["runs"]
    n = len(runs)
    avg = np.asarray(summary["avg"], dtype=float)
    var_instant = n / (n - 1) * (np.mean([r["mean_sq_nees"] for r in runs]) - np.mean(avg ** 2))
    return float(var_instant / np.var([r["mean_nees"] for r in runs], ddof=1))


def ablation_rows(doc: dict, sigma: str, methods=None, instants=None) -> list[dict]:
    """One row per filter of one slip of the stored study: the Monte-Carlo average pose NEES at
    ``instants`` (s, on the study's grid; default :data:`INSTANTS`) (``avg_at``) and at the end
    (``avg_end``), the heading's (``heading_at``, ``heading_end``), the mean and median of the
    runs' final pose NEES, of their time means, the share of runs that closed the loop and the
    share of gated readings rejected (pooled over the runs, and the median run's)."""
    block = doc["studies"][sigma]
    t = np.arange(1, len(block["ekf"]["avg"]) + 1) * doc["step"]
    instants = np.asarray(doc["instants"] if instants is None else instants, dtype=float)
    at = np.searchsorted(t, instants)
    if np.any(at >= len(t)) or not np.allclose(t[np.minimum(at, len(t) - 1)], instants):
        raise ValueError(f"instants: expected times on the study's {doc['step']} s grid up to "
                         f"{t[-1]} s, got {instants.tolist()}")
    rows = []
    for m in methods or block:
        s = block[m]
        runs = s["runs"]
        avg, hd = np.asarray(s["avg"]), np.asarray(s["avg_heading"])
        fin = np.array([r["final_nees"] for r in runs])
        means = np.array([r["mean_nees"] for r in runs])
        gated = np.array([r["gated"] for r in runs])
        rej = np.array([r["rejected"] for r in runs])
        rows.append({"method": m, "avg_at": avg[at].tolist(), "avg_end": float(avg[-1]),
                     "heading_at": hd[at].tolist(), "heading_end": float(hd[-1]),
                     "final_mean": float(fin.mean()), "final_median": float(np.median(fin)),
                     "mean_mean": float(means.mean()), "mean_median": float(np.median(means)),
                     "closed": float(np.mean([r["closed"] for r in runs])),
                     "rejected": float(rej.sum() / gated.sum()),
                     "rejected_median_run": float(np.median(rej / gated)),
                     "n_runs": len(runs)})
    return rows
