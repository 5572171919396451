"""Comparing a study record recomputed now with the stored one.

A stored study is regenerated bit for bit on the machine that wrote it (``make`` targets);
another CPU or BLAS may round the last bit of a sum differently. So a recomputed record
must make the same decisions (every int, bool, string and None equal: gated and rejected
counts, closure status, seeds) and give every float to ``rel`` (1e-6 by default: chapter 07's
closed-loop exploration of 180 s grows a last-bit difference to 2e-9): a change in the code
changes a decision or a float far beyond that.
"""

from __future__ import annotations

import json
import math

import numpy as np


def _plain(x):
    return x.tolist() if isinstance(x, (np.ndarray, np.generic)) else repr(x)


def assert_same_record(fresh, stored, where: str = "", rel: float = 1e-6,
                       abs_tol: float = 1e-12, count_rel: float = 0.0) -> None:
    """Assert that ``fresh`` equals ``stored`` exactly in structure and in every non-float,
    and to ``rel`` (relative) or ``abs_tol`` (absolute, for values near 0) in every float.
    Both are first written as JSON and read back, as a stored study is.

    ``count_rel`` > 0 lets an int (a count) differ by that fraction of itself: only for a
    closed-loop study, whose controller steers on the estimate, so that a last-bit difference
    moves the path (chapter 07's exploration: up to 3e-4 relative over 180 s when the
    arithmetic's order changed) and an instant or two may cross a 2-sigma bound.
    """
    fresh = json.loads(json.dumps(fresh, default=_plain))
    stored = json.loads(json.dumps(stored, default=_plain))
    _same(fresh, stored, where, rel, abs_tol, count_rel)


def _same(fresh, stored, where, rel, abs_tol, count_rel=0.0):
    if isinstance(stored, dict):
        assert isinstance(fresh, dict), f"{where}: expected a dict, got {fresh!r}"
        assert set(fresh) == set(stored), f"{where}: keys {sorted(fresh)} != {sorted(stored)}"
        for k in stored:
            _same(fresh[k], stored[k], f"{where}/{k}", rel, abs_tol, count_rel)
    elif isinstance(stored, (list, tuple)):
        assert isinstance(fresh, (list, tuple)), f"{where}: expected a list, got {fresh!r}"
        assert len(fresh) == len(stored), f"{where}: length {len(fresh)} != {len(stored)}"
        for i, (a, b) in enumerate(zip(fresh, stored)):
            _same(a, b, f"{where}[{i}]", rel, abs_tol, count_rel)
    elif isinstance(stored, float) or isinstance(fresh, float):
        assert isinstance(fresh, (int, float)) and not isinstance(fresh, bool), \
            f"{where}: expected a number, got {fresh!r}"
        if math.isnan(stored):
            assert math.isnan(fresh), f"{where}: {fresh!r} != nan"
        else:
            assert math.isclose(fresh, stored, rel_tol=rel, abs_tol=abs_tol), \
                f"{where}: {fresh!r} != {stored!r} (rel {rel})"
    elif count_rel > 0 and type(stored) is int and type(fresh) is int:
        assert abs(fresh - stored) <= count_rel * abs(stored), \
            f"{where}: {fresh!r} != {stored!r} (count rel {count_rel})"
    else:
        assert type(fresh) is type(stored) and fresh == stored, f"{where}: {fresh!r} != {stored!r}"
