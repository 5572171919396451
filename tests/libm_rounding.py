"""Whether numpy's arctan2 rounds as the C library's atan2, which compiled code calls.

numpy's AVX-512 code (on machines that have it) rounds some arctangents differently in the
last bit; every make target turns it off (the Makefile's NPY_DISABLE_CPU_FEATURES), and then
the compiled steps and their Python give the same numbers to the last bit.
"""

import math

import numpy as np

_a = np.random.default_rng(0).uniform(-9.0, 9.0, (2, 4000))
#: True under make, or on a machine without AVX-512.
NUMPY_ROUNDS_AS_LIBM = bool(np.array_equal(np.arctan2(*_a),
                                           [math.atan2(p, q) for p, q in _a.T]))
WHY = ("numpy's AVX-512 arctan2 is on here: run under make (NPY_DISABLE_CPU_FEATURES) for "
       "the last-bit comparison with compiled code")
