"""Regenerate chapter 06's stored Monte-Carlo studies (``data/studies/ch06_consistency.json``).

Usage:
    python tools/make_studies.py [--workers 2]          # rewrite the file
    python tools/make_studies.py --check [--workers 2]  # exit 1 if it would change

Each study of ``slamlib.course.studies_ch06.CH06_STUDIES`` is run over the seeds
``CH06_SEEDS`` (100 seeded runs); the same code gives the same bytes, whatever
the number of workers (``tests/test_studies_store.py`` recomputes a sample).
Chapter 06 loads the file: its 100-seed tables would take minutes to run live.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from slamlib.course.stored import write_or_check
from slamlib.course.studies_ch06 import CH06_SEEDS, CH06_STUDIES, run_study, summarise

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "data" / "studies" / "ch06_consistency.json"


def build(workers: int) -> str:
    studies = {}
    for key, (scenario, sigma, q, gate, _methods) in CH06_STUDIES.items():
        t0 = time.perf_counter()
        res = run_study(key, CH06_SEEDS, workers=workers)
        studies[key] = {"scenario": scenario, "sigma_wheel": sigma, "Q": q, "gate": gate,
                        "methods": {m: summarise(s) for m, s in res.items()}}
        print(f"{key}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    doc = {"format": "slamlib-studies/1", "seeds": list(CH06_SEEDS),
           "made_by": "tools/make_studies.py (make studies)", "studies": studies}
    return json.dumps(doc, indent=1) + "\n"


def main(argv: list[str]) -> int:
    return write_or_check(OUT, build, argv, "the stored studies")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
