"""EKF SLAM's four linearisation links, one at a time (issue 20; chapter 06's ablation).

Written against the public API of ``slamlib.ekf`` only (``LinearisedEKFSLAM``, ``FEJEKFSLAM``,
``IdealEKFSLAM``, ``EKFSLAM``: constructor, predict, update, x, P), so that any implementation
of the spec passes. Each one-factor variant is driven beside EKF SLAM through the same steps:

- while both hold the same state, a step in which the variant's link does not act gives
  EKF SLAM's numbers bit for bit (the other links are EKF SLAM's);
- every step of the variant is recomputed independently, from the variant's own prior, with
  the dense textbook formulas (full F, H, J matrices) and the Jacobians evaluated at the points
  the spec names for each link (propagated poses, first estimates, the truth); the filter
  agrees with it to rounding, and where its link acts it differs from EKF SLAM.
"""

from __future__ import annotations

import numpy as np
import pytest

from slamlib import sim
from slamlib.ekf import EKFSLAM, FEJEKFSLAM, IdealEKFSLAM, LinearisedEKFSLAM
from slamlib.models import (
    inverse_observation_jacobians,
    inverse_observe,
    motion_jacobians,
    motion_model,
    observation_jacobians,
    observe,
    wrap_angle,
)

Q = np.diag([0.04, 0.05]) ** 2
R = np.diag([0.03, np.radians(1.5)]) ** 2
P0 = np.diag([1e-4, 2e-4, 3e-4])
DT = 0.1
TRUE_MAP = {1: np.array([2.0, 0.6]), 2: np.array([1.5, -1.2]), 3: np.array([3.0, 0.1]),
            4: np.array([2.6, 1.4])}
X0 = np.array([0.02, -0.03, 0.05])                 # the estimate starts off the truth


def _world(seed=0, steps=12):
    """True poses at t = k DT (from the true start (0, 0, 0) with slipping wheels), the
    commanded wheel speeds and the camera frames: step index -> the ids of each frame at that
    time (at step 9 two frames in a row: the second one's prior is not x_{k|k-1})."""
    rng = np.random.default_rng(seed)
    u = np.array([0.30, 0.36])
    poses = [np.zeros(3)]
    for _ in range(steps):
        poses.append(motion_model(poses[-1], u + rng.normal(0.0, 0.04, 2), DT))
    frames = {0: [[1, 2, 3]], 3: [[1, 2]], 5: [[1, 3, 4]], 8: [[2, 3, 4, 1]],
              9: [[4, 2], [1, 3]], 12: [[1, 2, 3, 4]]}
    readings = {k: [np.array([observe(poses[k], TRUE_MAP[i]) for i in ids])
                    + rng.normal(0.0, [0.03, np.radians(1.5)], (len(ids), 2)) for ids in frame]
                for k, frame in frames.items()}
    return np.array(poses), u, frames, readings


POSES, U, FRAMES, READINGS = _world()


def _truth(t: float) -> np.ndarray:
    k = int(round(t / DT))
    assert abs(t - k * DT) < 1e-9, t
    return POSES[k].copy()


def _make(cls=LinearisedEKFSLAM, **links):
    if cls is EKFSLAM:
        return EKFSLAM(X0, P0, Q, R, gate=None)
    return cls(X0, P0, Q, R, gate=None, truth=_truth, landmarks=TRUE_MAP, **links)


