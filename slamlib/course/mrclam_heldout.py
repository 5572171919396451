"""Chapter 10: the noise identification tested on data it never saw (UTIAS MRCLAM Dataset 6).

An identification is a hypothesis: that the noise found on some data is the
noise of other data. This module tests it. Each **split** divides the logs
into a part the identification learns from and a part it never sees; EKF
SLAM (:func:`slamlib.datasets.mrclam.slam`, gate 0.95) runs on each robot's
held-out part with the calibration that :func:`slamlib.datasets.identify.identify`
found on the other part, and its position ATE against Vicon is recorded:

- ``robots_excerpt``: the shipped excerpt; each robot judged with the noise
  identified on the OTHER four robots (leave one robot out);
- ``halves``: full Dataset 6; every robot's first half teaches, its second half
  is judged (across time);
- ``excerpt_rest``: full Dataset 6; the excerpt (its first 200 s) teaches, the
  rest of each log (about 11 minutes) is judged;
- ``robots``: full Dataset 6, leave one robot out over the whole logs.

Each **variant** identifies some components (:data:`VARIANTS`, the ablation):
the textbook noise, then R(rho), its outlier model, the noise density Q, the
command scale and delay. For the chosen model (:data:`CHOSEN`) and for the
model with every component (:data:`EVERYTHING`), the **in-sample** ATE too: the
same runs with the noise identified on the judged data itself (what a test
on the data one fitted to would have reported).

These are one run per robot and split (real data): no Monte-Carlo band.
:func:`compare` pools the splits' runs to decide a component (paired
ratios, a sign count and a seeded bootstrap interval of the median ratio that
resamples whole robots, :meth:`Study.compare`: a robot's runs on the four
nested splits are not independent). The variants were compared, and
:data:`CHOSEN` picked, on these same runs: they validate a choice, they are
not an untouched test.

The full data set is not shipped: ``make mrclam-heldout MRCLAM=/path/to/MRCLAM_Dataset6``
(``python -m slamlib.course.mrclam_heldout /path/to/MRCLAM_Dataset6``) writes
``data/studies/mrclam_heldout.json`` (6 significant digits, no timings: bit for
bit the same on every regeneration; about 20 minutes on one core);
``tests/test_mrclam_heldout.py`` recomputes the excerpt's split (and, with
``MRCLAM_DATASET6`` set to a download, a robot of the full data set).
"""

from __future__ import annotations

import argparse
import dataclasses
import warnings
from pathlib import Path

import numpy as np

from ..datasets import identify, mrclam
from ..worlds import DATA_DIR
from .stored import load_stored, save_rows

__all__ = ["FORMAT", "STUDY_FILE", "VARIANTS", "CHOSEN", "EVERYTHING", "SPLITS", "IN_SAMPLE",
           "load_logs", "split_parts", "run_split", "study", "save", "load", "Study",
           "compare", "main"]

FORMAT = "slamlib-mrclam-heldout/1"
STUDY_FILE = DATA_DIR / "studies" / "mrclam_heldout.json"
#: The ablation: name -> (components identified, density window in s).
VARIANTS = {
    "textbook": ((), 1.0),
    "R": (("R",), 1.0),
    "R+outliers": (("R", "outliers"), 1.0),
    "R+outliers+Q": (("R", "outliers", "Q"), 1.0),
    "R+Q": (("R", "Q"), 1.0),
    "Q": (("Q",), 1.0),
    "R+outliers+Q(16 s)": (("R", "outliers", "Q"), 16.0),
    "R+outliers+Q+scale": (("R", "outliers", "Q", "scale"), 1.0),
    "R+outliers+Q+delay": (("R", "outliers", "Q", "delay"), 1.0),
    "R+outliers+Q+scale+delay": (("R", "outliers", "Q", "scale", "delay"), 1.0),
    "R+outliers+Q per step": (("R", "outliers", "Q"), 1.0),
    "R+outliers+Q+scale, Q as logged": (("R", "outliers", "Q", "scale"), 1.0),
    "R+outliers+Q+delay, Q as logged": (("R", "outliers", "Q", "delay"), 1.0),
}
#: Variants that change the identified calibration after :func:`identify` (the confounds'
#: controls): "per step" uses the identified size of Q as a FIXED per-step covariance
#: ``Q_c / dt_med`` (``dt_med`` the teaching logs' median step), not a density; "Q as logged"
#: keeps the command correction but fits Q's density on the commands as logged (``identify``
#: fits it on the corrected commands, so adding scale or delay also changes Q).
PER_STEP = ("R+outliers+Q per step",)
Q_AS_LOGGED = ("R+outliers+Q+scale, Q as logged", "R+outliers+Q+delay, Q as logged")
#: The model the held-out evidence kept (identify.KEPT), and the one with every component.
CHOSEN = "R+outliers+Q"
EVERYTHING = "R+outliers+Q+scale+delay"
#: The variants whose in-sample ATE is stored beside the held-out one.
IN_SAMPLE = ("R+outliers+Q", "R+outliers+Q+scale+delay")
#: The splits: name -> (which data, how it is divided).
SPLITS = {
    "robots_excerpt": ("excerpt", "leave one robot out"),
    "halves": ("full", "first half -> second half"),
    "excerpt_rest": ("full", "the excerpt's 200 s -> the rest"),
    "robots": ("full", "leave one robot out"),
}
_DIGITS = 6


