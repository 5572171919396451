"""The 100-seed studies behind the consistency lessons of chapters 02, 03, 05 and 07.

A lesson drawn from one run is an assertion: a run's errors at neighbouring
instants are strongly correlated, so one run is close to one sample. Each
function here runs one seeded re-simulation of the report's arena loop and
returns a small JSON-ready dict of numbers; :func:`run_study` runs it over
many seeds. The studies that do not fit in a chapter's Run All are stored in
``data/evidence/<name>.json`` by ``tools/make_evidence.py`` (``make
evidence``) and loaded by the chapters with :func:`load_study`;
``tests/test_evidence.py`` recomputes a sample of their seeds and compares
bit for bit.

Studies (:data:`STUDIES`):

- ``arena_localization``: the map-based EKF (chapter 03) on ``arena_loop``,
  seeds 1-100 (seed 1 is the recorded run): three gates (0.95, 0.999, none),
  the same on ``arena_loop_misreads``, and a filter that assumes 2x or 4x the
  camera's noise.
- ``arena_slam``: EKF SLAM (chapter 05) on ``arena_loop``, seeds 1-100, the
  pose and heading NEES on a 0.5 s grid.
- ``arena_slam_misreads``: EKF SLAM on ``arena_loop_misreads``, seeds 1-100:
  no gate, gate 0.95, gate with confirmed landmarks (ATE, map).
- ``explore_world5``: chapter 07's closed-loop exploration, simulation seeds
  1-100 (seed 5 is the chapter's run): the NEES and the largest heading error
  in units of its sigma.
- ``arena_sign_error``: the map-based EKF (chapter 03, section 6) with the
  library's ``H`` and with the report's printed ``H_pose`` (the sign error in
  ``[1, 1]``, :class:`BrokenReportHLocalization`) on ``arena_loop``, seeds
  1-100, started at the truth and started lost (a start error drawn from the
  filter's own :data:`LOST_P0`).
- ``arena_camera``: the map-based EKF fed by the rendered camera
  (:class:`slamlib.vision.CameraMarkerSensor`, chapters 02 and 03): the lagged
  correlation of the readings' errors and the NEES with the camera's R,
  inflated R and decimated frames.
- ``arena_noise``: dead reckoning (chapter 01's filter, chapter 03's comparison)
  and the map-based EKF whose R is wrong by a factor (chapter 03, section 7) on
  ``arena_loop``, seeds 1-100: :data:`NOISE_SETTINGS`.

Everything is seeded; the same code gives the same numbers bit for bit, in any
order of the seeds and in any number of processes.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..ekf import EKFLocalization
from ..metrics import nees as _nees
from ..metrics import pose_error
from ..runner import DEFAULT_P0, reading_covariances, run_filter
from ..runs import CameraRows, Run
from ..studies import sample_trace
from ..worlds import DATA_DIR
from .stored import load_stored

__all__ = ["EVIDENCE_DIR", "FORMAT", "STUDIES", "SEEDS", "GRID_STEP", "GATES",
           "CAMERA_VARIANTS", "CAMERA_LAGS", "ModelRLocalization", "decimate", "trace_stats",
           "gate_stats", "localization_seed", "slam_seed", "camera_run", "camera_seed",
           "error_correlation", "run_study", "save_study", "load_study", "column", "rank",
           "pooled_correlation", "nees_study", "explore_seed", "slam_misreads_seed",
           "BrokenReportHLocalization", "LOST_P0", "sign_error_seed", "NOISE_SETTINGS",
           "noise_seed"]

#: Where the stored studies live.
EVIDENCE_DIR = DATA_DIR / "evidence"
#: The files' format tag.
FORMAT = "slamlib-evidence/1"
#: The seeds of every stored study (seed 1 is the recorded ``arena_loop``).
SEEDS = tuple(range(1, 101))
#: Spacing (s) of the time grid of the NEES series (as in :func:`slamlib.studies.monte_carlo`).
GRID_STEP = 0.5
#: The gates of the gate study (None: no gate).
GATES = (0.95, 0.999, None)
#: The camera study's filter variants: (name, R inflation factor on the std, keep every k-th frame).
CAMERA_VARIANTS = (("R", 1.0, 1), ("R x1.5^2", 1.5, 1), ("R x2^2", 2.0, 1), ("R x3^2", 3.0, 1),
                   ("every 3rd frame", 1.0, 3), ("every 5th frame", 1.0, 5),
                   ("every 10th frame", 1.0, 10), ("R x1.5^2, every 3rd", 1.5, 3))
#: Lags (camera frames, 0.1 s each) of the error autocorrelation.
CAMERA_LAGS = tuple(range(1, 11))
#: The lost robot's prior (chapter 03, section 6): 0.5 m in x and y, 0.02 rad in heading.
LOST_P0 = np.diag([0.5 ** 2, 0.5 ** 2, 0.02 ** 2])
#: The noise study's settings (chapter 03, section 7): (real, assumed) multiples of the analytic
#: sensor's noise std; (1, 1), (1, 2) and (1, 4) are in ``arena_localization``.
NOISE_SETTINGS = ((1.0, 0.5), (1.0, 0.25), (3.0, 3.0), (3.0, 1.0))


def _key(gate) -> str:
    return "none" if gate is None else f"{gate:g}"


# --------------------------------------------------------------------------- filters and runs
class ModelRLocalization(EKFLocalization):
    """The library's map-based EKF, its readings' covariance scaled and, if asked, modelled.

    Each reading gets ``factor**2 * R_i``: ``R_i`` is what ``update`` is given
    (:func:`slamlib.runner.run_filter` hands it the run's sensor's
    ``R(range)``) or, when it is given none, ``noise.R(range)`` of the
    ``noise`` model (e.g. :data:`slamlib.vision.DEFAULT_NOISE_MODEL` for a
    run of the rendered camera, whose model a run does not record).
    ``factor > 1``: the filter assumes a noisier camera than ``R_i``.
    """

    def __init__(self, *args, factor: float = 1.0, noise=None, **kwargs):
        super().__init__(*args, **kwargs)
        self.factor = float(factor)
        self.noise = noise

    def update(self, ids, z, R=None):
        if R is None and self.noise is not None:
            R = reading_covariances(self.noise, np.asarray(z, dtype=float).reshape(-1, 2))
        if R is not None and self.factor != 1.0:
            R = self.factor ** 2 * np.asarray(R, dtype=float)
        return super().update(ids, z, R)


class BrokenReportHLocalization(EKFLocalization):
    """BROKEN ON PURPOSE, for demonstration only (chapter 03, section 6): the map-based EKF
    with the report's printed ``H_pose``, whose entry ``[1, 1]`` has the wrong sign. It
    overrides the one method that gives ``update`` its readings' predictions and
    Jacobians; everything else is the library's filter, which is not changed."""

    def reading_model(self, pose, positions):
        h, H_pose, H_landmark = super().reading_model(pose, positions)
        H_pose[:, 1, 1] = -H_pose[:, 1, 1]          # the report's +dx/q
        return h, H_pose, H_landmark


