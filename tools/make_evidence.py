"""Regenerate the stored 100-seed studies in data/evidence, bit for bit.

Usage:
    python tools/make_evidence.py                    # every study of evidence.STUDIES
    python tools/make_evidence.py arena_slam         # one study
    python tools/make_evidence.py --workers 2 ...    # a process pool (the same numbers)
    python tools/make_evidence.py --check ...        # recompute in memory; exit 1 if a file differs

The chapters (02, 03, 05, 07) load these files instead of running the studies
live (a 100-seed study takes from one to fifteen minutes here);
tests/test_evidence.py recomputes a sample of seeds and compares exactly.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from slamlib.course.evidence import EVIDENCE_DIR, STUDIES, run_study, save_study


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("studies", nargs="*", default=sorted(STUDIES))
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args(argv)
    bad = 0
    for name in args.studies:
        t0 = time.perf_counter()
        study = run_study(name, workers=args.workers)
        dt = time.perf_counter() - t0
        path = EVIDENCE_DIR / f"{name}.json"
        if args.check:
            same = path.exists() and json.loads(path.read_text()) == study
            print(f"{name}: {'unchanged' if same else 'DIFFERS'} ({dt:.0f} s)")
            bad += not same
        else:
            print(f"{name}: wrote {save_study(study)} ({dt:.0f} s)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