def _r(v) -> float:
    return float(f"{float(v):.{_DIGITS}g}")


def load_logs(folder) -> dict:
    """The five robots' logs of ``folder`` as loaded (misreads dropped; their warnings
    silenced here: the chapter shows them)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrclam.MRCLAMWarning)
        return {r: mrclam.load(folder, r) for r in mrclam.ROBOTS}


def split_parts(split: str, logs: dict, excerpt: dict | None = None) -> tuple[dict, dict]:
    """For each robot: the logs to identify from, and the held-out time span ``(t0, t1)``.

    ``logs`` the data set's logs (the excerpt for ``robots_excerpt``, the full data
    set otherwise); ``excerpt`` the excerpt's logs (``excerpt_rest`` only).
    """
    R = mrclam.ROBOTS
    if split in ("robots_excerpt", "robots"):
        fit = {r: [logs[k] for k in R if k != r] for r in R}
        held = {r: (logs[r].enc_t[0], logs[r].enc_t[-1]) for r in R}
    elif split == "halves":
        mid = {r: 0.5 * (logs[r].enc_t[0] + logs[r].enc_t[-1]) for r in R}
        first = [logs[k].between(logs[k].enc_t[0], mid[k]) for k in R]
        fit = {r: first for r in R}
        held = {r: (mid[r], logs[r].enc_t[-1]) for r in R}
    elif split == "excerpt_rest":
        if excerpt is None:
            raise ValueError("excerpt: expected the excerpt's logs for split 'excerpt_rest'")
        fit = {r: list(excerpt.values()) for r in R}
        held = {r: (excerpt[r].enc_t[-1], logs[r].enc_t[-1]) for r in R}
    else:
        raise ValueError(f"split: expected one of {tuple(SPLITS)}, got {split!r}")
    return fit, held


def _judge(folder, robot: int, cal: identify.Calibration, span, q_step_dt=None) -> float:
    """Held-out ATE of ``robot`` over ``span`` with ``cal`` (its Q density as a fixed
    per-step ``Q_c / q_step_dt`` if ``q_step_dt`` is given)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrclam.MRCLAMWarning)
        if q_step_dt is None:
            log = mrclam.load(folder, robot, calibration=cal)
        else:
            if cal.command_scale is not None or cal.command_delay is not None:
                raise ValueError("cal: a per-step Q variant expects no command correction")
            noise = cal.noise(mrclam.DEFAULT_WHEEL_BASE)
            noise["Q"] = np.asarray(noise.pop("Q_density")) / float(q_step_dt)
            log = mrclam.load(folder, robot, noise=noise)
    return float(mrclam.slam(log.between(*span)).metrics()["ate_xy"])


def _calibrate(name: str, fit_logs) -> tuple[identify.Calibration, float | None]:
    """The variant's calibration from ``fit_logs``, and its per-step dt (PER_STEP only)."""
    comps, window = VARIANTS[name]
    cal = identify.identify(fit_logs, comps, window=window)
    if name in Q_AS_LOGGED:
        cal = dataclasses.replace(cal, q_density=identify.noise_density(fit_logs, window))
    dt = (float(np.median(np.concatenate([np.diff(lg.enc_t) for lg in fit_logs])))
          if name in PER_STEP else None)
    return cal, dt