def decimate(run: Run, every: int, rate: float = 10.0) -> Run:
    """``run`` with only the camera frames captured at ``j / rate``, ``j % every == 0``."""
    if every == 1:
        return run
    keep = np.round(run.camera.t_capture * rate).astype(np.int64) % int(every) == 0
    c = run.camera
    cam = CameraRows(*(getattr(c, k)[keep] for k in ("t_capture", "t_arrival", "id", "rho",
                                                      "bearing", "true_id", "true_rho",
                                                      "true_bearing")))
    return replace(run, camera=cam)


def _filter(run: Run, *, gate=0.95, factor: float = 1.0, noise=None) -> ModelRLocalization:
    R0 = noise.R(2.0) if noise is not None else run.sensor().R(2.0)
    return ModelRLocalization(run.start_pose, DEFAULT_P0, run.Q(), R0, run.world().landmarks(),
                              wheel_base=run.wheel_base, gate=gate, factor=factor, noise=noise)


# --------------------------------------------------------------------------- per-run numbers
def _g(v: float) -> float:
    """Six significant digits: the stored precision of long series."""
    return float(f"{float(v):.6g}")


def trace_stats(trace, grid_step: float = GRID_STEP, series: bool = False) -> dict:
    """One run's consistency and accuracy numbers.

    Over every event after the start (as chapter 03 counts them): the number
    of events ``n``, the sums of the pose NEES and of the heading's
    ``e_theta^2 / P_theta_theta``, per component the sums of the squared error
    and of the variance (``rms error / rms sigma = sqrt(e2 / var)``) and the
    count inside 2 sigma; the ATE. On the grid ``grid_step, 2 grid_step, ...``
    (:func:`slamlib.studies.sample_trace`): the means of both NEES, and with
    ``series`` the series themselves (six significant digits).
    """
    e, P = trace.error[1:], trace.P[1:]
    var = np.diagonal(P, axis1=1, axis2=2)
    nees = np.asarray(_nees(e, P))
    m = trace.metrics()
    t = np.arange(1, int(np.floor(trace.t[-1] / grid_step + 1e-9)) + 1) * grid_step
    g_pose, g_head = sample_trace(trace, t)
    out = {"n": int(e.shape[0]), "nees_sum": float(nees.sum()),
           "nees_heading_sum": float(np.sum(e[:, 2] ** 2 / var[:, 2])),
           "e2_sum": [float(v) for v in np.sum(e ** 2, axis=0)],
           "var_sum": [float(v) for v in np.sum(var, axis=0)],
           "inside_2sigma": [int(v) for v in np.sum(np.abs(e) <= 2 * np.sqrt(var), axis=0)],
           "ate_xy": m["ate_xy"], "ate_theta": m["ate_theta"],
           "grid_nees_mean": float(g_pose.mean()), "grid_nees_heading_mean": float(g_head.mean())}
    if series:
        out["grid_nees"] = [_g(v) for v in g_pose]
        out["grid_nees_heading"] = [_g(v) for v in g_head]
    return out


