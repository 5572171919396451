"""Input checks shared by the whole library.

Every public function of ``slamlib`` checks what it is given with these helpers,
so that bad input fails early with a ``ValueError`` that names the argument and
says what was expected, instead of a NaN three chapters later.
"""

from __future__ import annotations

import json
import math
import numbers
import re
from collections.abc import Mapping

import numpy as np

from .compiled import compiled

__all__ = ["as_vector", "as_matrix", "as_covariance", "as_positive", "as_finite_scalar", "as_seed",
           "read_text_file", "read_json_file", "as_marker_ids", "ID_MAX", "as_readings",
           "count_readings", "as_reading_covariances", "as_landmark_map", "integer_at_least",
           "Checked"]


#: Where a number is expected these are refused, not converted: ``float("0.1")`` and
#: ``float(True)`` work, which would let a typo or a flag pass as a number.
_NOT_NUMBERS = (bool, np.bool_, str, bytes)


def _first_non_number(value):
    """The first bool or string in a (nested) list or tuple, or None."""
    stack = [value]
    while stack:
        v = stack.pop()
        if isinstance(v, (list, tuple)):
            stack.extend(reversed(v))
        elif isinstance(v, _NOT_NUMBERS):
            return v
    return None


def _describe(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return f"the bool {bool(v)}"
    return f"the string {v!r}"


def _array(name: str, value, what: str) -> np.ndarray:
    """``np.asarray(value)`` unconverted, after refusing a bool or a string, alone or in a
    (nested) list, which numpy would turn into a number (``[True, 7]`` -> ``[1, 7]``)."""
    if isinstance(value, _NOT_NUMBERS):
        raise ValueError(f"{name}: expected {what}, got {_describe(value)}")
    if not isinstance(value, np.ndarray):
        bad = _first_non_number(value)
        if bad is not None:
            raise ValueError(f"{name}: expected {what}, got {_describe(bad)} in {value!r}")
    try:
        return np.asarray(value)
    except (TypeError, ValueError) as exc:       # ragged input
        raise ValueError(f"{name}: expected {what}, got {value!r}") from exc


def _numbers(name: str, value, what: str) -> np.ndarray:
    """``value`` as an array of numbers (any shape), refusing bools, strings and objects
    that are not real numbers, before any conversion."""
    arr = _array(name, value, what)
    kind = arr.dtype.kind
    if kind in "iuf":
        return arr
    if kind == "b":
        raise ValueError(f"{name}: expected {what}, got booleans (dtype bool)")
    if kind in "USa":
        raise ValueError(f"{name}: expected {what}, got strings (dtype {arr.dtype})")
    if kind == "O":
        for v in arr.flat:
            if isinstance(v, _NOT_NUMBERS) or not isinstance(v, numbers.Real):
                raise ValueError(f"{name}: expected {what}, got {v!r} "
                                 f"({type(v).__name__}) in it")
        return arr
    raise ValueError(f"{name}: expected {what}, got dtype {arr.dtype}")


def as_vector(name: str, value, size: int | None = None) -> np.ndarray:
    """Return ``value`` as a finite 1-D float array, checking its length.

    Parameters
    ----------
    name : str
        The argument's name, used in the error message.
    value : array_like
        The input.
    size : int, optional
        The expected length; any length if None.

    Raises
    ------
    ValueError
        If the shape is wrong, an entry is NaN or infinite, or is not a number (a
        string or a bool is refused, not converted).
    """
    if type(value) is not np.ndarray or value.dtype.kind not in "fiu":   # fast path: numbers
        value = _numbers(name, value, "an array of numbers")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{name}: expected an array of numbers, got {value!r}") from exc
    if arr.ndim != 1 or (size is not None and arr.shape[0] != size):
        want = f"({size},)" if size is not None else "(n,)"
        raise ValueError(f"{name}: expected shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite numbers, got {arr} (NaN or inf)")
    return arr


def as_matrix(name: str, value, shape: tuple[int | None, int | None]) -> np.ndarray:
    """Return ``value`` as a finite 2-D float array of the given shape (None: any); strings
    and bools are refused, not converted."""
    if type(value) is not np.ndarray or value.dtype.kind not in "fiu":
        value = _numbers(name, value, "a matrix of numbers")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{name}: expected a matrix of numbers, got {value!r}") from exc
    ok = arr.ndim == 2 and all(w is None or w == s for w, s in zip(shape, arr.shape))
    if not ok:
        want = "(" + ", ".join("n" if w is None else str(w) for w in shape) + ")"
        raise ValueError(f"{name}: expected shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite numbers (NaN or inf found)")
    return arr


def as_covariance(name: str, value, size: int | None = None, *, semidefinite: bool = False
                  ) -> np.ndarray:
    """Return ``value`` as a symmetric positive-definite matrix (a copy).

    Parameters
    ----------
    name : str
        The argument's name, used in the error message.
    value : array_like
        A square matrix.
    size : int, optional
        Its expected order.
    semidefinite : bool
        Accept a positive *semi*-definite matrix (for instance a noise
        covariance with a zero variance).

    Raises
    ------
    ValueError
        If it is not square of the right size, not finite, not symmetric (to a
        relative 1e-9) or not positive (semi-)definite.
    """
    if (size == 2 and type(value) is np.ndarray and value.dtype == np.float64
            and value.shape == (2, 2) and not semidefinite):
        a, b, c, d = value.ravel().tolist()              # the usual 2x2 (Q or R of a step)
        scale = max(1.0, abs(a), abs(b), abs(c), abs(d))
        s = 0.5 * (b + c)                                # the symmetrised off-diagonal
        if (math.isfinite(a + b + c + d) and abs(b - c) <= 1e-9 * scale and a > 0.0
                and a * d - s * s > 1e-9 * a * d):       # clearly positive definite
            return 0.5 * (value + value.T)
    arr = as_matrix(name, value, (size, size))
    if arr.shape[0] != arr.shape[1]:
        raise ValueError(f"{name}: expected a square matrix, got shape {arr.shape}")
    scale = max(1.0, float(np.max(np.abs(arr)))) if arr.size else 1.0
    if not np.allclose(arr, arr.T, rtol=0.0, atol=1e-9 * scale):
        raise ValueError(f"{name}: expected a symmetric matrix")
    arr = 0.5 * (arr + arr.T)
    if semidefinite:
        if arr.size and np.min(np.linalg.eigvalsh(arr)) < -1e-12 * scale:
            raise ValueError(f"{name}: expected a positive semi-definite matrix")
    else:
        try:
            np.linalg.cholesky(arr)
        except np.linalg.LinAlgError as exc:
            raise ValueError(f"{name}: expected a positive-definite matrix") from exc
    return arr


def as_positive(name: str, value) -> float:
    """Return ``value`` as a finite float > 0, or raise a ValueError naming it."""
    v = as_finite_scalar(name, value)
    if v <= 0.0:
        raise ValueError(f"{name}: expected a positive number, got {v}")
    return v


def as_seed(name: str, value) -> int:
    """A random seed: a non-negative integer (a float, such as 1.7, or a bool is refused:
    ``int(1.7) == int(1.2)`` would make two runs the same)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral,
                                                                     np.integer)):
        raise ValueError(f"{name}: expected a non-negative integer seed, got {value!r}")
    if value < 0:
        raise ValueError(f"{name}: expected a non-negative integer seed, got {value}")
    return int(value)


def as_finite_scalar(name: str, value) -> float:
    """Return ``value`` as a finite float, or raise a ValueError naming it.

    A string (``"0.1"``), a bool or an array of more than a number is refused, not
    converted.
    """
    if isinstance(value, _NOT_NUMBERS):
        raise ValueError(f"{name}: expected a number, got {_describe(value)}")
    if isinstance(value, np.ndarray) and (value.ndim != 0 or value.dtype.kind not in "iuf"):
        raise ValueError(f"{name}: expected a number, got an array {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected a number, got {value!r}") from exc
    if not np.isfinite(v):
        raise ValueError(f"{name}: expected a finite number, got {v}")
    return v


def read_text_file(path, error=ValueError) -> str:
    """A data file's text, decoded as UTF-8; ``error`` names the file and where it is wrong.

    Parameters
    ----------
    path : str or Path
        The file.
    error : ValueError subclass, or a callable making one from a message
        What to raise (the caller's format error).

    Raises
    ------
    error
        For a missing file, a UTF-8 byte-order mark (the course's files have none, and
        OpenCV and the CSV headers would stumble on it) or bytes that are not UTF-8, with
        their line and column.
    """
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise error(f"{p}: missing file")
    raw = p.read_bytes()
    if raw.startswith(b"\xef\xbb\xbf"):
        raise error(f"{p}: line 1: starts with a UTF-8 byte-order mark (BOM); save the file "
                    f"as UTF-8 without one")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise error(f"{p}: line {line}, column {column}: not valid UTF-8 (byte "
                    f"0x{raw[exc.start]:02x})") from None


def _line_of(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def _deepest(text: str) -> tuple[int, int]:
    """``(line, depth)`` of the deepest ``[`` or ``{`` of a JSON text (strings skipped)."""
    depth = best = where = 0
    in_str = esc = False
    for i, ch in enumerate(text):
        if in_str:
            if esc:
                esc = False
            elif ch == "\\":
                esc = True
            elif ch == '"':
                in_str = False
        elif ch == '"':
            in_str = True
        elif ch in "[{":
            depth += 1
            if depth > best:
                best, where = depth, i
        elif ch in "]}":
            depth -= 1
    return _line_of(text, where), best


def read_json_file(path, error: type[ValueError] = ValueError, folder=None):
    """Read a JSON data file; a malformed one raises ``error`` naming the file and line.

    Parameters
    ----------
    path : str or Path
        The file. A bare name (no folder) that does not exist here is looked up
        in ``folder``, with ``.json`` added if it has no suffix.
    error : ValueError subclass
        What to raise (the caller's format error).
    folder : Path, optional
        Where bare names live (``data/worlds``, ``data/calibration``...).

    Returns
    -------
    (object, Path)
        The parsed JSON and the path it was read from.

    Raises
    ------
    error
        Besides invalid JSON: a missing or empty file, bytes that are not UTF-8
        (:func:`read_text_file`), nesting too deep for the parser and integers
        longer than Python converts (4300 digits), each with its line.
    """
    from pathlib import Path

    p = Path(path)
    if folder is not None and not p.exists() and not p.is_absolute() and len(p.parts) == 1:
        p = Path(folder) / (p.name if p.suffix else p.name + ".json")
    text = read_text_file(p, error)
    if not text.strip():
        raise error(f"{p}: line 1: empty file, expected JSON")
    try:
        return json.loads(text), p
    except json.JSONDecodeError as exc:
        raise error(f"{p}: line {exc.lineno}: not valid JSON ({exc.msg})") from None
    except RecursionError:
        line, depth = _deepest(text)
        raise error(f"{p}: line {line}: JSON nested {depth} levels deep, too deep to "
                    f"read") from None
    except ValueError as exc:                 # an integer beyond int()'s limit of digits
        m = re.search(r"\d{1000,}", text)
        where = f"line {_line_of(text, m.start())}: " if m else ""
        digits = f"an integer of {len(m.group())} digits" if m else "a number"
        raise error(f"{p}: {where}{digits}, too long to read ({str(exc).split(':')[0]})"
                    ) from None


# --------------------------------------------------------------------------- the filters' inputs
# What every filter's update checks (slamlib.ekf, slamlib.confirmation, the runners).

def count_readings(z) -> int:
    """Number of rows of z (readings without ids), for :func:`as_readings`."""
    if type(z) is not np.ndarray or z.dtype.kind not in "fiu":
        z = _numbers("z", z, "a (k, 2) array of [range, bearing]")
    try:
        a = np.asarray(z, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"z: expected a (k, 2) array of [range, bearing], got {z!r}") from exc
    if a.ndim == 2:
        return a.shape[0]
    if a.shape == (2,):
        return 1
    if a.size == 0:
        return 0
    raise ValueError(f"z: expected shape (k, 2), got {a.shape}")


#: Marker ids are non-negative int64 (``report.matched`` uses -1 for "rejected").
ID_MAX = 2**63 - 1
#: Above this a float no longer holds every integer: 2**53 + 1 reads as 2**53.
_FLOAT_ID_MAX = 2**53


def as_marker_ids(ids) -> np.ndarray:
    """Marker ids as an int64 array (k,): integers in 0..2**63-1, or floats with integer
    values up to 2**53.

    Refused with a ValueError naming ``ids``: ids beyond int64 (they would wrap around),
    negative ids (``report.matched`` uses -1 for a rejected reading), floats that are not
    integers or are beyond 2**53, bools and strings (also inside a list). ``None``
    (readings without ids) raises, saying which filters take it.
    """
    if type(ids) is np.ndarray and ids.dtype == np.int64 and ids.ndim == 1 and (
            min(ids.tolist(), default=0) >= 0):
        return ids.copy()                   # the usual case: non-negative int64 ids
    if ids is None:
        raise ValueError("ids: None (readings without ids) needs a filter built with "
                         "association='nn' or association='jcbb'; this one has "
                         "association='ids': pass the marker ids, update(ids, z)")
    what = "integer marker ids"
    a = _array("ids", ids, f"a 1-D array of {what}")
    if a.ndim == 0:
        raise ValueError(f"ids: expected a 1-D array of {what}, got the scalar {ids!r}")
    if a.ndim != 1:
        raise ValueError(f"ids: expected shape (k,), got {a.shape}")
    if a.size == 0:
        return np.zeros(0, dtype=np.int64)
    kind = a.dtype.kind
    if kind == "O":                         # Python ints beyond uint64, or mixed objects
        for v in a:
            _check_id_object(v)
        a = np.array([int(v) for v in a], dtype=np.int64)
    elif kind == "b":
        raise ValueError(f"ids: expected {what}, got booleans (dtype bool)")
    elif kind == "u" and int(a.max()) > ID_MAX:
        raise ValueError(f"ids: expected marker ids in 0..2**63-1 (int64), got {int(a.max())}")
    elif kind == "f":
        if not np.all(np.isfinite(a)):
            raise ValueError(f"ids: expected finite {what}, got {a} (NaN or inf)")
        if not np.all(a == np.round(a)):
            raise ValueError(f"ids: expected {what}, got {a}")
        big = np.abs(a) > _FLOAT_ID_MAX
        if big.any():
            v = float(a[big][0])
            if abs(v) > ID_MAX:
                raise ValueError(f"ids: expected marker ids in 0..2**63-1 (int64), got the "
                                 f"float {v!r}")
            raise ValueError(f"ids: expected {what}; the float {v!r} is beyond 2**53, where a "
                             f"float no longer holds every integer: pass the ids as integers")
    elif kind not in "iu":
        raise ValueError(f"ids: expected {what}, got dtype {a.dtype}")
    a = a.astype(np.int64)
    if (a < 0).any():
        raise ValueError(f"ids: expected non-negative marker ids, got {int(a[a < 0][0])} "
                         f"(report.matched uses -1 for a rejected reading)")
    return a


def _check_id_object(v) -> None:
    """One id of an object array (:func:`as_marker_ids`)."""
    if isinstance(v, _NOT_NUMBERS):
        raise ValueError(f"ids: expected integer marker ids, got {_describe(v)}")
    if isinstance(v, (numbers.Integral, np.integer)):
        if not 0 <= int(v) <= ID_MAX:
            raise ValueError(f"ids: expected marker ids in 0..2**63-1 (int64), got {int(v)}"
                             if int(v) > 0 else
                             f"ids: expected non-negative marker ids, got {int(v)} "
                             f"(report.matched uses -1 for a rejected reading)")
        return
    if isinstance(v, numbers.Real) and float(v).is_integer() and abs(v) <= _FLOAT_ID_MAX:
        return
    raise ValueError(f"ids: expected integer marker ids, got {v!r} ({type(v).__name__})")


def as_readings(z, k: int) -> np.ndarray:
    """Readings ``[range, bearing]`` as a finite float array (k, 2) with ranges >= 0."""
    if type(z) is not np.ndarray or z.dtype.kind not in "fiu":
        z = _numbers("z", z, "a (k, 2) array of [range, bearing]")
    try:
        a = np.asarray(z, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"z: expected a (k, 2) array of [range, bearing], got {z!r}") from exc
    if k == 0 and a.size == 0:
        return np.zeros((0, 2))
    if a.ndim == 1 and a.shape == (2,) and k == 1:
        a = a.reshape(1, 2)
    if a.shape != (k, 2):
        raise ValueError(f"z: expected shape ({k}, 2) for {k} ids, got {a.shape}")
    not_finite, negative = _first_bad_readings(a)
    if not_finite >= 0:
        raise ValueError(f"z: expected finite readings, row {not_finite} is {a[not_finite]} "
                         f"(NaN or inf)")
    if negative >= 0:
        raise ValueError(f"z: expected non-negative ranges z[:, 0], row {negative} has range "
                         f"{a[negative, 0]}")
    return a


@compiled
def _first_bad_readings(a: np.ndarray) -> tuple[int, int]:
    """The first row of readings (k, 2) that is not finite, and the first with a negative
    range (-1: none)."""
    not_finite, negative = -1, -1
    for i in range(a.shape[0]):
        if not_finite < 0 and not (math.isfinite(a[i, 0]) and math.isfinite(a[i, 1])):
            not_finite = i
        if negative < 0 and a[i, 0] < 0.0:
            negative = i
    return not_finite, negative


def as_reading_covariances(R, default: np.ndarray, k: int) -> np.ndarray:
    """R as a new array (k, 2, 2): one matrix for all readings or one per reading, each
    checked."""
    if R is None:
        return np.broadcast_to(default, (k, 2, 2)).copy()
    if type(R) is not np.ndarray or R.dtype.kind not in "fiu":
        R = _numbers("R", R, f"a (2, 2) or ({k}, 2, 2) array of numbers")
    try:
        a = np.asarray(R, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"R: expected a (2, 2) or ({k}, 2, 2) array, got {R!r}") from exc
    if a.ndim == 2:
        return np.broadcast_to(as_covariance("R", a, 2), (k, 2, 2)).copy()
    if a.ndim != 3 or a.shape != (k, 2, 2):
        raise ValueError(f"R: expected shape (2, 2) or ({k}, 2, 2) for {k} readings, "
                         f"got {a.shape}")
    i = _first_bad_covariance(a)             # k 2x2 matrices, one per reading, every frame
    if i >= 0:
        as_covariance(f"R[{i}]", a[i], 2)     # raises with the precise reason
        raise ValueError(f"R[{i}]: expected a positive-definite matrix")  # pragma: no cover
    return 0.5 * (a + a.transpose(0, 2, 1))


@compiled
def _first_bad_covariance(a: np.ndarray) -> int:
    """The first of k 2x2 matrices (k, 2, 2) that is not finite, symmetric (to 1e-9 of its
    largest entry, at least 1) and, symmetrised, positive definite, or -1 (:func:`as_covariance`'s
    checks: its Cholesky of ``(m + m') / 2`` exists when ``m00 > 0`` and ``m00 m11 - s^2 > 0``)."""
    for i in range(a.shape[0]):
        m = a[i]
        if not np.isfinite(m).all():
            return i
        scale = max(1.0, np.abs(m).max())
        s = 0.5 * (m[0, 1] + m[1, 0])                       # the symmetrised off-diagonal
        if not (abs(m[0, 1] - m[1, 0]) <= 1e-9 * scale and m[0, 0] > 0.0
                and m[0, 0] * m[1, 1] - s * s > 0.0):
            return i
    return -1


def as_landmark_map(landmarks) -> dict[int, np.ndarray]:
    """A known map ``{marker id: (2,)}``: integer keys, finite positions (copies)."""
    if not isinstance(landmarks, Mapping):
        raise ValueError("landmarks: expected a dict {marker id: (x, y)}, got "
                         f"{type(landmarks).__name__}")
    out: dict[int, np.ndarray] = {}
    for key, pos in landmarks.items():
        if isinstance(key, (bool, np.bool_)) or not isinstance(key, (numbers.Integral,
                                                                       np.integer)):
            raise ValueError(f"landmarks: expected integer marker ids as keys, got {key!r}")
        k = int(key)
        if not 0 <= k <= ID_MAX:
            raise ValueError(f"landmarks: expected marker ids in 0..2**63-1 as keys, got {k}")
        if k in out:
            raise ValueError(f"landmarks: duplicate marker id {k}")
        out[k] = as_vector(f"landmarks[{k}]", pos, 2).copy()
    return out


def integer_at_least(name: str, value, minimum: int) -> int:
    """``value`` as an int >= ``minimum`` (not a bool), or a ValueError naming it."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (numbers.Integral, np.integer)) or value < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    return int(value)


class Checked:
    """A filter's parameter, checked whenever it is set; a checked array is
    stored read-only, so that it cannot be changed behind the check."""

    def __init__(self, check, doc: str):
        self.check, self.__doc__ = check, doc

    def __set_name__(self, owner, name: str) -> None:
        self.name = "_" + name

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        value = getattr(obj, self.name)
        if isinstance(value, np.ndarray):               # (a copy of the filter is frozen too)
            value.flags.writeable = False
        return value

    def __set__(self, obj, value) -> None:
        value = self.check(value)
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
        setattr(obj, self.name, value)
