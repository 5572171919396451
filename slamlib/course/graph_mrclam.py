"""Chapter 11, section 6: the EKF beside batch and incremental smoothing on the MRCLAM robots.

For each robot of the UTIAS MRCLAM excerpt (chapter 10), the log is loaded with
the noise chapter 10 identified from the OTHER four robots (leave one out:
``cal = identify.identify(others)``, ``mrclam.load(folder, robot, calibration=cal)``:
the components chapter 10's held-out test kept, ``identify.KEPT``: R(rho) with its
outlier model and the noise density Q, the commands as logged), and the same log
goes through:

- ``ekf``: :func:`slamlib.datasets.mrclam.slam` (gate 0.95, chapter 10's pipeline; filtered);
- ``ekf_ungated``: the same without the gate (every reading fused, as in the graph);
- ``isam2_online``: :func:`slamlib.graph.smooth` ``(method="isam2")``, each pose's
  estimate right after its own update (filtered: the readings up to then);
- ``isam2``: iSAM2's final estimate (smoothed; it should equal ``batch``);
- ``batch``: ``smooth(method="batch")`` (smoothed: every pose from ALL the readings);
- ``huber``, ``cauchy``: the batch smoother with that robust kernel on the readings
  (threshold :data:`ROBUST_K` on the reading's Mahalanobis distance, 2 degrees of freedom).

Every estimate is judged against Vicon at the SAME times: the graph's pose
nodes (the start, every camera frame with landmark readings, the end); the
EKF's estimate at such a time is the one after its update there. The graph also gets a
pose after every :data:`MAX_STEPS` filter steps without a frame (about 1 s), so the
long blind stretches count as well. These times are not chapter 10's (every filter
step), so the EKF's ATE here differs from chapter 10's table. Per estimate:
the position ATE, the final position error, the mean pose NEES over those times,
the map's RMS error against Vicon's landmarks. Per smoothed estimate also: how
many readings end with a Mahalanobis distance above ``ROBUST_K`` from the solution (the
ones a Huber kernel down-weights) and how many of those chapter 10 flagged as
outliers against Vicon. Per estimate also a profile every :data:`PROFILE_STEP` s (NEES,
heading error and its sigma), and for the EKFs the readings they fused beyond
the 0.95 gate's bound (the ungated one fuses every reading). Per robot,
:func:`solver_check`: whether the batch solution is the optimum of its graph
(Levenberg-Marquardt restarted from Vicon) and what the graph's cost is at Vicon's
trajectory, odometry and readings apart.

These are ONE run per robot (real data): no Monte-Carlo band applies.

The five robots take longer than chapter 11 may spend, so ``make graph-mrclam``
(``python -m slamlib.course.graph_mrclam``) stores the numbers in
``data/studies/graph_mrclam.json`` (6 significant digits, no timings: bit for bit
the same on every regeneration); ``tests/test_graph_mrclam.py`` recomputes a robot
and compares.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import gtsam
import numpy as np

from .. import graph, runner
from ..datasets import identify, mrclam
from ..metrics import chi2_quantile, nees, pose_error
from ..models import observe, wrap_angle
from ..worlds import DATA_DIR
from .stored import load_stored, save_rows

__all__ = ["ESTIMATES", "FILTERED", "MAX_STEPS", "ROBUST_K", "PROFILE_STEP", "STUDY_FILE", "FORMAT",
           "robot_traces", "node_samples", "whitened_residuals", "figures", "solver_check",
           "run_robot", "study", "save", "load", "Study", "main"]

FORMAT = "slamlib-graph-mrclam/1"
STUDY_FILE = DATA_DIR / "studies" / "graph_mrclam.json"
#: The estimates, in table order.
ESTIMATES = ("ekf", "ekf_ungated", "isam2_online", "isam2", "batch", "huber", "cauchy")
#: Which of them are filtered (the rest are smoothed).
FILTERED = ("ekf", "ekf_ungated", "isam2_online")
#: A pose node also after this many filter steps without a camera frame (about 1 s on
#: these logs), so that the blind stretches are judged too.
MAX_STEPS = 100
#: The robust kernels' threshold on a reading's Mahalanobis distance: the library's
#: :data:`slamlib.graph.ROBUST_K`, ``sqrt(chi2_2^-1(0.95)) = 2.448`` (Huber's 1.345 is a
#: constant for a 1-D residual; for the norm of a 2-D one ``P(d > 1.345) = 0.40``).
ROBUST_K = graph.ROBUST_K
#: The profile of each estimate is sampled every this many seconds from the log's start.
PROFILE_STEP = 10.0
_DIGITS = 6


def _r(v) -> float:
    return float(f"{float(v):.{_DIGITS}g}")


def _raw_logs(folder) -> dict:
    with warnings.catch_warnings():           # robot 4's misread barcodes: dropped, counted
        warnings.simplefilter("ignore", mrclam.MRCLAMWarning)
        return {r: mrclam.load(folder, r) for r in mrclam.ROBOTS}


def robot_traces(robot: int, folder=mrclam.EXCERPT_DIR, raw: dict | None = None,
                 estimates=ESTIMATES) -> tuple[dict, mrclam.Log]:
    """Every estimate of one robot (see the module docstring) and its identified log.

    ``raw``: the five robots' logs as loaded (misreads dropped), to identify the
    noise from; read from ``folder`` if not given.
    """
    if robot not in mrclam.ROBOTS:
        raise ValueError(f"robot: expected one of {mrclam.ROBOTS}, got {robot!r}")
    unknown = set(estimates) - set(ESTIMATES)
    if unknown:
        raise ValueError(f"estimates: expected names from {ESTIMATES}, got {sorted(unknown)}")
    raw = _raw_logs(folder) if raw is None else raw
    cal = identify.identify(raw[k] for k in mrclam.ROBOTS if k != robot)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrclam.MRCLAMWarning)
        log = mrclam.load(folder, robot, calibration=cal)
    out: dict = {}
    if "ekf" in estimates:
        out["ekf"] = mrclam.slam(log)
    if "ekf_ungated" in estimates:
        out["ekf_ungated"] = mrclam.slam(log, gate=None)
    if {"isam2", "isam2_online"} & set(estimates):
        i = graph.smooth(log, "isam2", max_steps=MAX_STEPS)
        out["isam2"] = i
        out["isam2_online"] = runner.Trace(t=i.t, kind=i.kind, x=i.online_x, P=i.online_P,
                                           truth=i.truth, filter=i.filter)
    if "batch" in estimates:
        out["batch"] = graph.smooth(log, "batch", max_steps=MAX_STEPS)
    for k in ("huber", "cauchy"):
        if k in estimates:
            out[k] = graph.smooth(log, "batch", max_steps=MAX_STEPS, robust=k,
                                  robust_k=ROBUST_K)
    return {k: out[k] for k in estimates}, log


def node_samples(trace: runner.Trace, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The estimate, its covariance and the truth at the times ``t``.

    The state after the last event at or before each time (for a filter at a
    camera frame: after its update there).
    """
    t = np.asarray(t, dtype=float)
    k = np.searchsorted(trace.t, t + 1e-9, side="right") - 1
    if np.any(k < 0):
        raise ValueError("t: expected times at or after the trace's start")
    return trace.x[k], trace.P[k], trace.truth[k]