def gate_stats(trace, run: Run | None = None) -> dict:
    """What the gate did in one run, and the pose NEES around the frames where it rejected.

    ``gated``, ``rejected``: readings of mapped ids tested and turned away;
    ``d2_sum``: the sum of their ``d2`` (all gated readings); the prior (just
    before the update) and posterior pose NEES summed over the frames where the
    gate rejected at least one reading (``*_rej``) and over the others with a
    gated reading (``*_acc``), with their counts. With ``run``, its readings'
    true ids count the misread ids the gate let through.
    """
    upd = np.flatnonzero(trace.kind == "update")
    nees_all = np.asarray(_nees(trace.error, trace.P))
    out = {"gated": 0, "rejected": 0, "d2_sum": 0.0, "frames_rej": 0, "frames_acc": 0,
           "prior_rej": 0.0, "prior_acc": 0.0, "post_rej": 0.0, "post_acc": 0.0}
    frames = [f for f in run.frames() if len(f)] if run is not None else None
    if frames is not None:
        out.update(misread=0, misread_accepted=0)
    for j, ((_, rep), k) in enumerate(zip(trace.reports, upd)):
        g = np.isfinite(rep.d2)
        if not g.any():
            continue
        rej = np.array([s == "rejected" for s in rep.status])
        out["gated"] += int(g.sum())
        out["rejected"] += int(rej.sum())
        out["d2_sum"] += float(rep.d2[g].sum())
        prior = float(_nees(pose_error(trace.x[k - 1], trace.truth[k]), trace.P[k - 1]))
        tag = "rej" if rej.any() else "acc"
        out[f"frames_{tag}"] += 1
        out[f"prior_{tag}"] += prior
        out[f"post_{tag}"] += float(nees_all[k])
        if frames is not None:
            wrong = frames[j].ids != frames[j].true_ids
            out["misread"] += int(np.sum(wrong & g))
            out["misread_accepted"] += int(np.sum(wrong & rep.accepted))
    return out


def localization_seed(seed: int) -> dict:
    """Every map-based EKF of the ``arena_localization`` study on one seed.

    Keys ``clean/<gate>`` and ``misreads/<gate>`` for the gates of
    :data:`GATES` (the trace's and the gate's numbers), ``assumed/2`` and
    ``assumed/4`` (gate 0.95, the filter assumes 2x, 4x the camera's noise std).
    """
    from ..sim import scenario

    out = {}
    for name in ("arena_loop", "arena_loop_misreads"):
        run = scenario(name, seed=seed)
        part = "clean" if name == "arena_loop" else "misreads"
        for gate in GATES:
            tr = run_filter(run, _filter(run, gate=gate))
            out[f"{part}/{_key(gate)}"] = {**trace_stats(tr), **gate_stats(tr, run)}
        if part == "clean":
            for factor in (2.0, 4.0):
                tr = run_filter(run, _filter(run, factor=factor))
                out[f"assumed/{factor:g}"] = {**trace_stats(tr), **gate_stats(tr)}
    return out