# --------------------------------------------------------------------------- the dense reference
class Reference:
    """The variant's own bookkeeping of its linearisation points, and the dense formulas."""

    def __init__(self, links):
        self.links = dict(links)
        self.k = 0                        # steps predicted (the filter's t = k DT)
        self.propagated = X0.copy()       # x_{k|k-1}
        self.first = {}                   # id -> first estimate
        self.ids = []

    def predict(self, x, P):
        """The posterior of one predict from (x, P) with A, W at the motion link's point."""
        pose = x[:3]
        new = motion_model(pose, U, DT)
        A, W = motion_jacobians(pose, U, DT)
        if self.links["motion"] == "first":
            A = np.eye(3)
            A[0, 2], A[1, 2] = -(new[1] - self.propagated[1]), new[0] - self.propagated[0]
        elif self.links["motion"] == "truth":
            p0, p1 = POSES[self.k], POSES[self.k + 1]
            A = np.eye(3)
            A[0, 2], A[1, 2] = -(p1[1] - p0[1]), p1[0] - p0[0]
            W = motion_jacobians(p0, U, DT)[1]
        n = x.size
        F, G = np.eye(n), np.zeros((n, 2))
        F[:3, :3], G[:3] = A, W
        x2 = x.copy()
        x2[:3] = new
        return x2, F @ P @ F.T + G @ Q @ G.T

    def update(self, x, P, ids, z):
        """The posterior of one update (all readings fused, then new ids added)."""
        pt = POSES[self.k]
        old = [j for j, i in enumerate(ids) if i in self.ids]
        n = x.size
        if old:
            H = np.zeros((2 * len(old), n))
            y = np.zeros(2 * len(old))
            for r, j in enumerate(old):
                mid = ids[j]
                s = 3 + 2 * self.ids.index(mid)
                pose, m = x[:3], x[s:s + 2]
                if self.links["observation"] == "first":
                    Hp, Hl = observation_jacobians(self.propagated, self.first[mid])
                elif self.links["observation"] == "truth":
                    Hp, Hl = observation_jacobians(pt, TRUE_MAP[mid])
                else:
                    Hp, Hl = observation_jacobians(pose, m)
                if self.links["innovation"] == "truth":
                    Hpt, Hlt = observation_jacobians(pt, TRUE_MAP[mid])
                    dp = pose - pt
                    dp[2] = wrap_angle(dp[2])
                    h = observe(pt, TRUE_MAP[mid]) + Hpt @ dp + Hlt @ (m - TRUE_MAP[mid])
                else:
                    h = observe(pose, m)
                H[2 * r:2 * r + 2, :3], H[2 * r:2 * r + 2, s:s + 2] = Hp, Hl
                y[2 * r:2 * r + 2] = [z[j, 0] - h[0], wrap_angle(z[j, 1] - h[1])]
            Rs = np.kron(np.eye(len(old)), R)
            S = H @ P @ H.T + Rs
            K = P @ H.T @ np.linalg.inv(S)
            x = x + K @ y
            x[2] = wrap_angle(x[2])
            IKH = np.eye(n) - K @ H
            P = IKH @ P @ IKH.T + K @ Rs @ K.T           # Joseph form
        for j, mid in enumerate(ids):
            if mid in self.ids:
                continue
            pose = x[:3]
            if self.links["initialisation"] == "truth":
                zt = observe(pt, TRUE_MAP[mid])
                J1, J2 = inverse_observation_jacobians(pt, zt)
                dp = pose - pt
                dp[2] = wrap_angle(dp[2])
                dz = z[j] - zt
                dz[1] = wrap_angle(dz[1])
                m = TRUE_MAP[mid] + J1 @ dp + J2 @ dz
            else:
                J1, J2 = inverse_observation_jacobians(pose, z[j])
                m = inverse_observe(pose, z[j])
            n = x.size
            J = np.zeros((2, n))
            J[:, :3] = J1
            Pn = np.zeros((n + 2, n + 2))
            Pn[:n, :n] = P
            Pn[n:, :n] = J @ P
            Pn[:n, n:] = (J @ P).T
            Pn[n:, n:] = J1 @ P[:3, :3] @ J1.T + J2 @ R @ J2.T
            x, P = np.concatenate([x, m]), Pn
            self.ids.append(mid)
            self.first[mid] = m.copy()
        return x, P