def run_split(split: str, folder, logs: dict, excerpt: dict | None = None,
              variants=tuple(VARIANTS), in_sample=IN_SAMPLE, robots=mrclam.ROBOTS) -> dict:
    """Every variant's held-out ATE per robot on one split (and the in-sample ones)."""
    fit, held = split_parts(split, logs, excerpt)
    rows: dict = {}
    for name in variants:
        ate, cals = [], {}
        for r in robots:
            cal, dt = _calibrate(name, fit[r])
            ate.append(_r(_judge(folder, r, cal, held[r], dt)))
            cals[r] = cal
        row = {"ate": ate}
        if name in (CHOSEN, EVERYTHING):
            row["calibration"] = {str(r): _rounded(cals[r].to_dict()) for r in robots}
        rows[name] = row
    ins: dict = {}
    for name in in_sample:
        comps, window = VARIANTS[name]
        judged = [logs[r].between(*held[r]) for r in mrclam.ROBOTS]
        cal = identify.identify(judged, comps, window=window)
        ins[name] = {"ate": [_r(_judge(folder, r, cal, held[r])) for r in robots],
                     "calibration": _rounded(cal.to_dict())}
    return {"data": SPLITS[split][0], "division": SPLITS[split][1], "robots": list(robots),
            "held_seconds": [_r(held[r][1] - held[r][0]) for r in robots],
            "variants": rows, "in_sample": ins}


def _rounded(d):
    if isinstance(d, dict):
        return {k: _rounded(v) for k, v in d.items()}
    if isinstance(d, (list, tuple)):
        return [_rounded(v) for v in d]
    if isinstance(d, float):
        return _r(d)
    return d


def _whiteness_dict(wh: identify.Whiteness) -> dict:
    return {k: [_r(v) for v in getattr(wh, k)] for k in
            ("windows", "n", "q_v", "q_w", "corr_v", "corr_w")}


def checks(full: dict, excerpt: dict) -> dict:
    """Two measurements of the full data set that chapter 10 quotes beside the excerpt's.

    ``whiteness``: :func:`identify.whiteness` of the five full logs pooled, commands as
    logged and scaled and delayed (fitted on the same logs). ``excerpt_span_full_vicon``:
    the reading noise of the excerpt's time span (each robot's first 200 s) read from
    the full download, every Vicon sample kept: is the excerpt's outlier share a
    property of its thinned Vicon or of its period?
    """
    fit = identify.fit_commands(full.values())
    spans = [full[r].between(excerpt[r].enc_t[0], excerpt[r].enc_t[-1]) for r in mrclam.ROBOTS]
    out = {}
    for name, logs in (("excerpt", list(excerpt.values())), ("excerpt_span_full_vicon", spans),
                       ("full", list(full.values()))):
        res = identify.ReadingResiduals.concatenate(identify.reading_residuals(lg) for lg in logs)
        rn = identify.fit_reading_noise(res)
        out[name] = {"readings": int(rn.outlier.size), "outliers": int(rn.outlier.sum()),
                     **{k: _r(v) for k, v in rn.params().items()}}
    return {"whiteness": {"as logged": _whiteness_dict(identify.whiteness(full.values())),
                          "scaled and delayed": _whiteness_dict(
                              identify.whiteness(full.values(), commands=fit))},
            "reading_noise": out}


def study(full_folder, excerpt_folder=mrclam.EXCERPT_DIR, splits=tuple(SPLITS)) -> dict:
    """Every split (the full data set's from ``full_folder``)."""
    excerpt = load_logs(excerpt_folder)
    full = load_logs(full_folder) if any(SPLITS[s][0] == "full" for s in splits) else None
    out = {}
    for s in splits:
        if SPLITS[s][0] == "excerpt":
            out[s] = run_split(s, excerpt_folder, excerpt)
        else:
            out[s] = run_split(s, full_folder, full, excerpt)
    return {"format": FORMAT, "excerpt": Path(excerpt_folder).name,
            "full": Path(full_folder).name,
            "variants": {k: {"components": list(v[0]), "window": v[1]}
                         for k, v in VARIANTS.items()},
            "checks": checks(full, excerpt) if full is not None else None,
            "splits": out}


def save(data: dict, path=STUDY_FILE) -> None:
    """Write the study as JSON, one split per line."""
    save_rows(data, "splits", path)


