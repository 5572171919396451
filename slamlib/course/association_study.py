"""Chapter 09's study: the course's runs with the ids hidden, associated by NN or JCBB.

- :func:`run_without_ids` drives a filter over a run like
  :func:`slamlib.runner.run_filter`, but hands it ``update(None, z)``
  (for ``association="ids"`` the ids as read) and keeps each frame's true ids;
- :func:`association_errors` scores a run: how many readings were fused into
  the wrong landmark, rejected, or started a landmark from clutter;
- :func:`study` runs ids / NN / JCBB over many seeds (ATE, NEES, wrong
  association rate, rejected readings), in a process pool whose answer does
  not depend on the number of workers; :func:`save_study` / :func:`load_study`
  store it as JSON (``make association-study`` writes
  ``data/studies/association_study.json``; a test recomputes a sample);
- :func:`drift_row` / :func:`drift_study`: the whole loop with three times the
  wheel slip (``sigma_wheel`` 0.06, seeds 1-100; seed 1 is the chapter's drifted
  run), ids / NN / JCBB at gates 0.95 and 0.99, scored before and after the loop
  closure (``data/studies/association_drift.json``, the same make target);
- :func:`dense_run` / :func:`dense_row` / :func:`dense_study`: a random world of
  200 markers 8 cm apart, one world and one drive per seed (seed 1 is the
  chapter's), NN and JCBB (``data/studies/association_dense.json``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import runner
from ..confirmation import ConfirmedSLAM
from ..ekf import EKFSLAM
from ..metrics import ate
from ..runs import Run
from ..studies import map_jobs
from ..worlds import DATA_DIR
from .stored import load_stored

__all__ = ["run_without_ids", "make_filter", "AssociationScore", "association_errors",
           "study_row", "study", "save_study", "load_study", "STUDY_PATH", "STUDY_SETTINGS",
           "crowded_frame", "landmark_readings", "wrong_associations", "drift_row",
           "drift_study", "load_drift_study", "DRIFT_PATH",
           "DRIFT_SETTINGS", "dense_run", "dense_row", "dense_study", "load_dense_study",
           "DENSE_PATH", "DENSE_SETTINGS"]

#: Where ``make association-study`` stores the Monte-Carlo of chapter 09.
STUDY_PATH = DATA_DIR / "studies" / "association_study.json"
#: The study's settings: the arena re-simulated with clutter, the first 30 s (first lap).
STUDY_SETTINGS = {"scenario": "arena_loop", "p_outlier": 0.1, "max_time": 30.0,
                  "seeds": list(range(2000, 2100)), "methods": ["ids", "nn", "jcbb"]}
#: Where ``make association-study`` stores the drifted full loops of chapter 09, section 7.
DRIFT_PATH = STUDY_PATH.with_name("association_drift.json")
#: The drift study: the whole arena loop, three times the wheel slip, no clutter; seed 1 is
#: ``scenario("arena_loop", sigma_wheel=0.06)``. ``closure_time``: the scores before/after it
#: (the robot sees 21 and 31 again at about 48 s); ``probe_time``: the pose error and NEES
#: just before the closure.
DRIFT_SETTINGS = {"scenario": "arena_loop", "sigma_wheel": 0.06, "seeds": list(range(1, 101)),
                  "configs": [["ids", 0.95], ["nn", 0.95], ["jcbb", 0.95], ["nn", 0.99],
                              ["jcbb", 0.99]],
                  "closure_time": 40.0, "probe_time": 47.0}
#: Where ``make association-study`` stores the dense random worlds of chapter 09, section 7.
DENSE_PATH = STUDY_PATH.with_name("association_dense.json")
#: The dense worlds: ``count`` markers at least ``min_spacing`` apart in ``extent``, one loop of
#: ``max_duration`` s; seed s draws the world and the drive (seed 1 is the chapter's world).
DENSE_SETTINGS = {"extent": [0.0, 6.0, -3.0, 3.0], "count": 200, "min_spacing": 0.08,
                  "sigma_wheel": 0.02, "max_duration": 25.0, "seeds": list(range(1, 101)),
                  "methods": ["nn", "jcbb"]}


def make_filter(run: Run, association: str, *, confirmed: bool = True, gate: float = 0.95,
                n_confirm: int = 2):
    """The chapter's filter for ``run``: ConfirmedSLAM (or plain EKFSLAM) with that association."""
    if not confirmed:
        return runner.make_filter(EKFSLAM, run, gate=gate, association=association)
    return runner.make_filter(ConfirmedSLAM, run, gate=gate, association=association,
                              n_confirm=n_confirm)


