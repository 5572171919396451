"""Landmarks that must be confirmed before they enter the map (chapter 05).

A chi-square gate judges a reading against the landmark it claims to be, so it
cannot judge the *first* reading of an id: there is nothing to compare with.
When that first reading is a misread id, plain EKF SLAM creates the landmark in
the wrong place, and the gate then rejects every true reading of it for the
rest of the run. A misread is a one-off, while a real marker stays in view for
many frames; so :class:`ConfirmedSLAM` holds a new id back as a *candidate*
(its position from the inverse observation, with covariance
``J1 P_rr J1^T + J2 R J2^T``) and adds it to the state only after
``n_confirm`` consistent sightings, each at most ``max_gap`` frames after the
previous one. Two sightings are consistent when the squared Mahalanobis
distance of their positions, ``(m2 - m1)^T (C1 + C2)^-1 (m2 - m1)``, is below
``chi2.ppf(confirm, 2)``. (Adding ``C1 + C2`` ignores that both positions share
the pose's error, so the test is somewhat lenient.)

Readings of mapped ids go through :meth:`EKFSLAM.update` unchanged (gate
against the prior, one joint update); a confirmed id is then added by
:meth:`EKFSLAM.update` from the updated pose and the confirming reading, as
plain EKF SLAM would have added it. A held reading gets the status
``"candidate"``.

Without ids (``association="nn"`` or ``"jcbb"``, ``update(None, z)``, chapter
09) the same idea keeps clutter out of the map: a reading outside every
landmark's gate is compared with the candidates of the last ``max_gap`` frames
(same test as above; the closest consistent one, each candidate at most once
per frame); it confirms that candidate, or starts a new one. A confirmed
candidate enters the map under a name the filter gives (``max(ids) + 1``).
Candidates not seen again within ``max_gap`` frames are dropped: a one-off
clutter reading never enters the map.
"""

from __future__ import annotations

import dataclasses
import numbers

import numpy as np

from . import runner as ex
from .ekf import EKFSLAM, UpdateReport, gate_threshold
from .metrics import mahalanobis2
from .models import KOBUKI_WHEEL_BASE, inverse_observation_jacobians, inverse_observe
from .runs import Run
from .validate import as_marker_ids, as_reading_covariances, as_readings

__all__ = ["Candidate", "ConfirmedSLAM", "confirmed_slam"]


@dataclasses.dataclass(frozen=True)
class Candidate:
    """An id seen but not yet in the map.

    Attributes
    ----------
    position : numpy.ndarray (2,)
        Its position from the last sighting (inverse observation from the pose then).
    cov : numpy.ndarray (2, 2)
        That position's covariance ``J1 P_rr J1^T + J2 R J2^T``.
    sightings : int
        Consistent sightings so far (1 after the first).
    frame : int
        The update call (1, 2, ...) of the last sighting.
    """

    position: np.ndarray
    cov: np.ndarray
    sightings: int
    frame: int


def _positive_int(name, value, minimum):
    integral = isinstance(value, (numbers.Integral, np.integer))
    if isinstance(value, (bool, np.bool_)) or not integral or value < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    return int(value)


