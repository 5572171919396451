"""Chapter 11's study: EKF SLAM against batch and incremental smoothing over 100 seeds.

For each seed, the arena loop is re-simulated (:func:`slamlib.sim.scenario`),
at the nominal wheel slip and at a high one, and five estimates are made from
the SAME run:

- ``ekf``: :func:`slamlib.runner.slam` (filtered: the pose at t from the
  readings up to t; with its chi-square gate, 0.95; ``rejected``: readings it rejected);
- ``ekf_ungated``: the same without the gate (every reading fused, as in the graph);
- ``isam2_online``: :func:`slamlib.graph.smooth` ``(method="isam2")``, the
  estimate of each pose right after its own update (also filtered: the same
  information as the EKF at every instant);
- ``batch``: :func:`slamlib.graph.smooth` ``(method="batch")`` (smoothed: every
  pose from ALL the readings, before and after it);
- ``isam2``: iSAM2's final, smoothed estimate (kept to show it equals batch;
  its NEES curve, equal to batch's, is not stored).

Per estimate: the position ATE over its poses, the final position error, the
pose NEES on a 1 s grid (and its mean), the final map's RMS error and its mean
landmark NEES (2 degrees of freedom). The final map and the last pose carry
the same information in all of them (except that the gated EKF drops the
readings its gate rejects): only their linearisation differs.

100 seeds x 2 cases take several minutes, more than a chapter may spend, so
``make graph-study`` (``python -m slamlib.course.graph_study``) stores the
numbers in ``data/studies/graph_arena.json`` (rounded to 6 significant
digits, no timings: bit for bit the same on every regeneration, whatever the
number of worker processes); ``tests/test_graph_course.py`` recomputes a sample
of seeds and compares.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from .. import graph, runner
from ..metrics import SeedSpread, chi2_band, nees, pose_error, seed_spread
from ..sim import scenario
from ..studies import map_jobs, sample_trace
from ..worlds import DATA_DIR
from .stored import load_stored

__all__ = ["CASES", "SEEDS", "GRID", "ESTIMATES", "STUDY_FILE", "FORMAT", "run_seed", "study",
           "save", "load", "Study", "Spread", "spread", "main"]

FORMAT = "slamlib-graph-study/1"
#: Where ``make graph-study`` writes the study.
STUDY_FILE = DATA_DIR / "studies" / "graph_arena.json"
#: The scenario re-simulated, and the wheel slip of each case (m/s per encoder period).
SCENARIO = "arena_loop"
CASES = {"nominal": 0.02, "high_slip": 0.10}
#: One run per seed (independent of the recorded run's seed 1).
SEEDS = tuple(range(2000, 2100))
#: The NEES is sampled every second (s).
GRID = np.arange(1.0, 59.0, 1.0)
#: The estimates compared.
ESTIMATES = ("ekf", "ekf_ungated", "isam2_online", "batch", "isam2")
_DIGITS = 6


def _r(v) -> float | list:
    if np.ndim(v):
        return [_r(a) for a in np.asarray(v, dtype=float)]
    return float(f"{float(v):.{_DIGITS}g}")


def _map_figures(landmarks: dict, cov_of, world) -> tuple[float, float]:
    true = world.landmarks()
    err, nn = [], []
    for i, p in landmarks.items():
        if i not in true:
            continue
        d = np.asarray(p) - true[i]
        err.append(float(d @ d))
        nn.append(float(nees(d, cov_of(i))))
    if not err:
        return float("nan"), float("nan")
    return float(np.sqrt(np.mean(err))), float(np.mean(nn))


def _figures(tr: runner.Trace, landmarks: dict, cov_of, world, curve: bool = True) -> dict:
    e = pose_error(tr.x, tr.truth)
    grid_nees, _ = sample_trace(tr, GRID)
    rmse, mnees = _map_figures(landmarks, cov_of, world)
    out = {"ate_xy": _r(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2))),
            "final_xy_error": _r(np.hypot(*e[-1, :2])),
            "final_nees": _r(nees(e[-1], tr.P[-1])),
            "mean_nees": _r(np.mean(grid_nees)),
            "map_rmse": _r(rmse), "map_nees": _r(mnees)}
    if curve:
        out["nees"] = _r(grid_nees)
    return out


def run_seed(case: str, seed: int) -> dict:
    """The five estimates' figures for one seed of one case (see the module docstring)."""
    if case not in CASES:
        raise ValueError(f"case: expected one of {sorted(CASES)}, got {case!r}")
    run = scenario(SCENARIO, seed=int(seed), sigma_wheel=CASES[case])
    world = run.world()
    ekf = runner.slam(run)
    ungated = runner.slam(run, gate=None)
    b = graph.smooth(run, "batch")
    i = graph.smooth(run, "isam2")
    online = runner.Trace(t=i.t, kind=i.kind, x=i.online_x, P=i.online_P, truth=i.truth)
    out = {"seed": int(seed),
           "ekf": _figures(ekf, ekf.filter.landmarks, ekf.filter.landmark_cov, world),
           "ekf_ungated": _figures(ungated, ungated.filter.landmarks,
                                   ungated.filter.landmark_cov, world),
           "isam2_online": _figures(online, i.landmarks, i.landmark_cov, world),
           "batch": _figures(b, b.landmarks, b.landmark_cov, world),
           "isam2": _figures(i, i.landmarks, i.landmark_cov, world, curve=False)}
    out["ekf"]["rejected"] = int(ekf.counts().get("rejected", 0))
    return out


def _job(args):
    return run_seed(*args)