def whitened_residuals(trace: graph.GraphTrace) -> np.ndarray:
    """Each reading's Mahalanobis distance from the smoother's solution, in the log's order.

    ``d = sqrt(e^T R^-1 e)`` with ``e = z - h(x_i, l_j)`` (bearing wrapped), from the
    solved poses and landmarks (z-down) and the reading's own R.
    """
    p = trace.problem
    lm = trace.landmarks
    out = []
    for i, (ids, z, R) in enumerate(p.readings):
        for j in range(ids.shape[0]):
            e = z[j] - observe(trace.x[i], lm[int(ids[j])])
            e[1] = wrap_angle(e[1])
            out.append(float(np.sqrt(e @ np.linalg.solve(R[j], e))))
    return np.array(out)


def figures(traces: dict, log: mrclam.Log, outliers: np.ndarray | None = None) -> dict:
    """ATE, final error, mean NEES and map error of each estimate, at the graph's pose times.

    ``outliers``: chapter 10's flags (one per reading of ``log``, against Vicon),
    to count how many of the readings a kernel would down-weight were outliers.
    """
    ref = next((tr for tr in traces.values() if isinstance(tr, graph.GraphTrace)), None)
    if ref is None:
        raise ValueError("traces: expected at least one smoother's trace (its pose times)")
    t = ref.t
    world = log.world()
    out: dict = {"poses": int(t.size), "readings": int(len(log.camera))}
    for name, tr in traces.items():
        x, P, truth = node_samples(tr, t)
        e = pose_error(x, truth)
        row = {"ate_xy": _r(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2))),
               "final_xy_error": _r(np.hypot(*e[-1, :2])),
               "mean_nees": _r(np.mean(nees(e, P))),
               "map_rmse": _r(runner.map_error(tr.filter, world)[0])}
        row["profile"] = _profile(tr, t)
        if tr.reports:
            row["fused_beyond_gate"] = _fused_beyond_gate(tr, t[0])
        if isinstance(tr, graph.GraphTrace):
            d = whitened_residuals(tr)
            far = d > ROBUST_K
            row["beyond_k"] = int(far.sum())
            if outliers is not None:
                if outliers.shape != d.shape:
                    raise ValueError(f"outliers: expected {d.size} flags, got {outliers.size}")
                row["beyond_k_outliers"] = int(np.sum(far & outliers))
            row["max_residual"] = _r(d.max()) if d.size else 0.0
        if name == "ekf":
            row["rejected"] = int(tr.counts().get("rejected", 0))
        out[name] = row
    if outliers is not None:
        out["outliers"] = int(np.sum(outliers))
    return out