def run_without_ids(run: Run, filt, *, max_time: float | None = None,
                    gates: list | None = None):
    """Drive ``filt`` over ``run`` with the ids hidden (unless its association is ``"ids"``).

    With a list ``gates``, one entry per report is appended to it: per reading,
    how many landmarks had it inside their gate
    (``filt.last_association["in_gate"]``; zeros with ids).

    Returns
    -------
    (trace, true_ids) : (slamlib.runner.Trace, list of numpy.ndarray)
        The trace (one report per frame with readings) and, per report, the
        true marker of each reading (-1 for clutter).
    """
    sensor = run.sensor()
    anonymous = filt.association != "ids"
    rec = runner.TraceRecorder(run.enc_t[0], filt)
    true_ids = []
    for ev in run.events():
        if max_time is not None and ev.t > max_time:
            break
        report = None
        if ev.kind == "predict":
            filt.predict(ev.u, ev.dt)
        else:
            obs = ev.obs
            if len(obs) == 0:
                continue
            R = runner.reading_covariances(sensor, obs.z)
            report = filt.update(None if anonymous else obs.ids, obs.z, R=R)
            true_ids.append(obs.true_ids.copy())
            if gates is not None:
                in_gate = filt.last_association.get("in_gate") if anonymous else None
                gates.append(np.zeros(len(obs), dtype=np.int64) if in_gate is None
                             else np.array(in_gate, dtype=np.int64))
        rec.record(ev.t, ev.kind, filt, report)
    return rec.trace(run, filt), true_ids


@dataclass(frozen=True)
class AssociationScore:
    """How one run's readings were associated.

    A landmark is *labelled* with the true marker that most of its readings
    (the one that started it and those fused into it) came from; a fused
    reading is *wrong* when its true marker is not its landmark's label. (A
    landmark started by marker 31 and fed marker 21 for the rest of the run is
    marker 21's landmark: its first reading counts as the wrong one.)

    Attributes
    ----------
    readings : int
        Readings of real markers (clutter excluded).
    fused : int
        Readings of real markers fused into a landmark.
    wrong : int
        Of those, readings whose landmark's label is another marker (or clutter).
    rejected : int
        Readings of real markers not used (rejected, candidate, duplicate).
    clutter : int
        Clutter readings in the run.
    clutter_fused : int
        Clutter readings fused into a landmark.
    clutter_landmarks : int
        Landmarks of the final map started by a clutter reading.
    duplicates : int
        Landmarks of the final map whose label is a marker that labels another one too.
    origin : dict
        Map id -> the true marker whose reading started it (-1: clutter).
    label : dict
        Map id -> the true marker most of its readings came from.
    """

    readings: int
    fused: int
    wrong: int
    rejected: int
    clutter: int
    clutter_fused: int
    clutter_landmarks: int
    duplicates: int
    origin: dict
    label: dict

    @property
    def wrong_rate(self) -> float:
        """Wrong associations per fused reading."""
        return self.wrong / self.fused if self.fused else 0.0


def landmark_readings(trace, true_ids) -> dict[int, dict]:
    """Per map id of ``trace`` (from :func:`run_without_ids`): the time ``born`` and the true
    marker ``origin`` of the reading that started it, and ``readings``, how many readings of
    each true marker (-1: clutter) started it or were fused into it."""
    out: dict[int, dict] = {}
    for (t, rep), tid in zip(trace.reports, true_ids):
        for i, mk in enumerate(tid):
            if not (rep.new[i] or rep.accepted[i]):
                continue
            d = out.setdefault(int(rep.matched[i]), {"born": None, "origin": None, "readings": {}})
            if rep.new[i]:
                d["born"], d["origin"] = float(t), int(mk)
            d["readings"][int(mk)] = d["readings"].get(int(mk), 0) + 1
    return out


