"""The 100-run studies behind chapters 07 and 08 (``make chapter-studies``).

A claim about accuracy or consistency rests on at least 100 seeded runs, and a
causal claim on an ablation that changes one thing on the same seeds. Each
function here computes one seed of one study and returns a small JSON-ready
dict; :func:`run_study` runs it over the study's seeds (in a process pool
whose answer does not depend on the number of workers) and the files go to
``data/evidence/<name>.json`` in the format of :mod:`slamlib.course.evidence`
(:func:`~slamlib.course.evidence.save_study`,
:func:`~slamlib.course.evidence.load_study`). ``tests/test_studies_ch07_08.py``
recomputes a sample of seeds and compares them (decisions exactly, floats to 1e-6
relative: ``tests/same_record.py``).

Stored (:data:`STUDIES`):

- ``explore_fej`` (chapter 07, section 4): the chapter's world 5 explored
  with simulation seeds 1-100 (seed 5 is the chapter's run), 180 s, return
  rule 0.1 m. The EKF SLAM estimate that steered (``closed``), and the
  recorded run replayed through EKF SLAM (``ekf``) and through First-Estimates
  Jacobians EKF SLAM (``fej``): the replays see the same readings and
  controls, so ``ekf`` against ``fej`` changes the filter's Jacobians alone.

Written but not stored yet (not in :data:`STUDIES`): one seed takes about 34 s
(:func:`explore_rule_seed`) and 77 s (:func:`delay_seed`) on one busy core, so a
hundred of each did not fit the session that wrote them, and the chapters word
what would rest on them as examples of one run:

- :func:`explore_rule_seed` (chapter 07, section 5): random world ``seed``
  (:func:`slamlib.explore.exploration_world`, the simulation seed equal to the
  world's; worlds 0-4 are the chapter's examples) explored for 120 s twice,
  with the return rule (``sigma_return`` 0.1 m) and without it: the rule is the
  only difference within a pair.
- :func:`delay_seed` (chapter 08): the arena loop re-simulated with ``seed``
  (seed 1 is the recorded run) and camera latencies 0.1, 0.2, 0.3 and 0.5 s;
  EKF SLAM and the map-based EKF fed at the capture times (no delay), and on
  arrival naive, fixed (re-prediction, the estimate in real time) and
  compensated (readings moved by odometry); the naive SLAM also without the
  gate (the gate alone removed).

Everything is seeded; the same code gives the same numbers bit for bit.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from ..metrics import nees as _nees
from ..studies import map_jobs, sample_trace
from .evidence import FORMAT, load_study

__all__ = ["STUDIES", "STUDY_SEEDS", "RULE_THRESHOLD", "RULE_DURATION", "FEJ_DURATION",
           "FEJ_GRID", "LATENCIES", "TURN_BINS", "DELAY_METHODS", "position_nees",
           "explore_rule_seed", "explore_fej_seed", "delay_seed", "run_study", "load",
           "main"]

#: The chapter-07 return threshold (m) of both exploration studies.
RULE_THRESHOLD = 0.1
#: Length (s) of each exploration of ``explore_rule``...
RULE_DURATION = 120.0
#: ...and of ``explore_fej``.
FEJ_DURATION = 180.0
#: Spacing (s) of the NEES series stored by ``explore_fej``.
FEJ_GRID = 1.0
#: The camera latencies (s) of ``delay_latency``.
LATENCIES = (0.1, 0.2, 0.3, 0.5)
#: Edges (rad/s) of the bins of the true turn rate at capture in which ``delay_latency``
#: counts the gated and the rejected readings.
TURN_BINS = (0.0, 0.1, 0.3, 0.5, math.inf)
#: The ways of handling a late frame in ``delay_latency`` (see :data:`slamlib.delay.METHODS`).
DELAY_METHODS = ("naive", "fixed", "compensated")


def _g(v: float, digits: int = 6) -> float:
    return float(f"{float(v):.{digits}g}")


def position_nees(error, P) -> np.ndarray:
    """The position-only NEES ``e_xy^T P_xy^-1 e_xy`` (2 degrees of freedom) of pose errors
    ``error`` (..., 3) and covariances ``P`` (..., 3, 3)."""
    e = np.asarray(error, dtype=float)
    P = np.asarray(P, dtype=float)
    return np.asarray(_nees(e[..., :2], P[..., :2, :2]))


# --------------------------------------------------------------------------- chapter 07
def _trace_sums(trace) -> dict:
    """Sums over every event after the start: pose, position and heading NEES, and the
    largest ``|e_theta| / sigma_theta`` and ``|e_xy| / sigma_xy`` of the run."""
    e, P = trace.error[1:], trace.P[1:]
    sx = np.sqrt(P[:, 0, 0] + P[:, 1, 1])
    return {"n": int(e.shape[0]), "nees_sum": float(np.sum(_nees(e, P))),
            "nees_pos_sum": float(np.sum(position_nees(e, P))),
            "nees_heading_sum": float(np.sum(e[:, 2] ** 2 / P[:, 2, 2])),
            "max_heading_ratio": float(np.max(np.abs(e[:, 2]) / np.sqrt(P[:, 2, 2]))),
            "max_xy_ratio": float(np.max(np.hypot(e[:, 0], e[:, 1]) / sx))}


def _frame_counts(err_xy, sigma_xy, threshold: float) -> dict:
    """Per camera frame: how often the true position error is beyond ``sigma_xy``, beyond
    ``threshold``, and beyond ``threshold`` while ``sigma_xy`` is not (the rule sees nothing)."""
    err_xy, sigma_xy = np.asarray(err_xy), np.asarray(sigma_xy)
    return {"frames": int(err_xy.size), "over_sigma": int(np.sum(err_xy > sigma_xy)),
            "error_over": int(np.sum(err_xy > threshold)),
            "sigma_over": int(np.sum(sigma_xy > threshold)),
            "missed": int(np.sum((err_xy > threshold) & (sigma_xy <= threshold)))}


def explore_rule_seed(seed: int) -> dict:
    """World ``seed`` explored for :data:`RULE_DURATION` s with the return rule
    (``rule``, ``sigma_return`` = :data:`RULE_THRESHOLD`) and without it (``none``).

    Per run: :meth:`slamlib.explore.Exploration.metrics` with the world, the largest
    ``sigma_xy``, :func:`_trace_sums`, and the per-frame counts of :func:`_frame_counts`
    against :data:`RULE_THRESHOLD` (for ``none`` too: what the rule would have seen).
    """
    from ..explore import Explorer, exploration_world, explore

    world = exploration_world(seed=int(seed))
    out = {}
    for name, rule in (("rule", RULE_THRESHOLD), ("none", None)):
        e = explore(world, seed=int(seed), duration=RULE_DURATION,
                    explorer=Explorer(sigma_return=rule))
        h = e.history()
        out[name] = {**e.metrics(world), "max_sigma": float(np.max(h["sigma_xy"])),
                     **_trace_sums(e.trace),
                     **_frame_counts(h["error_xy"], h["sigma_xy"], RULE_THRESHOLD)}
    return out


def _grid_series(trace, step: float, duration: float) -> dict:
    t = np.arange(1, int(np.floor(min(duration, trace.t[-1]) / step + 1e-9)) + 1) * step
    pose, heading = sample_trace(trace, t)
    k = np.searchsorted(trace.t, t + 1e-9, side="right") - 1
    pos = position_nees(trace.error[k], trace.P[k])
    return {"grid_nees": [_g(v, 5) for v in pose], "grid_nees_pos": [_g(v, 5) for v in pos],
            "grid_nees_heading": [_g(v, 5) for v in heading]}


def explore_fej_seed(seed: int) -> dict:
    """World 5 explored with simulation ``seed`` (:data:`FEJ_DURATION` s, return rule
    :data:`RULE_THRESHOLD`): the estimate that steered (``closed``) and the recorded run
    replayed through EKF SLAM (``ekf``) and FEJ EKF SLAM (``fej``).

    Per filter: :func:`_trace_sums`, the per-frame counts of :func:`_frame_counts` at the
    camera frames, and (``closed`` and ``fej``) the pose, position and heading NEES on the
    grid :data:`FEJ_GRID`, 2 :data:`FEJ_GRID`, ... (five significant digits).
    """
    from .. import runner
    from ..explore import Explorer, exploration_world, explore

    e = explore(exploration_world(seed=5), seed=int(seed), duration=FEJ_DURATION,
                explorer=Explorer(sigma_return=RULE_THRESHOLD))
    frames = np.asarray(e.history()["t"])
    out = {}
    for name, tr in (("closed", e.trace), ("ekf", runner.slam(e.run)),
                     ("fej", runner.fej_slam(e.run))):
        k = np.searchsorted(tr.t, frames, side="right") - 1
        err = np.hypot(tr.error[k, 0], tr.error[k, 1])
        sig = np.sqrt(tr.P[k, 0, 0] + tr.P[k, 1, 1])
        out[name] = {**_trace_sums(tr), **_frame_counts(err, sig, RULE_THRESHOLD)}
        if name != "ekf":
            out[name].update(_grid_series(tr, FEJ_GRID, FEJ_DURATION))
    return out


# --------------------------------------------------------------------------- chapter 08
def _turn_rate(run, t_capture) -> np.ndarray:
    """The true turn rate (rad/s) over the 0.1 s after each capture time."""
    t = np.asarray(t_capture, dtype=float)
    a, b = run.truth_at(t), run.truth_at(t + 0.1)
    d = (b[:, 2] - a[:, 2] + np.pi) % (2 * np.pi) - np.pi
    return d / 0.1


def _delay_stats(trace, run, latency: float, world) -> dict:
    """A trace's metrics, and its gated and rejected readings per bin of :data:`TURN_BINS`
    of the true turn rate at their capture (``latency`` before the report's time)."""
    m = trace.metrics(world)
    out = {k: m[k] for k in ("ate_xy", "ate_theta", "mean_nees", "final_xy_error")}
    if "map_rmse" in m:
        out["map_rmse"] = m["map_rmse"]
    gated = np.zeros(len(TURN_BINS) - 1, dtype=np.int64)
    rejected = np.zeros_like(gated)
    if trace.reports:
        tc = np.array([t for t, _ in trace.reports]) - latency
        w = np.abs(_turn_rate(run, tc))
        b = np.searchsorted(TURN_BINS, w, side="right") - 1
        for (_, rep), k in zip(trace.reports, b):
            st = np.asarray(rep.status)
            gated[k] += int(np.sum((st == "accepted") | (st == "rejected")))
            rejected[k] += int(np.sum(st == "rejected"))
    out["gated"] = [int(v) for v in gated]
    out["rejected"] = [int(v) for v in rejected]
    return out


def delay_seed(seed: int, latencies=LATENCIES) -> dict:
    """The arena loop with ``seed``: ``none/<kind>`` (fed at capture: no delay) and, for each
    of ``latencies``, ``<latency>/<kind>/<method>`` for the methods of
    :data:`DELAY_METHODS` (``fixed``: the real-time estimate of re-prediction) and
    ``<latency>/slam/naive_nogate``; ``kind`` is ``slam`` or ``localization``.
    Each entry: :func:`_delay_stats`. (A subset of the latencies gives the same entries
    as all of them.)"""
    from .. import delay, runner

    out = {}
    for lat in latencies:
        run = delay.delayed_run(lat, seed=int(seed))
        world = run.world()
        if not out:
            for kind in ("slam", "localization"):
                tr = runner.run_filter(run, delay.make_filter(run, kind), by="capture")
                out[f"none/{kind}"] = _delay_stats(tr, run, 0.0, world)
        for kind in ("slam", "localization"):
            for m in DELAY_METHODS:
                tr = delay.run_method(run, m, kind)
                out[f"{lat:g}/{kind}/{m}"] = _delay_stats(tr, run, lat, world)
        tr = runner.run_filter(run, delay.make_filter(run, "slam", gate=None), by="arrival")
        out[f"{lat:g}/slam/naive_nogate"] = _delay_stats(tr, run, lat, world)
    return out


# --------------------------------------------------------------------------- studies and files
#: name -> the function of one seed (the stored studies; see the module's docstring for
#: :func:`explore_rule_seed` and :func:`delay_seed`, not stored yet).
STUDIES = {"explore_fej": explore_fej_seed}
#: The seeds of each study.
STUDY_SEEDS = {"explore_fej": tuple(range(1, 101))}


def _one(job):
    name, seed = job
    return STUDIES[name](seed)


def run_study(name: str, seeds=None, workers: int = 1) -> dict:
    """Study ``name`` of :data:`STUDIES` over ``seeds`` (default :data:`STUDY_SEEDS`), in
    ``workers`` processes (the same numbers for any number), as stored by
    :func:`slamlib.course.evidence.save_study`."""
    if name not in STUDIES:
        raise ValueError(f"name: expected one of {sorted(STUDIES)}, got {name!r}")
    seeds = [int(s) for s in (STUDY_SEEDS[name] if seeds is None else seeds)]
    runs = map_jobs(_one, [(name, s) for s in seeds], max(int(workers), 1))
    return {"format": FORMAT, "study": name, "seeds": seeds, "runs": runs}


def load(name: str) -> dict:
    """The stored study ``name`` (``data/evidence/<name>.json``)."""
    if name not in STUDIES:
        raise ValueError(f"name: expected one of {sorted(STUDIES)}, got {name!r}")
    return load_study(name)


def main(argv=None) -> int:
    """``python -m slamlib.course.studies_ch07_08 [names] [--workers N] [--check]``."""
    from .evidence import main as command_line

    return command_line(argv, STUDIES, run_study, __doc__.splitlines()[0])


if __name__ == "__main__":
    sys.exit(main())
