"""Looking at an update without applying it (chapters 03 and 05).

A chapter often wants to see what one camera frame *would* do to a filter:
the predicted readings, the innovations, their covariances ``S_i``, the
squared Mahalanobis distances ``d2_i`` and the gate's verdict on each, while
the filter stays the prior it was. :func:`preview_update` computes exactly
what steps 1 and 2 of :meth:`slamlib.ekf.EKFSLAM.update` compute
(association by id, then each reading gated on its own against the prior),
from the filter's public pieces only, and changes nothing::

    h, H_pose, H_landmark = filt.reading_model(pose, positions)    # h(x) and H_i
    y_i  = z_i - h_i                   (bearing wrapped to [-pi, pi))
    S_i  = H_i P H_i^T + R_i           (from the 5x5 block of the pose and landmark i)
    d2_i = y_i^T S_i^-1 y_i,           accepted when d2_i < chi2.ppf(gate, 2)

It replaces ``copy.deepcopy(filt).update(ids, z)`` where only the gate's
numbers are wanted; ``tests/test_update_preview.py`` checks on random cases
that ``d2`` and the verdicts are those of a deep copy that is updated, to the
last bit.

It covers the filters whose gate is the one above: :class:`~slamlib.ekf.EKFLocalization`
and :class:`~slamlib.ekf.EKFSLAM` with ``association="ids"``, including
subclasses that only override the public hook ``reading_model`` (chapter 03's
filter with the report's sign error). Filters that linearise elsewhere
(:class:`~slamlib.ekf.FEJEKFSLAM`, :class:`~slamlib.ekf.IdealEKFSLAM`), that
hold new ids as candidates (:class:`~slamlib.confirmation.ConfirmedSLAM`) or
that pair readings without ids (chapter 09) are refused with a ValueError.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..confirmation import ConfirmedSLAM
from ..ekf import EKFSLAM, FEJEKFSLAM, EKFLocalization, IdealEKFSLAM
from ..models import wrap_angle
from ..validate import as_covariance
from .tables import format_table

__all__ = ["UpdatePreview", "preview_update"]


@dataclass(frozen=True)
class UpdatePreview:
    """What an update would do with each of k readings, before it is applied.

    The attributes have the names and meaning of :class:`slamlib.ekf.UpdateReport`'s
    (``status`` ``"accepted"`` means "would be fused"; ``"new"`` "would be added").

    Attributes
    ----------
    ids : numpy.ndarray of int, shape (k,)
    z : numpy.ndarray, shape (k, 2)
    status : tuple of str
        ``"accepted"``, ``"rejected"``, ``"new"``, ``"duplicate"``, ``"unknown"`` or
        ``"degenerate"`` per reading, as the update would report it.
    accepted, new : numpy.ndarray of bool, shape (k,)
    predicted, innovation : numpy.ndarray, shape (k, 2)
        ``h(x)`` and ``y = z - h(x)`` at the prior (bearing wrapped); NaN where not gated.
    S : numpy.ndarray, shape (k, 2, 2)
        Each gated reading's ``H_i P H_i^T + R_i``; NaN where not gated.
    d2 : numpy.ndarray, shape (k,)
        ``y^T S^-1 y``; NaN where not gated.
    threshold : float
        The gate on d2 (``inf`` without gating).
    gate : float or None
        The gate probability.
    """

    ids: np.ndarray
    z: np.ndarray
    status: tuple
    accepted: np.ndarray
    new: np.ndarray
    predicted: np.ndarray
    innovation: np.ndarray
    S: np.ndarray
    d2: np.ndarray
    threshold: float
    gate: float | None

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def rejected(self) -> np.ndarray:
        """True for the readings the gate would reject."""
        return np.array([s == "rejected" for s in self.status], dtype=bool)

    def table(self) -> str:
        """The readings, one line each: id, range, bearing, d2 and the verdict."""
        rows = [(int(i), z[0], z[1], d, s)
                for i, z, d, s in zip(self.ids, self.z, self.d2, self.status)]
        body = format_table(["id", "range", "bearing", "d2", "would be"], rows,
                            ["d", ".3f", "+.3f", ".3f", "s"])
        return f"gate {self.gate}  threshold {self.threshold:.3f}\n{body}"

    def __str__(self) -> str:
        return self.table()


def _check_filter(filt) -> None:
    if not isinstance(filt, (EKFLocalization, EKFSLAM)):
        raise ValueError(f"filt: expected an EKFLocalization or EKFSLAM, got "
                         f"{type(filt).__name__}")
    for cls, why in ((FEJEKFSLAM, "it linearises at the first estimates"),
                     (IdealEKFSLAM, "it linearises at the truth"),
                     (ConfirmedSLAM, "it holds new ids as candidates")):
        if isinstance(filt, cls):
            raise ValueError(f"filt: a {cls.__name__} gates differently ({why}); preview_update "
                             f"covers EKFLocalization and EKFSLAM")
    if filt.association != "ids":
        raise ValueError(f"filt: association={filt.association!r} pairs readings without ids; "
                         f"preview_update needs association='ids'")


def _check_ids(ids) -> np.ndarray:
    a = np.asarray(ids)
    if a.ndim != 1:
        raise ValueError(f"ids: expected a 1-D array of integer marker ids, got shape {a.shape}")
    if a.size == 0:
        return np.zeros(0, dtype=np.int64)
    if a.dtype == bool or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"ids: expected integer marker ids, got dtype {a.dtype}")
    return a.astype(np.int64)


def _check_z(z, k: int) -> np.ndarray:
    a = np.asarray(z, dtype=float)
    if k == 0 and a.size == 0:
        return np.zeros((0, 2))
    if a.shape == (2,) and k == 1:
        a = a.reshape(1, 2)
    if a.shape != (k, 2):
        raise ValueError(f"z: expected shape ({k}, 2) for {k} ids, got {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a[:, 0] < 0.0):
        raise ValueError("z: expected finite readings [range >= 0, bearing]")
    return a.copy()


def _check_R(R, default: np.ndarray, k: int) -> np.ndarray:
    """R as (k, 2, 2), symmetrised as the filter symmetrises it."""
    if R is None:
        return np.broadcast_to(default, (k, 2, 2))
    a = np.asarray(R, dtype=float)
    if a.ndim == 2:
        return np.broadcast_to(as_covariance("R", a, 2), (k, 2, 2))
    if a.shape != (k, 2, 2):
        raise ValueError(f"R: expected shape (2, 2) or ({k}, 2, 2) for {k} readings, "
                         f"got {a.shape}")
    for i in range(k):
        as_covariance(f"R[{i}]", a[i], 2)
    return 0.5 * (a + a.transpose(0, 2, 1))


def preview_update(filt, ids, z, R=None) -> UpdatePreview:
    """The gate's numbers for one frame, without changing the filter (chapters 03, 05).

    Parameters
    ----------
    filt : EKFLocalization or EKFSLAM
        The filter at the prior (after the prediction to the frame's time).
    ids : array_like of int, shape (k,)
    z : array_like, shape (k, 2)
        The readings ``[range, bearing]``.
    R : array_like, shape (2, 2) or (k, 2, 2), optional
        As for ``filt.update`` (the filter's own ``R`` if None).

    Returns
    -------
    UpdatePreview
        For every reading: status, predicted reading, innovation, S and d2 as
        ``filt.update(ids, z, R)`` would report them now. ``filt`` is unchanged.

    Raises
    ------
    ValueError
        For a filter that gates differently (see the module docstring) and for
        bad ids, z or R.
    """
    _check_filter(filt)
    ids = _check_ids(ids)
    k = ids.size
    z = _check_z(z, k)
    Rk = _check_R(R, filt.R, k)
    slam = isinstance(filt, EKFSLAM)
    known = set(filt.landmark_ids)
    mapped = filt.landmarks

    # step 1, association by id
    status = [""] * k
    gated: list[int] = []
    seen_new: set[int] = set()
    for i, mid in enumerate(int(m) for m in ids):
        if mid in known:
            gated.append(i)
        elif not slam:
            status[i] = "unknown"
        elif mid in seen_new:
            status[i] = "duplicate"
        else:
            seen_new.add(mid)
            status[i] = "new"

    predicted = np.full((k, 2), np.nan)
    innovation = np.full((k, 2), np.nan)
    S_all = np.full((k, 2, 2), np.nan)
    d2 = np.full(k, np.nan)
    accepted = np.zeros(k, dtype=bool)
    if gated:
        g = np.array(gated)
        positions = np.array([mapped[int(ids[i])] for i in g])
        h, Hp, Hl = filt.reading_model(filt.pose, positions)
        ok = np.isfinite(h[:, 1])
        for i in g[~ok]:
            status[i] = "degenerate"
        g, h, Hp, Hl = g[ok], h[ok], Hp[ok], Hl[ok]
        if g.size:
            # step 2, each reading on its own against the prior
            y = z[g] - h
            y[:, 1] = wrap_angle(y[:, 1])
            P = filt.P
            if slam:
                slots = np.array([filt.landmark_index(int(ids[i])) for i in g])
                idx = np.empty((g.size, 5), dtype=np.int64)
                idx[:, :3] = (0, 1, 2)
                idx[:, 3], idx[:, 4] = slots, slots + 1
                Hb = np.concatenate([Hp, Hl], axis=2)                   # H_i on its 5 columns
            else:
                idx = np.broadcast_to(np.arange(3), (g.size, 3))
                Hb = Hp                                                 # the map is exact
            Pb = P[idx[:, :, None], idx[:, None, :]]
            S = Hb @ Pb @ Hb.transpose(0, 2, 1) + np.ascontiguousarray(Rk[g])
            S = 0.5 * (S + S.transpose(0, 2, 1))
            d2g = np.einsum("ki,ki->k", y, np.linalg.solve(S, y[:, :, None])[:, :, 0])
            acc = np.ones(g.size, dtype=bool) if filt.gate is None else d2g < filt.threshold
            predicted[g], innovation[g], S_all[g], d2[g] = h, y, S, d2g
            accepted[g[acc]] = True
            for i, a in zip(g, acc):
                status[i] = "accepted" if a else "rejected"
    new = np.array([s == "new" for s in status], dtype=bool)
    return UpdatePreview(ids=ids, z=z, status=tuple(status), accepted=accepted, new=new,
                         predicted=predicted, innovation=innovation, S=S_all, d2=d2,
                         threshold=filt.threshold, gate=filt.gate)