def sign_error_seed(seed: int) -> dict:
    """The library's map-based EKF and :class:`BrokenReportHLocalization` on one seed of
    ``arena_loop`` (gate 0.95), each started at the true pose with ``DEFAULT_P0``
    (``tracking/...``) and started lost, at the true pose plus an error drawn from
    :data:`LOST_P0` with generator seed ``1000 + seed``, with ``P0 = LOST_P0``
    (``lost/...``): :func:`trace_stats` and :func:`gate_stats` of each;
    ``lost/start_error`` is the error drawn."""
    from ..sim import scenario

    run = scenario("arena_loop", seed=seed)
    e0 = np.random.default_rng(1000 + seed).multivariate_normal(np.zeros(3), LOST_P0)
    out = {"lost/start_error": [float(v) for v in e0]}
    for start, x0, P0 in (("tracking", run.start_pose, DEFAULT_P0),
                          ("lost", run.start_pose + e0, LOST_P0)):
        for name, cls in (("library", EKFLocalization), ("report", BrokenReportHLocalization)):
            f = cls(x0, P0, run.Q(), run.sensor().R(2.0), run.world().landmarks(),
                    wheel_base=run.wheel_base, gate=0.95)
            tr = run_filter(run, f)
            out[f"{start}/{name}"] = {**trace_stats(tr), **gate_stats(tr)}
    return out


def slam_seed(seed: int) -> dict:
    """EKF SLAM (gate 0.95) on ``arena_loop`` with ``seed``: :func:`trace_stats` with series."""
    from ..runner import slam
    from ..sim import scenario

    return {"slam": trace_stats(slam(scenario("arena_loop", seed=seed)), series=True)}


def slam_misreads_seed(seed: int) -> dict:
    """EKF SLAM on ``arena_loop_misreads`` with ``seed``: no gate, gate 0.95, and gate 0.95
    with confirmed landmarks (:func:`slamlib.confirmation.confirmed_slam`, chapter 05).

    Per filter: the ATE, the largest position error, the landmarks mapped, how many of them
    are ids the world does not have, and the map's RMS error over the true ids.
    """
    from ..confirmation import confirmed_slam
    from ..runner import map_error, slam
    from ..sim import scenario

    run = scenario("arena_loop_misreads", seed=seed)
    world = run.world()
    out = {}
    for name, tr in (("none", slam(run, gate=None)), ("0.95", slam(run, gate=0.95)),
                     ("confirmed 0.95", confirmed_slam(run, gate=0.95))):
        rms, per_id = map_error(tr.filter, world)
        out[name] = {"ate_xy": tr.metrics()["ate_xy"],
                     "max_xy_error": float(np.max(np.hypot(*tr.error[:, :2].T))),
                     "landmarks": len(per_id),
                     "not_in_world": int(sum(not np.isfinite(e) for e in per_id.values())),
                     "map_rmse": rms}
    return out


def camera_run(seed: int) -> Run:
    """``arena_loop`` re-simulated with ``seed``, its readings through the rendered camera."""
    from ..sim import scenario
    from ..vision import CameraMarkerSensor

    return scenario("arena_loop", seed=seed, sensor=CameraMarkerSensor())


def error_correlation(run: Run, noise, lags=CAMERA_LAGS, rate: float = 10.0) -> dict:
    """Sums for the lagged correlation of one run's normalised reading errors.

    Each reading of a true marker (``id == true_id``) gives ``u = (z - z_true)
    / sigma`` for range and bearing, sigma from ``noise.R(range)``. For lag 0:
    the count and the sums of ``u`` and ``u^2`` per component; for each lag L
    (frames): over the pairs of readings of the same marker L frames apart,
    the count and the sums of ``a, b, a^2, b^2, a b`` (a the earlier, b the
    later), per component. :func:`slamlib.course.evidence.pooled_correlation`
    turns summed sums into Pearson correlations.
    """
    c = run.camera
    ok = (c.id == c.true_id) & np.isfinite(c.true_rho)
    j = np.round(c.t_capture[ok] * rate).astype(np.int64)
    ids = c.id[ok]
    z = np.column_stack([c.rho[ok], c.bearing[ok]])
    zt = np.column_stack([c.true_rho[ok], c.true_bearing[ok]])
    err = z - zt
    err[:, 1] = (err[:, 1] + np.pi) % (2 * np.pi) - np.pi
    sig = np.sqrt(np.diagonal(reading_covariances(noise, z), axis1=1, axis2=2))
    u = err / sig
    out = {"n": int(u.shape[0]), "sum": [float(v) for v in u.sum(axis=0)],
           "sum2": [float(v) for v in np.sum(u ** 2, axis=0)], "lags": {}}
    index = {(int(i), int(k)): n for n, (i, k) in enumerate(zip(ids, j))}
    for L in lags:
        pairs = [(n, index[(i, k + L)]) for (i, k), n in index.items() if (i, k + L) in index]
        a = u[[p for p, _ in pairs]] if pairs else np.zeros((0, 2))
        b = u[[q for _, q in pairs]] if pairs else np.zeros((0, 2))
        out["lags"][str(L)] = {"n": len(pairs), "a": [float(v) for v in a.sum(axis=0)],
                               "b": [float(v) for v in b.sum(axis=0)],
                               "aa": [float(v) for v in np.sum(a * a, axis=0)],
                               "bb": [float(v) for v in np.sum(b * b, axis=0)],
                               "ab": [float(v) for v in np.sum(a * b, axis=0)]}
    return out