def _profile(trace: runner.Trace, t: np.ndarray) -> dict:
    """NEES, heading error and heading sigma (degrees) every PROFILE_STEP s from t[0]."""
    at = t[0] + np.arange(0.0, t[-1] - t[0] + 1e-9, PROFILE_STEP)
    x, P, truth = node_samples(trace, at)
    e = pose_error(x, truth)
    return {"t": [_r(a - t[0]) for a in at], "nees": [_r(v) for v in nees(e, P)],
            "heading_error_deg": [_r(v) for v in np.degrees(e[:, 2])],
            "heading_sigma_deg": [_r(v) for v in np.degrees(np.sqrt(P[:, 2, 2]))]}


def _fused_beyond_gate(trace: runner.Trace, t0: float, first: int = 5) -> dict:
    """The readings a filter fused (accepted, not new) beyond the 0.95 gate's chi2_2 bound:
    how many, and the first ``first`` of them as ``[t (s from t0), landmark, d2]``."""
    bound = float(chi2_quantile(0.95, 2))
    hits = []
    for t, rep in trace.reports:
        ok = np.asarray(rep.accepted, dtype=bool) & ~np.asarray(rep.new, dtype=bool)
        d2 = np.asarray(rep.d2, dtype=float)
        for j in np.flatnonzero(ok & (d2 > bound)):
            hits.append([_r(t - t0), int(rep.matched[j]), _r(d2[j])])
    return {"count": len(hits), "first": hits[:first]}


def _cost_split(g: gtsam.NonlinearFactorGraph, values: gtsam.Values
                ) -> tuple[float, float, float]:
    """The graph's cost (1/2 the sum of squared whitened errors) of its odometry factors
    and of its readings, and the median cost of one odometry factor."""
    odo, rb = [], 0.0
    for k in range(g.size()):
        f = g.at(k)
        if isinstance(f, gtsam.BetweenFactorPose2):
            odo.append(f.error(values))
        elif isinstance(f, gtsam.BearingRangeFactor2D):
            rb += f.error(values)
    return float(np.sum(odo)), rb, float(np.median(odo)) if odo else 0.0


