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
ratios, a sign count and a seeded bootstrap interval of the median ratio).

The full data set is not shipped: ``make mrclam-heldout MRCLAM=/path/to/MRCLAM_Dataset6``
(``python -m slamlib.course.mrclam_heldout /path/to/MRCLAM_Dataset6``) writes
``data/studies/mrclam_heldout.json`` (6 significant digits, no timings: bit for
bit the same on every regeneration; about 20 minutes on one core);
``tests/test_mrclam_heldout.py`` recomputes the excerpt's split (and, with
``MRCLAM_DATASET6`` set to a download, a robot of the full data set).
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

from ..datasets import identify, mrclam
from ..worlds import DATA_DIR
from .stored import load_stored

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
}
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


def _judge(folder, robot: int, cal: identify.Calibration, span) -> float:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrclam.MRCLAMWarning)
        log = mrclam.load(folder, robot, calibration=cal)
    return float(mrclam.slam(log.between(*span)).metrics()["ate_xy"])


def run_split(split: str, folder, logs: dict, excerpt: dict | None = None,
              variants=tuple(VARIANTS), in_sample=IN_SAMPLE, robots=mrclam.ROBOTS) -> dict:
    """Every variant's held-out ATE per robot on one split (and the in-sample ones)."""
    fit, held = split_parts(split, logs, excerpt)
    rows: dict = {}
    for name in variants:
        comps, window = VARIANTS[name]
        ate, cals = [], {}
        for r in robots:
            cal = identify.identify(fit[r], comps, window=window)
            ate.append(_r(_judge(folder, r, cal, held[r])))
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
            "splits": out}


def save(data: dict, path=STUDY_FILE) -> None:
    """Write the study as JSON, one split per line."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    head = {k: v for k, v in data.items() if k != "splits"}
    lines = ["{"] + [f"{json.dumps(k)}: {json.dumps(v, separators=(',', ':'))}," for k, v in
                     head.items()] + ['"splits": {']
    items = list(data["splits"].items())
    for j, (k, v) in enumerate(items):
        lines.append(f"{json.dumps(k)}: {json.dumps(v, separators=(',', ':'))}"
                     + ("," if j < len(items) - 1 else ""))
    lines += ["}", "}"]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def compare(runs_a, runs_b, seed: int = 22, n_boot: int = 4000) -> dict:
    """Paired comparison of two variants' held-out ATEs (same runs, in the same order).

    Returns how many runs ``a`` is better and worse on, the median of the ratios
    ``a / b`` and its 90 % bootstrap interval (resampling the runs, seeded).
    """
    a, b = np.asarray(runs_a, dtype=float), np.asarray(runs_b, dtype=float)
    if a.shape != b.shape or a.ndim != 1 or a.size == 0:
        raise ValueError(f"runs_a, runs_b: expected two equal-length lists, got {a.shape} and "
                         f"{b.shape}")
    lr = np.log(a / b)
    rng = np.random.default_rng(seed)
    boot = np.median(lr[rng.integers(0, lr.size, (n_boot, lr.size))], axis=1)
    lo, hi = np.percentile(boot, [5.0, 95.0])
    return {"n": int(lr.size), "better": int(np.sum(lr < 0)), "worse": int(np.sum(lr > 0)),
            "ratio": float(np.exp(np.median(lr))), "low": float(np.exp(lo)),
            "high": float(np.exp(hi))}


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