def camera_seed(seed: int, run: Run | None = None) -> dict:
    """The ``arena_camera`` study on one seed: error correlation and the filter variants.

    ``run`` may be given (it must be :func:`camera_run` ``(seed)``) to save the rendering.
    """
    from ..vision import DEFAULT_NOISE_MODEL

    run = camera_run(seed) if run is None else run
    out = {"errors": error_correlation(run, DEFAULT_NOISE_MODEL)}
    for name, factor, every in CAMERA_VARIANTS:
        r = decimate(run, every)
        tr = run_filter(r, _filter(r, factor=factor, noise=DEFAULT_NOISE_MODEL))
        out[name] = {**trace_stats(tr), **gate_stats(tr, r),
                     "nees_median": float(np.median(tr.nees[1:]))}
    return out


def noise_seed(seed: int) -> dict:
    """The ``arena_noise`` study on one seed of ``arena_loop``: dead reckoning
    (``dead_reckoning``: :func:`trace_stats`) and, for each ``(real, assumed)`` of
    :data:`NOISE_SETTINGS`, the run re-simulated with the analytic sensor's noise std times
    ``real`` (the same seed, so the same draws, scaled) and filtered (gate 0.95) by the
    map-based EKF that assumes ``assumed`` times the recorded sensor's noise
    (``real <real>/assumed <assumed>``: :func:`trace_stats` and :func:`gate_stats`)."""
    from ..runner import dead_reckoning
    from ..sim import scenario

    run = scenario("arena_loop", seed=seed)
    out = {"dead_reckoning": trace_stats(dead_reckoning(run))}
    sensor = run.sensor()
    for real, assumed in NOISE_SETTINGS:
        r = run if real == 1.0 else scenario(
            "arena_loop", seed=seed, sigma_range0=real * sensor.sigma_range0,
            sigma_range_per_m=real * sensor.sigma_range_per_m,
            sigma_bearing=real * sensor.sigma_bearing)
        tr = run_filter(r, _filter(r, factor=assumed / real))
        out[f"real {real:g}/assumed {assumed:g}"] = {**trace_stats(tr), **gate_stats(tr)}
    return out


def explore_seed(seed: int) -> dict:
    """Chapter 07's exploration (world ``exploration_world(5)``, return rule 0.1 m, 180 s)
    with simulation ``seed`` (the chapter's run is seed 5): :func:`trace_stats`, and the
    largest ``|e_theta| / sigma_theta`` of the run with its time."""
    from ..explore import Explorer, exploration_world
    from ..explore import explore as _explore

    e = _explore(exploration_world(seed=5), seed=seed, duration=180.0,
                 explorer=Explorer(sigma_return=0.1))
    tr = e.trace
    r = np.abs(tr.error[1:, 2]) / tr.sigma[1:, 2]
    k = int(np.argmax(r))
    return {"explore": {**trace_stats(tr), "max_heading_ratio": float(r[k]),
                        "t_max_heading_ratio": float(tr.t[1 + k])}}


# --------------------------------------------------------------------------- studies and files
STUDIES = {"arena_localization": localization_seed, "arena_sign_error": sign_error_seed,
           "arena_slam": slam_seed,
           "arena_slam_misreads": slam_misreads_seed,
           "arena_camera": camera_seed, "explore_world5": explore_seed,
           "arena_noise": noise_seed}


def _one(args):
    name, seed = args
    return STUDIES[name](seed)


def run_study(name: str, seeds=SEEDS, workers: int = 1) -> dict:
    """Run study ``name`` of :data:`STUDIES` on every seed; ``workers`` processes (same numbers)."""
    if name not in STUDIES:
        raise ValueError(f"name: expected one of {sorted(STUDIES)}, got {name!r}")
    seeds = [int(s) for s in seeds]
    if workers > 1:
        from multiprocessing import get_context

        with get_context("spawn").Pool(workers) as pool:
            runs = pool.map(_one, [(name, s) for s in seeds], chunksize=1)
    else:
        runs = [STUDIES[name](s) for s in seeds]
    return {"format": FORMAT, "study": name, "seeds": seeds, "grid_step": GRID_STEP,
            "runs": runs}