def solver_check(batch: graph.GraphTrace, log: mrclam.Log,
                 online: runner.Trace | None = None) -> dict:
    """Is the batch solution the optimum of its graph, and how does Vicon's trajectory fit it?

    Levenberg-Marquardt is restarted from Vicon (every pose; the landmarks at Vicon's
    positions) on the same graph, with GTSAM's defaults but up to 200 iterations and
    tight tolerances (1e-10 relative, 1e-12 absolute). Returns the batch solution's
    iterations and cost, the restarted solution's cost and its largest position distance
    to the batch solution (m), and the cost of the odometry factors and of the readings at
    the batch solution and at Vicon (and the median of one odometry factor's there:
    about 1.2, the median of chi2_3 / 2, for factors whose covariance is right).
    ``online`` (iSAM2's filtered trace): also the share of pose times at which it is
    nearer Vicon than the batch solution.
    """
    g = batch.graph
    v = gtsam.Values()
    for i in range(batch.problem.n_poses):
        v.insert(graph.pose_key(i), graph.pose_to_gtsam(batch.truth[i]))
    true = log.world().landmarks()
    for m, p in zip(batch.landmark_ids, batch.landmark_x):
        v.insert(graph.landmark_key(m), graph.point_to_gtsam(true.get(int(m), p)))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(200)
    params.setRelativeErrorTol(1e-10)
    params.setAbsoluteErrorTol(1e-12)
    opt = gtsam.LevenbergMarquardtOptimizer(g, v, params)
    sol = opt.optimize()
    x = np.array([graph.pose_from_gtsam(sol.atPose2(graph.pose_key(i)))
                  for i in range(batch.problem.n_poses)])
    odo, rb, _ = _cost_split(g, batch.values)
    odo_v, rb_v, med_v = _cost_split(g, v)
    out = {"lm_iterations": int(batch.iterations), "cost": _r(g.error(batch.values)),
           "cost_from_vicon": _r(g.error(sol)),
           "shift_from_vicon": _r(np.max(np.hypot(*(x - batch.x)[:, :2].T))),
           "cost_odometry": _r(odo), "cost_readings": _r(rb),
           "vicon_cost_odometry": _r(odo_v), "vicon_cost_readings": _r(rb_v),
           "vicon_median_odometry": _r(med_v)}
    if online is not None:
        xo, _, truth = node_samples(online, batch.t)
        eo = np.hypot(*pose_error(xo, truth)[:, :2].T)
        eb = np.hypot(*pose_error(batch.x, batch.truth)[:, :2].T)
        out["online_closer_share"] = _r(np.mean(eo < eb))
    return out


def run_robot(robot: int, folder=mrclam.EXCERPT_DIR, raw: dict | None = None) -> dict:
    """The stored figures of one robot (see the module docstring)."""
    raw = _raw_logs(folder) if raw is None else raw
    traces, log = robot_traces(robot, folder, raw)
    # chapter 10's outlier rule applied to this robot's readings alone (the per-robot set)
    flags = identify.fit_reading_noise(identify.reading_residuals(raw[robot])).outlier
    return {"robot": int(robot), **figures(traces, log, np.asarray(flags, dtype=bool)),
            "solver": solver_check(traces["batch"], log, traces["isam2_online"])}


def study(folder=mrclam.EXCERPT_DIR) -> dict:
    """Every robot, in order."""
    raw = _raw_logs(folder)
    return {"format": FORMAT, "folder": Path(folder).name, "robust_k": ROBUST_K,
            "max_steps": MAX_STEPS,
            "robots": [run_robot(r, folder, raw) for r in mrclam.ROBOTS]}


def save(data: dict, path=STUDY_FILE) -> None:
    """Write the study as JSON, one robot per line."""
    save_rows(data, "robots", path)


class Study:
    """The stored MRCLAM comparison, with the tables chapter 11 prints."""

    def __init__(self, data: dict):
        if data.get("format") != FORMAT:
            raise ValueError(f"data: expected format {FORMAT!r}, got {data.get('format')!r}")
        self.data = data

    @property
    def robots(self) -> list[int]:
        return [int(r["robot"]) for r in self.data["robots"]]

    def row(self, robot: int) -> dict:
        for r in self.data["robots"]:
            if int(r["robot"]) == int(robot):
                return r
        raise ValueError(f"robot: expected one of {self.robots}, got {robot!r}")

    def values(self, estimate: str, name: str) -> np.ndarray:
        """One figure of one estimate, robot by robot."""
        return np.array([r[estimate][name] for r in self.data["robots"]], dtype=float)

    def table(self, name: str, estimates=ESTIMATES, fmt: str = "7.2f") -> str:
        """``name`` of each estimate (columns) robot by robot (rows), and the median."""
        w = max(int(fmt.split(".")[0]), 6)
        head = "robot " + "".join(f"{e:>{max(w, len(e)) + 1}s}" for e in estimates)
        lines = [head]
        for r in self.data["robots"]:
            lines.append(f"{r['robot']:5d} " + "".join(
                f" {r[e][name]:{max(w, len(e))}{fmt[fmt.index('.'):]}}" for e in estimates))
        lines.append("median" + "".join(
            f" {np.median(self.values(e, name)):{max(w, len(e))}{fmt[fmt.index('.'):]}}"
            for e in estimates))
        return "\n".join(lines)


def load(path=STUDY_FILE) -> Study:
    """The stored comparison (``make graph-mrclam`` writes it)."""
    return Study(load_stored(path, "graph-mrclam"))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(STUDY_FILE))
    a = p.parse_args(argv)
    data = study()
    save(data, a.out)
    s = Study(data)
    for name in ("ate_xy", "mean_nees"):
        print(name)
        print(s.table(name))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
