"""The textbook EKF with full matrices: the tests' (and the benchmark's) independent reference.

Written from the equations, not from :mod:`slamlib.ekf`: the prediction with
``F = blkdiag(A, I)`` and ``F_w = [W; 0]``, each reading gated with its full
``H_i`` (2 x n), the joint update with the stacked H (2m x n), ``K = P H' S^-1``
and the Joseph form, augmentation with ``G_x = [I; J1 0]`` and ``G_z = [0; J2]``.
The semantics are the course's (report V.C, corrected; ``COURSE.md``): the
gate against the prior, one joint update, then new ids from the updated pose in
the order given (a new id read twice is added once, its second reading a
"duplicate"); with a known map an unknown id is rejected. It uses only the
models (:mod:`slamlib.models`, checked against finite differences elsewhere).
"""

from __future__ import annotations

import math

import numpy as np

from slamlib.models import (
    inverse_observation_jacobians,
    inverse_observe,
    motion_jacobians,
    motion_model,
    observe_landmarks,
    wrap_angle,
)


class DenseEKF:
    """EKF SLAM (``landmarks=None``) or map-based localisation, with n x n matrices."""

    def __init__(self, x0, P0, Q, R, landmarks=None, wheel_base=0.23, gate=0.95):
        self.x = np.array(x0, dtype=float)
        self.x[2] = wrap_angle(self.x[2])
        self.P = np.array(P0, dtype=float)
        self.Q, self.R, self.b = np.array(Q, float), np.array(R, float), wheel_base
        self.map = None if landmarks is None else {int(k): np.array(v, float)
                                                   for k, v in landmarks.items()}
        self.slot: dict[int, int] = {}
        self.ids: list[int] = []
        self.threshold = math.inf if gate is None else -2.0 * math.log(1.0 - gate)

    # the model, overridable like the library's hook
    def reading_model(self, pose, positions):
        return observe_landmarks(pose, positions)

    @property
    def landmark_ids(self):
        return list(self.ids) if self.map is None else list(self.map)

    def predict(self, u, dt):
        n = self.x.size
        A, W = motion_jacobians(self.x[:3], u, dt, self.b)
        F, Fw = np.eye(n), np.zeros((n, 2))
        F[:3, :3], Fw[:3] = A, W
        self.x[:3] = motion_model(self.x[:3], u, dt, self.b)
        P = F @ self.P @ F.T + Fw @ self.Q @ Fw.T
        self.P = 0.5 * (P + P.T)

    def _H(self, slot, Hp, Hl):
        H = np.zeros((2, self.x.size))
        H[:, :3] = Hp
        if slot >= 0:
            H[:, slot:slot + 2] = Hl
        return H

    def update(self, ids, z, R=None) -> dict:
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        k = z.shape[0]
        Rk = np.broadcast_to(self.R if R is None else np.asarray(R, float), (k, 2, 2))
        out = {"status": [""] * k, "accepted": np.zeros(k, bool), "new": np.zeros(k, bool),
               "d2": np.full(k, np.nan), "joint_nis": np.nan}
        rows, seen = [], set()
        for i, mid in enumerate(int(v) for v in ids):
            if self.map is not None:
                if mid not in self.map:
                    out["status"][i] = "unknown"
                    continue
                slot, pos = -1, self.map[mid]
            elif mid in self.slot:
                slot = self.slot[mid]
                pos = self.x[slot:slot + 2]
            else:
                out["status"][i] = "duplicate" if mid in seen else "new"
                out["new"][i] = mid not in seen
                seen.add(mid)
                continue
            h, Hp, Hl = self.reading_model(self.x[:3].copy(), pos[None, :])
            if not np.isfinite(h[0, 1]):
                out["status"][i] = "degenerate"
                continue
            H = self._H(slot, Hp[0], Hl[0])
            y = z[i] - h[0]
            y[1] = wrap_angle(y[1])
            d2 = float(y @ np.linalg.solve(H @ self.P @ H.T + Rk[i], y))
            out["d2"][i] = d2
            ok = d2 < self.threshold
            out["accepted"][i] = ok
            out["status"][i] = "accepted" if ok else "rejected"
            if ok:
                rows.append((H, y, Rk[i]))
        if rows:
            m, n = len(rows), self.x.size
            H = np.vstack([r[0] for r in rows])
            y = np.concatenate([r[1] for r in rows])
            Rb = np.zeros((2 * m, 2 * m))
            for j, r in enumerate(rows):
                Rb[2 * j:2 * j + 2, 2 * j:2 * j + 2] = r[2]
            S = H @ self.P @ H.T + Rb
            K = self.P @ H.T @ np.linalg.inv(S)
            self.x = self.x + K @ y
            self.x[2] = wrap_angle(self.x[2])
            IKH = np.eye(n) - K @ H
            P = IKH @ self.P @ IKH.T + K @ Rb @ K.T                 # Joseph form
            self.P = 0.5 * (P + P.T)
            out["joint_nis"] = float(y @ np.linalg.solve(S, y))
        for i in np.flatnonzero(out["new"]):
            self.augment(int(ids[i]), z[i], Rk[i])
        return out

    def augment(self, mid, z, R):
        n = self.x.size
        J1, J2 = inverse_observation_jacobians(self.x[:3], z)
        Gx, Gz = np.zeros((n + 2, n)), np.zeros((n + 2, 2))
        Gx[:n] = np.eye(n)
        Gx[n:, :3] = J1
        Gz[n:] = J2
        self.x = np.concatenate([self.x, inverse_observe(self.x[:3], z)])
        P = Gx @ self.P @ Gx.T + Gz @ R @ Gz.T
        self.P = 0.5 * (P + P.T)
        self.slot[mid] = n
        self.ids.append(mid)