def save_study(study: dict, folder=EVIDENCE_DIR) -> Path:
    """Write ``study`` to ``folder/<name>.json`` (sorted keys, floats as repr: exact)."""
    path = Path(folder) / f"{study['study']}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(study, sort_keys=True, separators=(",", ":")) + "\n")
    return path


def main(argv=None, studies=None, run=None, description: str | None = None) -> int:
    """The command line that writes (or, with ``--check``, recomputes and compares) stored
    studies: ``[names] [--workers N] [--check]``; every study of ``studies`` by default.

    ``studies`` and ``run`` default to this module's :data:`STUDIES` and :func:`run_study`
    (``tools/make_evidence.py``); chapters 07-08's studies pass theirs. Returns 1 if a
    checked file differs.
    """
    import argparse
    import time

    studies, run = (STUDIES if studies is None else studies), (run or run_study)
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("studies", nargs="*", default=sorted(studies))
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args(argv)
    bad = 0
    for name in args.studies:
        t0 = time.perf_counter()
        study = run(name, workers=args.workers)
        dt = time.perf_counter() - t0
        if args.check:
            path = EVIDENCE_DIR / f"{name}.json"
            same = path.exists() and json.loads(path.read_text()) == json.loads(json.dumps(study))
            print(f"{name}: {'unchanged' if same else 'DIFFERS'} ({dt:.0f} s)")
            bad += not same
        else:
            print(f"{name}: wrote {save_study(study)} ({dt:.0f} s)")
    return 1 if bad else 0


def load_study(name: str, folder=EVIDENCE_DIR) -> dict:
    """Read ``folder/<name>.json``, checking its format, seeds and runs."""
    path = Path(folder) / f"{name}.json"
    d = load_stored(path, "evidence")
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise ValueError(f"{path}: expected format {FORMAT!r}")
    if d.get("study") != name:
        raise ValueError(f"{path}: field 'study' is {d.get('study')!r}, expected {name!r}")
    if not isinstance(d.get("seeds"), list) or not isinstance(d.get("runs"), list) \
            or len(d["seeds"]) != len(d["runs"]):
        raise ValueError(f"{path}: expected lists 'seeds' and 'runs' of the same length")
    return d


def column(study: dict, part: str, key: str, index: int | None = None) -> np.ndarray:
    """``run[part][key]`` (or its ``index``-th entry) for every run of ``study``, as an array."""
    vals = [r[part][key] for r in study["runs"]]
    a = np.asarray(vals, dtype=float)
    return a if index is None else a[:, index]


def rank(values, value) -> tuple[int, float]:
    """How many of ``values`` are >= ``value``, and that count as a fraction of all."""
    v = np.asarray(values, dtype=float)
    k = int(np.sum(v >= value))
    return k, k / v.size


def pooled_correlation(parts: list[dict], lag: int) -> np.ndarray:
    """Pearson correlation (range, bearing) at ``lag`` from summed :func:`error_correlation`."""
    s = {k: np.zeros(2) for k in ("a", "b", "aa", "bb", "ab")}
    n = 0
    for p in parts:
        q = p["lags"][str(lag)]
        n += q["n"]
        for k in s:
            s[k] += np.asarray(q[k])
    ma, mb = s["a"] / n, s["b"] / n
    cov = s["ab"] / n - ma * mb
    return cov / np.sqrt((s["aa"] / n - ma ** 2) * (s["bb"] / n - mb ** 2))


def nees_study(study: dict, part: str = "slam"):
    """The stored NEES series of ``study[part]`` as a :class:`slamlib.studies.NEESStudy`.

    The runs end a few encoder periods apart: the grid is cut at the shortest
    (as :func:`slamlib.studies.monte_carlo` does).
    """
    from ..studies import NEESStudy

    runs = [r[part] for r in study["runs"]]
    T = min(len(r["grid_nees"]) for r in runs)
    t = np.arange(1, T + 1) * float(study["grid_step"])
    return NEESStudy(study["study"], part, tuple(study["seeds"]), t,
                     np.array([r["grid_nees"][:T] for r in runs]),
                     np.array([r["grid_nees_heading"][:T] for r in runs]),
                     np.array([r["ate_xy"] for r in runs]))