def compare(runs_a, runs_b, seed: int = 22, n_boot: int = 4000, clusters=None) -> dict:
    """Paired comparison of two variants' held-out ATEs (same runs, in the same order).

    Returns how many runs ``a`` is better and worse on, the median of the ratios
    ``a / b`` and its 90 % bootstrap interval (seeded). The bootstrap resamples
    whole **clusters** with replacement (``clusters``: one label per run, e.g. the
    robot, so that a robot's runs on several splits are drawn together: they are
    not independent); without ``clusters`` every run is its own cluster.
    """
    a, b = np.asarray(runs_a, dtype=float), np.asarray(runs_b, dtype=float)
    if a.shape != b.shape or a.ndim != 1 or a.size == 0:
        raise ValueError(f"runs_a, runs_b: expected two equal-length lists, got {a.shape} and "
                         f"{b.shape}")
    lab = np.arange(a.size) if clusters is None else np.asarray(clusters)
    if lab.shape != a.shape:
        raise ValueError(f"clusters: expected one label per run ({a.size}), got {lab.shape}")
    lr = np.log(a / b)
    groups = [lr[lab == g] for g in dict.fromkeys(lab.tolist())]
    rng = np.random.default_rng(seed)
    draws = rng.integers(0, len(groups), (n_boot, len(groups)))
    boot = np.array([np.median(np.concatenate([groups[j] for j in d])) for d in draws])
    lo, hi = np.percentile(boot, [5.0, 95.0])
    return {"n": int(lr.size), "clusters": len(groups), "better": int(np.sum(lr < 0)),
            "worse": int(np.sum(lr > 0)), "ratio": float(np.exp(np.median(lr))),
            "low": float(np.exp(lo)), "high": float(np.exp(hi))}


class Study:
    """The stored held-out study, with the tables chapter 10 prints."""

    def __init__(self, data: dict):
        if data.get("format") != FORMAT:
            raise ValueError(f"data: expected format {FORMAT!r}, got {data.get('format')!r}")
        self.data = data

    @property
    def splits(self) -> list[str]:
        return list(self.data["splits"])

    def ate(self, split: str, variant: str, in_sample: bool = False) -> np.ndarray:
        """The ATE per robot of one variant on one split (held out unless ``in_sample``)."""
        s = self.data["splits"][split]
        return np.array((s["in_sample"] if in_sample else s["variants"])[variant]["ate"])

    def runs(self, variant: str, splits=None) -> np.ndarray:
        """The held-out ATEs of every robot and split, pooled (split by split, robot order)."""
        return np.concatenate([self.ate(s, variant) for s in (splits or self.splits)])

    def robots_of_runs(self, splits=None) -> np.ndarray:
        """The robot of each pooled run (:meth:`runs`' order): the bootstrap's clusters."""
        return np.concatenate([self.data["splits"][s]["robots"] for s in (splits or self.splits)])

    def compare(self, a: str, b: str, by: str = "robot", splits=None) -> dict:
        """:func:`compare` of variants ``a`` and ``b`` pooled over the splits, resampling
        whole robots (``by="robot"``, the default) or single runs (``by="run"``)."""
        if by not in ("robot", "run"):
            raise ValueError(f"by: expected 'robot' or 'run', got {by!r}")
        return compare(self.runs(a, splits), self.runs(b, splits),
                       clusters=self.robots_of_runs(splits) if by == "robot" else None)

    def ratios(self, a: str, b: str, splits=None) -> str:
        """The ratio ``ATE(a) / ATE(b)`` per robot (rows) and split (columns)."""
        splits = splits or self.splits
        robots = self.data["splits"][splits[0]]["robots"]
        lines = ["robot" + "".join(f"{s:>15s}" for s in splits)]
        for i, r in enumerate(robots):
            lines.append(f"{r:5d}" + "".join(f"{self.ate(s, a)[i] / self.ate(s, b)[i]:15.2f}"
                                             for s in splits))
        lines.append("median" + "".join(
            f"{np.median(self.ate(s, a) / self.ate(s, b)):14.2f} " for s in splits))
        return "\n".join(lines)

    def table(self, variants, splits=None) -> str:
        """Median held-out ATE per split, and robots better than the textbook noise."""
        splits = splits or self.splits
        head = f"{'median ATE (m)':26s}" + "".join(f"{s:>15s}" for s in splits)
        lines = [head]
        for v in variants:
            cells = []
            for s in splits:
                a = self.ate(s, v)
                better = int(np.sum(a < self.ate(s, "textbook")))
                cells.append(f"{np.median(a):6.2f} ({better}/{a.size})"
                             if v != "textbook" else f"{np.median(a):6.2f}      ")
            lines.append(f"{v:26s}" + "".join(f"{c:>15s}" for c in cells))
        return "\n".join(lines)


def load(path=STUDY_FILE) -> Study:
    """The stored study (``make mrclam-heldout MRCLAM=...`` writes it)."""
    return Study(load_stored(path, "mrclam-heldout MRCLAM=/path/to/MRCLAM_Dataset6"))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("full", help="the folder of a full download of MRCLAM_Dataset6")
    p.add_argument("--out", default=str(STUDY_FILE))
    a = p.parse_args(argv)
    if not Path(a.full).is_dir():
        raise SystemExit(f"{a.full}: not a folder (the full MRCLAM_Dataset6 download)")
    data = study(a.full)
    save(data, a.out)
    s = Study(data)
    print(s.table(list(VARIANTS)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