class ConfirmedSLAM(EKFSLAM):
    """EKF SLAM in which a new id waits as a candidate until ``n_confirm`` consistent sightings.

    Parameters
    ----------
    x0, P0, Q, R, wheel_base, gate, capacity
        As for :class:`~slamlib.ekf.EKFSLAM`.
    n_confirm : int
        Sightings needed before an id is added (1 = plain EKF SLAM).
    max_gap : int
        A sighting counts towards the previous ones only if it comes at most
        this many update calls (camera frames) later; otherwise it starts again.
    confirm : float
        Probability of the chi-square test between two sightings' positions.
    """

    def __init__(self, x0, P0, Q, R, wheel_base: float = KOBUKI_WHEEL_BASE,
                 gate: float | None = 0.95, capacity: int = 16, *, n_confirm: int = 2,
                 max_gap: int = 2, confirm: float = 0.95, association: str = "ids"):
        super().__init__(x0, P0, Q, R, wheel_base=wheel_base, gate=gate, capacity=capacity,
                         association=association)
        self.n_confirm = _positive_int("n_confirm", n_confirm, 1)
        self.max_gap = _positive_int("max_gap", max_gap, 1)
        if not 0.0 < confirm < 1.0:
            raise ValueError(f"confirm: expected a probability in (0, 1), got {confirm!r}")
        self.confirm_threshold = gate_threshold(confirm)
        self.candidates: dict[int, Candidate] = {}
        self.frame = 0
        self._next_candidate = 0        # names of the candidates without ids
        if self.association != "ids":   # chapter 09: readings without ids
            self.update = self._update_anonymous

    def _update_anonymous(self, ids, z, R=None) -> UpdateReport:
        """``update(None, z)`` without ids (chapter 09): :meth:`EKFSLAM.update`'s association,
        and each reading far from every landmark goes to :meth:`_unmatched` (a candidate)."""
        frame = self.frame
        self.frame += 1
        try:
            return EKFSLAM.update(self, ids, z, R)
        except ValueError:
            self.frame = frame                                       # unchanged after an error
            raise

    def _sighting(self, pose, P_rr, z, R) -> tuple[np.ndarray, np.ndarray]:
        """Position of a sighting and its covariance ``J1 P_rr J1^T + J2 R J2^T`` (the same
        as in :meth:`update`, which chapter 05 prints and therefore keeps its own lines)."""
        m = inverse_observe(pose, z)
        J1, J2 = inverse_observation_jacobians(pose, z)
        return m, J1 @ P_rr @ J1.T + J2 @ R @ J2.T

    def _consistency(self, prev: Candidate, m, C) -> float:
        """``d2`` between a sighting and a candidate; inf when the candidate is too old."""
        if self.frame - prev.frame > self.max_gap:
            return float("inf")
        return float(mahalanobis2(m - prev.position, C + prev.cov))

    def _unmatched(self, readings, z, R):
        """Without ids: each reading outside every gate confirms a candidate or starts one."""
        for key in [c for c, prev in self.candidates.items()
                    if self.frame - prev.frame > self.max_gap]:
            del self.candidates[key]                                 # not seen again: dropped
        pose, P_rr = self.pose, self.pose_cov
        sightings = [self._sighting(pose, P_rr, z[i], R[i]) for i in readings]
        keys = [c for c, prev in self.candidates.items() if prev.frame < self.frame]
        # pairs (reading, candidate) that pass the test, closest first, each used once
        pairs = sorted((self._consistency(self.candidates[c], m, C), q, c)
                       for q, (m, C) in enumerate(sightings) for c in keys)
        match: dict[int, int] = {}
        taken = set()
        for d2, q, c in pairs:
            if d2 < self.confirm_threshold and q not in match and c not in taken:
                match[q] = c
                taken.add(c)
        out = []
        for q, i in enumerate(readings):
            m, C = sightings[q]
            n = 1
            if q in match:
                n = self.candidates.pop(match[q]).sightings + 1
            if n >= self.n_confirm:
                mid = max(self._ids) + 1 if self._ids else 0
                self._add_landmark(mid, z[i], R[i])
                out.append(("new", mid))
            else:
                self.candidates[self._next_candidate] = Candidate(m, C, n, self.frame)
                self._next_candidate += 1
                out.append(("candidate", None))
        return out

    def update(self, ids, z, R=None) -> UpdateReport:
        """:meth:`EKFSLAM.update` for mapped ids; new ids become candidates, then landmarks.

        The report has one entry per reading, in the order given: mapped ids as
        :meth:`EKFSLAM.update` reports them, ``"new"`` for an id confirmed (and
        added) by this reading, ``"candidate"`` for one held back, ``"duplicate"``
        for a second reading of an unmapped id in the same call.
        """
        ids = as_marker_ids(ids)                                           # the base class's checks
        z = as_readings(z, ids.shape[0])
        Rk = as_reading_covariances(R, self.R, ids.shape[0])
        self.frame += 1
        mapped = np.isin(ids, self.landmark_ids)
        first = super().update(ids[mapped], z[mapped], np.ascontiguousarray(Rk[mapped]))
        pose, P_rr = self.pose, self.pose_cov                       # after the joint update
        status = np.array(["candidate"] * len(ids), dtype=object)
        status[mapped] = first.status
        confirmed, seen = [], set()
        for i in np.flatnonzero(~mapped):
            mid = int(ids[i])
            if mid in seen:                                          # read twice in one frame
                status[i] = "duplicate"
                continue
            seen.add(mid)
            m = inverse_observe(pose, z[i])
            J1, J2 = inverse_observation_jacobians(pose, z[i])
            C = J1 @ P_rr @ J1.T + J2 @ Rk[i] @ J2.T
            n = 1
            prev = self.candidates.get(mid)
            if (prev is not None and self.frame - prev.frame <= self.max_gap
                    and mahalanobis2(m - prev.position, C + prev.cov) < self.confirm_threshold):
                n = prev.sightings + 1                               # consistent: one more
            if n >= self.n_confirm:
                confirmed.append(i)
                self.candidates.pop(mid, None)
            else:
                self.candidates[mid] = Candidate(m, C, n, self.frame)
        if confirmed:                                                # all unmapped: added
            super().update(ids[confirmed], z[confirmed], np.ascontiguousarray(Rk[confirmed]))
            status[confirmed] = "new"

        def spread(a, fill):                                         # back to the given order
            out = np.full((len(ids),) + a.shape[1:], fill, dtype=a.dtype)
            out[mapped] = a
            return out

        return dataclasses.replace(
            first, ids=ids, z=z, status=tuple(str(s) for s in status), new=status == "new",
            accepted=spread(first.accepted, False), d2=spread(first.d2, np.nan),
            innovation=spread(first.innovation, np.nan),
            predicted=spread(first.predicted, np.nan), S=spread(first.S, np.nan))


def confirmed_slam(run: Run, *, gate: float | None = 0.95, n_confirm: int = 2,
                   max_gap: int = 2, confirm: float = 0.95, Q=None, P0=ex.DEFAULT_P0,
                   by: str = "capture", until: float | None = None) -> ex.Trace:
    """:func:`slamlib.runner.slam` with :class:`ConfirmedSLAM` (chapter 05)."""
    filt = ex.make_filter(ConfirmedSLAM, run, Q=Q, P0=P0, gate=gate, n_confirm=n_confirm,
                          max_gap=max_gap, confirm=confirm)
    return ex.run_filter(run, filt, by=by, until=until)