def _close(f, x, P):
    np.testing.assert_allclose(f.x, x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(f.P, P, rtol=1e-9, atol=1e-14)


def _drive(links):
    """The variant and EKF SLAM through the same steps; returns the steps at which the variant
    left EKF SLAM (the state was the same before and differs after)."""
    f, e, ref = _make(**links), _make(EKFSLAM), Reference(links)
    differs_at = []
    for k in range(len(POSES)):
        for ids, z in zip(FRAMES.get(k, []), READINGS.get(k, [])):
            same = np.array_equal(f.x, e.x) and np.array_equal(f.P, e.P)
            x, P = ref.update(f.x, f.P, ids, z)
            f.update(ids, z)
            e.update(ids, z)
            _close(f, x, P)
            if same and not (np.array_equal(f.x, e.x) and np.array_equal(f.P, e.P)):
                differs_at.append(("update", k))
        if k == len(POSES) - 1:
            break
        same = np.array_equal(f.x, e.x) and np.array_equal(f.P, e.P)
        x, P = ref.predict(f.x, f.P)
        f.predict(U, DT)
        e.predict(U, DT)
        ref.k += 1
        ref.propagated = f.x[:3].copy()
        _close(f, x, P)
        if same and not (np.array_equal(f.x, e.x) and np.array_equal(f.P, e.P)):
            differs_at.append(("predict", k))
    return f, e, differs_at


ESTIMATE = dict(motion="estimate", observation="estimate", initialisation="estimate",
                innovation="estimate")


def test_all_estimate_is_ekf_slam_bit_for_bit_and_the_reference_is_right():
    f, e, differs_at = _drive(ESTIMATE)
    assert differs_at == []
    assert np.array_equal(f.x, e.x) and np.array_equal(f.P, e.P)


@pytest.mark.parametrize("link, point, first_step", [
    # a new landmark: the very first frame maps three of them
    ("initialisation", "truth", ("update", 0)),
    # the first re-observation (frame 3) reads landmarks that have not moved since they were
    # mapped, from the propagated pose: their first estimates are their estimates, so FEJ's
    # observation link first acts at frame 5, once frame 3's update has moved them
    ("observation", "first", ("update", 5)),
    ("observation", "truth", ("update", 3)),
    ("innovation", "truth", ("update", 3)),
    # FEJ's A from the difference of two poses, EKF SLAM's from V sin(theta) dt: equal up to
    # rounding from the first predict on, apart once an update has corrected the pose (the
    # reference checks each A)
    ("motion", "first", ("predict", 0)),
    ("motion", "truth", ("predict", 0)),
])
def test_a_one_factor_variant_leaves_ekf_slam_where_its_link_acts_and_only_there(
        link, point, first_step):
    f, e, differs_at = _drive({**ESTIMATE, link: point})
    assert getattr(f, link) == point
    assert differs_at == [first_step]            # bit for bit EKF SLAM's until that step
    assert not np.allclose(f.P, e.P, rtol=1e-6)  # and not after it


@pytest.mark.parametrize("links", [
    dict(motion="first", observation="first", initialisation="estimate", innovation="estimate"),
    dict(motion="truth", observation="truth", initialisation="estimate", innovation="truth"),
    dict(motion="truth", observation="truth", initialisation="truth", innovation="truth"),
    dict(motion="truth", observation="truth", initialisation="truth", innovation="estimate"),
    dict(motion="truth", observation="truth", initialisation="estimate", innovation="estimate"),
])
def test_the_studys_combined_variants_follow_the_dense_reference(links):
    f, _, _ = _drive(links)                        # every step checked inside
    assert {k: getattr(f, k) for k in links} == links


def _run_events(f, run, t_end=25.0):
    """Drive a filter through a simulated run's events (public API) up to ``t_end``."""
    sensor = run.sensor()
    for ev in run.events():
        if ev.t > t_end:
            break
        if ev.kind == "predict":
            f.predict(ev.u, ev.dt)
        elif len(ev.obs):
            f.update(ev.obs.ids, ev.obs.z, R=np.array([sensor.R(r) for r in ev.obs.z[:, 0]]))
    return f


def _truth_of(run):
    t, X = run.truth_t, run.truth

    def pose(time):
        i = int(np.argmin(np.abs(t - time)))
        assert abs(t[i] - time) < 1e-6
        return X[i].copy()
    return pose


@pytest.fixture(scope="module")
def run():
    return sim.scenario("arena_loop", seed=1003, sigma_wheel=0.10)


def _pair(run, preset, links):
    kw = dict(truth=_truth_of(run), landmarks=run.world().landmarks(),
              t0=float(run.enc_t[0]))
    args = (run.start_pose, np.eye(3) * 1e-6, run.Q(), run.sensor().R(2.0))
    a = _run_events(preset(*args), run)
    b = _run_events(LinearisedEKFSLAM(*args, **links, **kw), run)
    return a, b


def test_ekf_slam_is_the_all_estimate_filter_on_a_simulated_run(run):
    a, b = _pair(run, lambda *args: EKFSLAM(*args), {})
    assert b.landmark_ids == a.landmark_ids and len(a.landmark_ids) >= 4
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)


