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
against the prior, one joint update). After the joint update
``EKFSLAM._update_ids`` hands the readings of unmapped ids to the hook
:meth:`ConfirmedSLAM._admit`, which tests them against the candidates and
passes the confirmed ones to ``EKFSLAM._admit``: they are added from the
updated pose, as plain EKF SLAM would have added them (no second update). A
held reading gets the status ``"candidate"``; :meth:`ConfirmedSLAM.update`
only counts the frames.

Without ids (``association="nn"`` or ``"jcbb"``, ``update(None, z)``, chapter
09) the same idea keeps clutter out of the map: a reading outside every
landmark's gate is compared with the candidates of the last ``max_gap`` frames
(same test as above; the closest consistent one, each candidate at most once
per frame); it confirms that candidate, or starts a new one. A confirmed
candidate enters the map under a name the filter gives (``max(ids) + 1``).
With or without ids, candidates not seen again within ``max_gap`` frames are
dropped (at the next frame with a reading of no mapped landmark): a one-off
misread or clutter reading never enters the map, nor stays among the candidates.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from . import runner
from .ekf import (
    EKFSLAM,
    UpdateReport,
    _check_gate,
    gate_threshold,
    landmark_covariance,
)
from .metrics import mahalanobis2
from .models import KOBUKI_WHEEL_BASE
from .runs import Run
from .validate import Checked, integer_at_least

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


class ConfirmedSLAM(EKFSLAM):
    """EKF SLAM in which a new id waits as a candidate until ``n_confirm`` consistent sightings.

    Parameters
    ----------
    x0, P0, Q, R, wheel_base, gate, capacity, association
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
        self.n_confirm, self.max_gap = n_confirm, max_gap
        self.confirm_threshold = gate_threshold(_check_gate(confirm, "confirm", none=False))
        self.candidates: dict[int, Candidate] = {}
        self.frame = 0
        self._next_candidate = 0        # names of the candidates without ids

    n_confirm = Checked(lambda v: integer_at_least("n_confirm", v, 1),
                        "Sightings needed before an id is added (checked on set).")
    max_gap = Checked(lambda v: integer_at_least("max_gap", v, 1),
                      "Update calls a sighting may come after the previous one (checked on set).")

    def update(self, ids, z, R=None) -> UpdateReport:
        """:meth:`EKFSLAM.update`, in which a reading of no mapped landmark confirms a candidate
        (status ``"new"``: added, from the updated pose) or is held as one (``"candidate"``)."""
        self.frame += 1
        try:
            return super().update(ids, z, R)
        except ValueError:
            self.frame -= 1                                          # unchanged after an error
            raise

    def preview(self, ids, z, R=None) -> UpdateReport:
        raise ValueError("preview: ConfirmedSLAM holds new ids as candidates: apply update to "
                         "a copy instead")

    def _consistency(self, prev: Candidate, m, C) -> float:
        """``d2`` between a sighting and a candidate; inf when the candidate is too old."""
        if self.frame - prev.frame > self.max_gap:
            return float("inf")
        return float(mahalanobis2(m - prev.position, C + prev.cov))

    def _admit(self, ids, z, R):
        """Each reading of no mapped landmark, seen from the updated pose, confirms a candidate
        or starts one; the confirmed ones are added (:meth:`EKFSLAM._admit`) at the m, J1, J2
        computed here."""
        k = z.shape[0]
        m, J1, J2 = self.jacobians("initialisation", ids=np.full(k, -1) if ids is None else ids,
                                   z=z)
        C = [landmark_covariance(J1[q], self._P[:3, :3], J2[q], R[q]) for q in range(k)]
        expired = [c for c, prev in self.candidates.items()
                   if self.frame - prev.frame > self.max_gap]     # too old to be confirmed
        if ids is None:
            match = self._match_anonymous(m, C, expired)
        else:                       # with ids: the candidate of the same id, if consistent
            match = {q: mid for q, mid in enumerate(ids.tolist()) if mid in self.candidates
                     and self._consistency(self.candidates[mid], m[q], C[q])
                     < self.confirm_threshold}
        n = [self.candidates[match[q]].sightings + 1 if q in match else 1 for q in range(k)]
        confirmed = [q for q in range(k) if n[q] >= self.n_confirm]
        added = dict(zip(confirmed, (mid for _, mid in super()._admit(
            None if ids is None else ids[confirmed], z[confirmed], R[confirmed],
            (m[confirmed], J1[confirmed], J2[confirmed])))))
        for key in expired:                                          # not seen again: dropped
            del self.candidates[key]
        out = []
        for q in range(k):
            key = match.get(q, None if ids is None else int(ids[q]))
            self.candidates.pop(key, None)
            if q in added:
                out.append(("new", added[q]))
                continue
            if ids is None:
                key, self._next_candidate = self._next_candidate, self._next_candidate + 1
            self.candidates[key] = Candidate(m[q], C[q], n[q], self.frame)
            out.append(("candidate", None))
        return out

    def _match_anonymous(self, m, C, expired) -> dict[int, int]:
        """Without ids: each sighting goes to the closest consistent candidate (each at most
        once) among those of earlier frames not ``expired`` (not seen within ``max_gap``)."""
        keys = [c for c, prev in self.candidates.items()
                if prev.frame < self.frame and c not in expired]
        pairs = sorted((self._consistency(self.candidates[c], m[q], C[q]), q, c)
                       for q in range(len(C)) for c in keys)
        match: dict[int, int] = {}
        for d2, q, c in pairs:
            if d2 < self.confirm_threshold and q not in match and c not in match.values():
                match[q] = c
        return match


def confirmed_slam(run: Run, *, gate: float | None = 0.95, n_confirm: int = 2,
                   max_gap: int = 2, confirm: float = 0.95, Q=None, P0=runner.DEFAULT_P0,
                   by: str = "capture", until: float | None = None) -> runner.Trace:
    """:func:`slamlib.runner.slam` with :class:`ConfirmedSLAM` (chapter 05)."""
    filt = runner.make_filter(ConfirmedSLAM, run, Q=Q, P0=P0, gate=gate, n_confirm=n_confirm,
                              max_gap=max_gap, confirm=confirm)
    return runner.run_filter(run, filt, by=by, until=until, use_run_Q_steps=Q is None)
