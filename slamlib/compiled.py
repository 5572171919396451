"""numba on the course's own functions: the same function compiled, never a second copy.

:func:`compiled` returns ``func`` compiled by numba; its ``py_func`` is ``func``
itself, the code a chapter prints with ``inspect.getsource``. The machine code is
cached beside the source when that folder (or numba's user cache) is writable;
otherwise it is compiled once per process (a read-only install and HOME). With
``NUMBA_DISABLE_JIT=1`` the same functions run as Python, with the same results for float
arrays: to the last bit where numpy's arithmetic is the C library's (numpy's AVX-512 code off,
as every make target sets it), except the joint update's, equal to rounding (numba's Cholesky
sums in another order; ``bench/README.md``).
"""

from __future__ import annotations

import re
import warnings
from functools import wraps
from pathlib import Path

import numba
import numpy as np
from numba.core.errors import NumbaPerformanceWarning

__all__ = ["compiled"]

# numba notes, once per compilation, that ``A @ P[r, m]`` on a block of P (not contiguous)
# copies the block first: that is the block product the chapters write. numba gives the
# source file as the warning's module, so the note is silenced for this package's files only.
warnings.filterwarnings("ignore", category=NumbaPerformanceWarning,
                        module=re.escape(str(Path(__file__).resolve().parent)) + r"[/\\]")


def compiled(func):
    """``func`` compiled by numba (``numba.njit``), cached where it can be. With
    ``NUMBA_DISABLE_JIT=1``, ``func`` itself with numpy's floating-point warnings off, as
    compiled code has none (an overflow the caller refuses is refused without a warning)."""
    if numba.config.DISABLE_JIT:
        @wraps(func)
        def as_python(*args):
            with np.errstate(all="ignore"):
                return func(*args)
        as_python.py_func = func
        return as_python
    try:
        return numba.njit(cache=True)(func)
    except RuntimeError:                     # numba: "cannot cache function ...: no locator"
        return numba.njit(func)