def wrong_associations(seed: int, method: str = "jcbb", settings: dict = STUDY_SETTINGS) -> dict:
    """Each wrong association of one run of the study (:func:`study_row`), and why it had
    no right answer to choose.

    Returns a dict: ``score`` (:class:`AssociationScore`), ``landmarks``
    (:func:`landmark_readings`) and ``wrong``, one dict per reading fused into a
    landmark labelled with another marker: ``t``, ``marker`` (its true marker),
    ``label`` (its landmark's), ``in_gate`` (landmarks inside its gate: 1 means the
    wrong one alone), ``own_mapped`` (a landmark labelled ``marker`` existed before this
    frame) and ``others`` (other readings of the frame inside some gate).
    """
    from ..sim import scenario

    run = scenario(settings["scenario"], seed=int(seed), p_outlier=settings["p_outlier"])
    filt = make_filter(run, method)
    gates: list = []
    tr, tid = run_without_ids(run, filt, max_time=settings["max_time"], gates=gates)
    sc = association_errors(tr, tid)
    lm = landmark_readings(tr, tid)
    wrong = []
    for (t, rep), marks, g in zip(tr.reports, tid, gates):
        for i, mk in enumerate(marks):
            mk = int(mk)
            if mk < 0 or not rep.accepted[i] or rep.new[i] or sc.label[int(rep.matched[i])] == mk:
                continue
            wrong.append({"t": float(t), "marker": mk, "label": sc.label[int(rep.matched[i])],
                          "in_gate": int(g[i]),
                          "own_mapped": any(sc.label.get(m) == mk and d["born"] is not None
                                            and d["born"] < t for m, d in lm.items()),
                          "others": int(np.count_nonzero(g > 0)) - 1})
    return {"score": sc, "landmarks": lm, "wrong": wrong}


def association_errors(trace, true_ids) -> AssociationScore:
    """Score ``trace`` (from :func:`run_without_ids`) against the true ids of its readings."""
    lm = landmark_readings(trace, true_ids)
    origin = {m: d["origin"] for m, d in lm.items() if d["origin"] is not None}
    votes = {m: d["readings"] for m, d in lm.items() if d["readings"]}
    # the majority; a tie goes to the marker that started the landmark, then to the lower id
    label = {m: max(v, key=lambda t, m=m: (v[t], t == origin.get(m), -t))
             for m, v in votes.items()}
    readings = fused = wrong = rejected = clutter = clutter_fused = 0
    for (_, rep), tid in zip(trace.reports, true_ids):
        for i, t in enumerate(tid):
            t = int(t)
            clutter += t < 0
            readings += t >= 0
            if rep.accepted[i] and not rep.new[i]:
                if t < 0:
                    clutter_fused += 1
                    continue
                fused += 1
                wrong += label[int(rep.matched[i])] != t
            elif t >= 0 and not rep.new[i]:
                rejected += 1
    labels = list(label.values())
    dup = sum(labels.count(t) - 1 for t in set(labels) if t >= 0)
    return AssociationScore(readings, fused, wrong, rejected, clutter, clutter_fused,
                            list(origin.values()).count(-1), dup, origin, label)


def study_row(seed: int, method: str, settings: dict = STUDY_SETTINGS) -> dict:
    """One run of the study: ATE (m), mean pose NEES, the association's counts."""
    from ..sim import scenario

    run = scenario(settings["scenario"], seed=int(seed), p_outlier=settings["p_outlier"])
    filt = make_filter(run, method)
    tr, tid = run_without_ids(run, filt, max_time=settings["max_time"])
    sc = association_errors(tr, tid)
    return {"seed": int(seed), "method": method,
            "ate": round(float(ate(tr.x, tr.truth).position), 6),
            "nees": round(float(np.mean(tr.nees)), 6),
            "readings": sc.readings, "fused": sc.fused, "wrong": sc.wrong,
            "rejected": sc.rejected, "clutter": sc.clutter, "clutter_fused": sc.clutter_fused,
            "clutter_landmarks": sc.clutter_landmarks, "duplicates": sc.duplicates,
            "landmarks": int(filt.n_landmarks)}