def study(seeds=SEEDS, cases=tuple(CASES), workers: int = 2) -> dict:
    """Every case and seed, in a fixed order (the result does not depend on ``workers``)."""
    jobs = [(c, int(s)) for c in cases for s in seeds]
    rows = map_jobs(_job, jobs, max(int(workers), 1))
    out = {"format": FORMAT, "scenario": SCENARIO, "seeds": [int(s) for s in seeds],
           "grid": _r(GRID), "cases": {}}
    for c in cases:
        out["cases"][c] = {"sigma_wheel": CASES[c],
                           "runs": [r for (cc, _), r in zip(jobs, rows) if cc == c]}
    return out


def save(data: dict, path=STUDY_FILE) -> None:
    """Write the study as JSON (one run per line, so that a diff shows which changed)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = ["{", f'"format": {json.dumps(data["format"])},',
             f'"scenario": {json.dumps(data["scenario"])},',
             f'"seeds": {json.dumps(data["seeds"])},', f'"grid": {json.dumps(data["grid"])},',
             '"cases": {']
    cases = list(data["cases"].items())
    for k, (c, d) in enumerate(cases):
        lines.append(f'{json.dumps(c)}: {{"sigma_wheel": {json.dumps(d["sigma_wheel"])}, '
                     '"runs": [')
        runs = d["runs"]
        for j, r in enumerate(runs):
            lines.append(json.dumps(r, separators=(",", ":")) + ("," if j < len(runs) - 1 else ""))
        lines.append("]}" + ("," if k < len(cases) - 1 else ""))
    lines += ["}", "}"]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


#: How one figure spreads over the seeds (:func:`spread`).
Spread = SeedSpread


def spread(values, seeds, n_top: int = 3, prob: float = 0.95, n_boot: int = 4000,
           seed: int = 0) -> SeedSpread:
    """The :class:`~slamlib.metrics.SeedSpread` of ``values`` (one per seed of ``seeds``), with
    scipy's BCa bootstrap interval (which, like any bootstrap interval, under-covers on the
    upper side where one run carries the mean; :func:`slamlib.metrics.mean_interval`)."""
    return seed_spread(values, seeds, n_top=n_top, level=prob, n_boot=n_boot, seed=seed,
                       method="BCa")


class Study:
    """The stored study, with the tables and curves chapter 11 shows."""

    def __init__(self, data: dict):
        if data.get("format") != FORMAT:
            raise ValueError(f"data: expected format {FORMAT!r}, got {data.get('format')!r}")
        self.data = data
        self.grid = np.array(data["grid"])
        self.seeds = tuple(data["seeds"])

    @property
    def cases(self) -> list[str]:
        return list(self.data["cases"])

    def runs(self, case: str) -> list[dict]:
        return self.data["cases"][case]["runs"]

    def sigma_wheel(self, case: str) -> float:
        return float(self.data["cases"][case]["sigma_wheel"])

    def values(self, case: str, estimate: str, name: str) -> np.ndarray:
        """One figure of one estimate over the seeds, shape (N,) (or (N, T) for ``nees``)."""
        return np.array([r[estimate][name] for r in self.runs(case)], dtype=float)

    def spread(self, case: str, estimate: str, name: str = "mean_nees",
               minus: str | None = None) -> Spread:
        """The :class:`Spread` of one figure over the seeds; ``minus``: of its difference,
        seed by seed, with the same figure of that estimate (a paired comparison)."""
        v = self.values(case, estimate, name)
        if minus is not None:
            v = v - self.values(case, minus, name)
        return spread(v, self.seeds)

    def average_nees(self, case: str, estimate: str) -> np.ndarray:
        """The Monte-Carlo average pose NEES at each grid time (shape (T,))."""
        return np.mean(self.values(case, estimate, "nees"), axis=0)

    def band(self, dof: int = 3, prob: float = 0.95) -> tuple[float, float]:
        """Two-sided band of a consistent estimator's N-run average NEES."""
        return chi2_band(dof, len(self.seeds), prob)

    def table(self, case: str, estimates=ESTIMATES) -> str:
        """Medians over the seeds, and the share of grid times inside the NEES band."""
        lo, hi = self.band()
        head = (f"{'estimate':<14}{'ATE (m)':>9}{'final (m)':>11}{'map (m)':>9}"
                f"{'pose NEES':>11}{'map NEES':>10}{'in band':>9}")
        lines = [head]
        for e in estimates:
            if "nees" not in self.runs(case)[0][e]:
                continue
            avg = self.average_nees(case, e)
            inside = float(np.mean((avg >= lo) & (avg <= hi)))
            lines.append(f"{e:<14}{np.median(self.values(case, e, 'ate_xy')):>9.3f}"
                         f"{np.median(self.values(case, e, 'final_xy_error')):>11.3f}"
                         f"{np.median(self.values(case, e, 'map_rmse')):>9.3f}"
                         f"{np.mean(avg):>11.2f}"
                         f"{np.mean(self.values(case, e, 'map_nees')):>10.2f}"
                         f"{100 * inside:>8.0f}%")
        return "\n".join(lines)


def load(path=STUDY_FILE) -> Study:
    """The stored study (``make graph-study`` writes it)."""
    return Study(load_stored(path, "graph-study"))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(STUDY_FILE))
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--seeds", type=int, default=len(SEEDS), help="first N seeds only")
    a = p.parse_args(argv)
    data = study(SEEDS[: a.seeds], workers=a.workers)
    save(data, a.out)
    s = Study(data)
    for c in s.cases:
        print(f"{c} (sigma_wheel {s.sigma_wheel(c)} m/s), {len(s.seeds)} seeds:")
        print(s.table(c))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
