"""Input checks shared by the whole library.

Every public function of ``slamlib`` checks what it is given with these helpers,
so that bad input fails early with a ``ValueError`` that names the argument and
says what was expected, instead of a NaN three chapters later.
"""

from __future__ import annotations

import json

import numpy as np

__all__ = ["as_vector", "as_matrix", "as_covariance", "as_positive", "as_finite_scalar",
           "read_json_file"]


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
        If the shape is wrong or an entry is NaN or infinite.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected an array of numbers, got {value!r}") from exc
    if arr.ndim != 1 or (size is not None and arr.shape[0] != size):
        want = f"({size},)" if size is not None else "(n,)"
        raise ValueError(f"{name}: expected shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite numbers, got {arr} (NaN or inf)")
    return arr


def as_matrix(name: str, value, shape: tuple[int | None, int | None]) -> np.ndarray:
    """Return ``value`` as a finite 2-D float array of the given shape (None: any)."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
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


def as_finite_scalar(name: str, value) -> float:
    """Return ``value`` as a finite float, or raise a ValueError naming it."""
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected a number, got {value!r}") from exc
    if not np.isfinite(v):
        raise ValueError(f"{name}: expected a finite number, got {v}")
    return v


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
    """
    from pathlib import Path

    p = Path(path)
    if folder is not None and not p.exists() and not p.is_absolute() and len(p.parts) == 1:
        p = Path(folder) / (p.name if p.suffix else p.name + ".json")
    if not p.is_file():
        raise error(f"{p}: missing file")
    try:
        return json.loads(p.read_text(encoding="utf-8")), p
    except json.JSONDecodeError as exc:
        raise error(f"{p}: line {exc.lineno}: not valid JSON ({exc.msg})") from exc