def _row(args):
    return study_row(*args)


def study(settings: dict = STUDY_SETTINGS, workers: int = 2) -> list[dict]:
    """Every (seed, method) of ``settings``, in that order (the same for any ``workers``)."""
    jobs = [(s, m, settings) for s in settings["seeds"] for m in settings["methods"]]
    return map_jobs(_row, jobs, max(int(workers), 1))


def save_study(rows: list[dict], path=STUDY_PATH, settings: dict = STUDY_SETTINGS) -> None:
    """Write the study as JSON (sorted keys, fixed rounding: the same rows give the same bytes)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps({"settings": settings, "rows": rows}, indent=1, sort_keys=True)
    path.write_text(text + "\n", encoding="utf-8")


def load_study(path=STUDY_PATH) -> tuple[dict, list[dict]]:
    """``(settings, rows)`` of a stored study."""
    d = load_stored(path, "association-study")
    return d["settings"], d["rows"]


def drift_row(seed: int, method: str, gate: float, settings: dict = DRIFT_SETTINGS) -> dict:
    """One drifted loop: the association's counts in all and after ``closure_time``, the
    duplicates, ATE, final position error, time-averaged pose NEES, and the position error
    and pose NEES at ``probe_time`` (just before the loop closure)."""
    from ..sim import scenario

    run = scenario(settings["scenario"], seed=int(seed), sigma_wheel=settings["sigma_wheel"])
    filt = make_filter(run, method, gate=gate)
    tr, tid = run_without_ids(run, filt)
    sc = association_errors(tr, tid)
    late = [k for k, (t, _) in enumerate(tr.reports) if t > settings["closure_time"]]
    wrong_late = 0
    for k in late:
        rep = tr.reports[k][1]
        for i, t in enumerate(tid[k]):
            if rep.accepted[i] and not rep.new[i] and int(t) >= 0:
                wrong_late += sc.label[int(rep.matched[i])] != int(t)
    kp = int(np.searchsorted(tr.t, settings["probe_time"]))
    return {"seed": int(seed), "method": method, "gate": float(gate),
            "wrong": sc.wrong, "wrong_late": int(wrong_late), "fused": sc.fused,
            "rejected": sc.rejected, "duplicates": sc.duplicates,
            "landmarks": int(filt.n_landmarks),
            "ate": round(float(ate(tr.x, tr.truth).position), 6),
            "final_error": round(float(np.hypot(*tr.error[-1, :2])), 6),
            "nees": round(float(np.mean(tr.nees)), 6),
            "probe_error": round(float(np.hypot(*tr.error[kp, :2])), 6),
            "probe_nees": round(float(tr.nees[kp]), 6)}


def _drift(args):
    return drift_row(*args)


def drift_study(settings: dict = DRIFT_SETTINGS, workers: int = 2) -> list[dict]:
    """Every (seed, config) of the drift study, in that order (the same for any ``workers``)."""
    jobs = [(s, m, g, settings) for s in settings["seeds"] for m, g in settings["configs"]]
    return map_jobs(_drift, jobs, max(int(workers), 1))


def load_drift_study(path=DRIFT_PATH) -> tuple[dict, list[dict]]:
    """``(settings, rows)`` of the stored drift study."""
    d = load_stored(path, "association-study")
    return d["settings"], d["rows"]


def dense_run(seed: int, settings: dict = DENSE_SETTINGS) -> Run:
    """The dense world of ``seed`` and one loop through it (analytic sensor, no clutter)."""
    from ..sensors import AnalyticMarkerSensor
    from ..sim import KobukiParams, WaypointController, loop_waypoints, simulate
    from ..worlds import random_world

    world = random_world(extent=tuple(settings["extent"]), count=settings["count"],
                         min_spacing=settings["min_spacing"], seed=int(seed))
    wp = loop_waypoints(world.bounds, margin=1.0)
    return simulate(world, WaypointController(wp[1:]), sensor=AnalyticMarkerSensor(),
                    seed=int(seed), params=KobukiParams(sigma_wheel=settings["sigma_wheel"]),
                    start_pose=[wp[0, 0], wp[0, 1], -np.pi / 2], name=f"dense_{settings['count']}",
                    max_duration=settings["max_duration"])


def dense_row(seed: int, method: str, settings: dict = DENSE_SETTINGS) -> dict:
    """One dense world: the association's counts, the map's size and the ATE."""
    run = dense_run(seed, settings)
    filt = make_filter(run, method)
    tr, tid = run_without_ids(run, filt)
    sc = association_errors(tr, tid)
    return {"seed": int(seed), "method": method, "wrong": sc.wrong, "fused": sc.fused,
            "rejected": sc.rejected, "duplicates": sc.duplicates,
            "landmarks": int(filt.n_landmarks),
            "ate": round(float(np.sqrt(np.mean(np.sum(tr.error[:, :2] ** 2, axis=1)))), 6)}


def _dense(args):
    return dense_row(*args)


def dense_study(settings: dict = DENSE_SETTINGS, workers: int = 2) -> list[dict]:
    """Every (seed, method) of the dense study, in that order (the same for any ``workers``)."""
    jobs = [(s, m, settings) for s in settings["seeds"] for m in settings["methods"]]
    return map_jobs(_dense, jobs, max(int(workers), 1))


def load_dense_study(path=DENSE_PATH) -> tuple[dict, list[dict]]:
    """``(settings, rows)`` of the stored dense study."""
    d = load_stored(path, "association-study")
    return d["settings"], d["rows"]


if __name__ == "__main__":  # python -m slamlib.course.association_study [first|drift|dense|all]
    import sys

    which = sys.argv[1] if len(sys.argv) > 1 else "all"
    if which in ("first", "all"):
        save_study(study(), STUDY_PATH)
        print(f"wrote {STUDY_PATH}")
    if which in ("drift", "all"):
        save_study(drift_study(), DRIFT_PATH, DRIFT_SETTINGS)
        print(f"wrote {DRIFT_PATH}")
    if which in ("dense", "all"):
        save_study(dense_study(), DENSE_PATH, DENSE_SETTINGS)
        print(f"wrote {DENSE_PATH}")


def crowded_frame(k: int, spacing: float, clutter: float = 0.0, seed: int = 0):
    """A known map of k landmarks in two staggered rows ``spacing`` apart, a filter on it
    (``EKFLocalization``, JCBB, pose sigma 0.1 m and 2 deg) and one frame of k readings, a
    fraction ``clutter`` of which are spurious readings near random landmarks (chapter 09's
    cost of JCBB). Returns ``(filter, z)``."""
    from ..ekf import EKFLocalization
    from ..models import observe

    Q = np.diag([1e-4, 1e-4])
    R = np.diag([0.02**2, np.radians(1.0) ** 2])
    lm = {j: np.array([2.0 + 0.3 * (j % 2), -0.5 * spacing * (k - 1) + spacing * j])
          for j in range(k)}
    P0 = np.diag([0.1**2, 0.1**2, np.radians(2.0) ** 2])
    f = EKFLocalization(np.zeros(3), P0, Q, R, lm, association="jcbb")
    true = np.array([0.03, 0.05, 0.01])
    rng = np.random.default_rng(seed)
    seen = rng.permutation(k)[:int(round(k * (1.0 - clutter)))]
    z = [observe(true, lm[j]) + rng.normal(0.0, [0.02, 0.017]) for j in seen]
    z += [observe(true, lm[int(rng.integers(k))] + rng.normal(0.0, 0.06, 2))
          for _ in range(k - len(seen))]
    return f, np.array(z)
