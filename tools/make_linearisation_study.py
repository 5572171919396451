"""Regenerate chapter 06's one-factor ablation of EKF SLAM's linearisation points
(``data/studies/ch06_linearisation.json``).

Usage:
    python tools/make_linearisation_study.py [--workers 2]          # rewrite the file
    python tools/make_linearisation_study.py --check [--workers 2]  # exit 1 if it would change

Every filter of ``slamlib.course.linearisation_study.METHODS`` (and the ungated
ones of ``UNGATED``) on the 100 seeds of ``STUDY`` at each slip (about 25 minutes
on 2 cores); the same bytes whatever the number of workers
(``tests/test_linearisation_study.py`` recomputes a sample). One line per run.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from slamlib.course.linearisation_study import INSTANTS, LABELS, METHODS, STUDY, UNGATED, run_study
from slamlib.course.stored import write_or_check

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "data" / "studies" / "ch06_linearisation.json"


def dumps(obj, indent: int = 0) -> str:
    """JSON with one line per run (a dict with a "seed") and per list of numbers."""
    pad = " " * (indent + 1)
    if isinstance(obj, dict) and "seed" not in obj:
        items = [f"{pad}{json.dumps(k)}: {dumps(v, indent + 1)}" for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + " " * indent + "}"
    if isinstance(obj, list) and obj and isinstance(obj[0], dict):
        rows = ",\n".join(pad + dumps(v, indent + 1) for v in obj)
        return "[\n" + rows + "\n" + " " * indent + "]"
    return json.dumps(obj)


def build(workers: int) -> str:
    t0 = time.perf_counter()
    studies = run_study(STUDY["seeds"], workers=workers)
    print(f"linearisation study: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    doc = {"format": "slamlib-linearisation-study/1", "seeds": list(STUDY["seeds"]),
           "made_by": "tools/make_linearisation_study.py (make linearisation-study)",
           "scenario": STUDY["scenario"], "gate": STUDY["gate"], "step": STUDY["step"],
           "t_end": STUDY["t_end"], "instants": list(INSTANTS),
           "methods": {m: {"links": links, "label": LABELS[m]} for m, links in METHODS.items()},
           "ungated": list(UNGATED), "studies": studies}
    return dumps(doc) + "\n"


def main(argv: list[str]) -> int:
    return write_or_check(OUT, build, argv, "the stored linearisation study")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