def test_fej_is_the_first_first_preset_bit_for_bit(run):
    a, b = _pair(run, FEJEKFSLAM, dict(motion="first", observation="first"))
    assert (a.motion, a.observation, a.initialisation, a.innovation) == (
        "first", "first", "estimate", "estimate")
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)
    e = _run_events(EKFSLAM(run.start_pose, np.eye(3) * 1e-6, run.Q(), run.sensor().R(2.0)), run)
    assert not np.allclose(a.P, e.P, rtol=1e-6)


@pytest.mark.parametrize("innovation", ["truth", "estimate"])
@pytest.mark.parametrize("landmark_init", ["estimate", "truth"])
def test_ideal_is_the_truth_truth_preset_bit_for_bit(run, innovation, landmark_init):
    kw = dict(truth=_truth_of(run), landmarks=run.world().landmarks(), t0=float(run.enc_t[0]))

    def ideal(*args):
        return IdealEKFSLAM(*args, innovation=innovation, landmark_init=landmark_init, **kw)

    a, b = _pair(run, ideal, dict(motion="truth", observation="truth",
                                  initialisation=landmark_init, innovation=innovation))
    assert (a.initialisation, a.innovation) == (landmark_init, innovation)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)


def test_bad_options_name_the_option_and_the_allowed_values():
    for link, bad in (("motion", "ideal"), ("observation", "last"), ("initialisation", "first"),
                      ("innovation", "first"), ("motion", None)):
        with pytest.raises(ValueError, match=link) as err:
            LinearisedEKFSLAM(X0, P0, Q, R, **{link: bad}, truth=_truth, landmarks=TRUE_MAP)
        assert "estimate" in str(err.value)
    for link in ("motion", "observation", "initialisation", "innovation"):
        with pytest.raises(ValueError, match="truth") as err:
            LinearisedEKFSLAM(X0, P0, Q, R, **{link: "truth"})
        assert "landmarks" in str(err.value)
        with pytest.raises(ValueError, match="landmarks"):
            LinearisedEKFSLAM(X0, P0, Q, R, **{link: "truth"}, truth=_truth)
    f = LinearisedEKFSLAM(X0, P0, Q, R, observation="first")   # "first" needs no truth
    with pytest.raises(AttributeError):
        f.observation = "estimate"


def test_a_misread_id_is_linearised_at_the_estimate():
    """An id outside the true map: every "truth" link falls back to the estimate there."""
    truthy = dict(motion="estimate", observation="truth", initialisation="truth",
                  innovation="truth")
    f, e = _make(**truthy), _make(EKFSLAM)
    z = np.array([[1.8, 0.3]])
    for g in (f, e):
        g.update([99], z)
        g.predict(U, DT)
        g.update([99], z + 0.01)
    assert np.array_equal(f.x, e.x) and np.array_equal(f.P, e.P)
