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

import sys

from slamlib.course.evidence import main

if __name__ == "__main__":
    sys.exit(main(description=__doc__.splitlines()[0]))
