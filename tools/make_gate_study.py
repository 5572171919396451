"""Regenerate chapter 06's stored study of the gate's readings (``data/studies/ch06_gate.json``).

Usage:
    python tools/make_gate_study.py [--workers 2]          # rewrite the file
    python tools/make_gate_study.py --check [--workers 2]  # exit 1 if it would change

Every reading of a mapped marker on the arena loop, for EKF SLAM, FEJ and the two
ideal filters at the slips of ``slamlib.course.studies_ch06.GATE_STUDY``, over the
seeds ``CH06_SEEDS`` (about 3 minutes on 2 cores); the same bytes whatever the
number of workers (``tests/test_studies_ch06_gate.py`` recomputes a sample).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from slamlib.course.stored import write_or_check
from slamlib.course.studies_ch06 import CH06_SEEDS, GATE_METHODS, GATE_STUDY, run_gate_study

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "data" / "studies" / "ch06_gate.json"


def build(workers: int) -> str:
    t0 = time.perf_counter()
    runs = run_gate_study(CH06_SEEDS, workers=workers)
    print(f"gate study: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    doc = {"format": "slamlib-gate-study/1", "seeds": list(CH06_SEEDS),
           "made_by": "tools/make_gate_study.py (make gate-study)",
           "study": {**GATE_STUDY, "sigmas": list(GATE_STUDY["sigmas"]),
                     "methods": list(GATE_METHODS)},
           "runs": runs}
    return json.dumps(doc, indent=1) + "\n"


def main(argv: list[str]) -> int:
    return write_or_check(OUT, build, argv, "the stored gate study")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
