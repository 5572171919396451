"""filter.preview: the gate's numbers of a frame without applying the update.

The preview must give what ``copy.deepcopy(filt).update(...)`` reports (d2 and the
verdicts to the last bit), leave the filter untouched, and agree with an
independent dense computation of ``S_i = H_i P H_i^T + R_i`` with the full
``H_i`` of the textbook module.
"""

import copy
import math

import numpy as np
import pytest
from test_ekf import P0, X0, Q, R, scripted_sequence

from slamlib.confirmation import ConfirmedSLAM
from slamlib.ekf import EKFSLAM, FEJEKFSLAM, EKFLocalization
from slamlib.models import observation_jacobians, observe, wrap_angle


def assert_preview_is_update(filt, ids, z, Rk):
    x0, P0_ = filt.x, filt.P
    pv = filt.preview(ids, z, Rk)
    np.testing.assert_array_equal(filt.x, x0)                  # nothing changed
    np.testing.assert_array_equal(filt.P, P0_)
    rep = copy.deepcopy(filt).update(ids, z, Rk)
    assert pv.status == rep.status
    np.testing.assert_array_equal(pv.accepted, rep.accepted)
    np.testing.assert_array_equal(pv.new, rep.new)
    np.testing.assert_array_equal(pv.d2, rep.d2)              # exactly, NaN where not gated
    np.testing.assert_array_equal(pv.innovation, rep.innovation)
    np.testing.assert_array_equal(pv.predicted, rep.predicted)
    np.testing.assert_array_equal(pv.S, rep.S)
    assert pv.threshold == rep.threshold and pv.gate == rep.gate
    assert math.isnan(pv.joint_nis)
    return pv


@pytest.mark.parametrize("cls", [EKFSLAM, FEJEKFSLAM])
@pytest.mark.parametrize("gate", [0.95, 0.5, None])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_preview_is_what_a_copy_that_is_updated_reports(gate, seed, cls):
    f = cls(X0, P0, Q, R, gate=gate)
    statuses = set()
    for u, dt, ids, z, Rk in scripted_sequence(seed=seed, steps=150):
        f.predict(u, dt)
        pv = assert_preview_is_update(f, ids, z, Rk)
        statuses.update(pv.status)
        f.update(ids, z, Rk)
    # the drive shows every kind of reading the preview must get right
    want = {"accepted", "new", "duplicate"} | ({"rejected"} if gate else set())
    assert want <= statuses


@pytest.mark.parametrize("seed", [3, 4])
def test_the_preview_of_the_map_based_filter(seed):
    rng = np.random.default_rng(seed)
    world = {int(i): rng.uniform(-4, 4, 2) for i in rng.choice(100, 12, replace=False)}
    f = EKFLocalization(X0, P0, Q, R, world)
    unknown = 0
    for u, dt, _, _, _ in scripted_sequence(seed=seed, steps=60):
        f.predict(u, dt)
        pick = rng.choice(list(world), 4, replace=False)
        ids = np.append(pick, 999)                          # 999 is not in the map
        z = np.array([observe(f.pose, world[int(i)]) for i in pick] + [[1.0, 0.2]])
        z += rng.normal(0.0, [0.05, math.radians(2.0)], z.shape)
        z[:, 0] = np.abs(z[:, 0])
        pv = assert_preview_is_update(f, ids, z, None)
        unknown += pv.status.count("unknown")
        f.update(ids, z)
    assert unknown == 60


def test_d2_agrees_with_the_full_jacobian():
    f = EKFSLAM(X0, P0, Q, R)
    for u, dt, ids, z, Rk in scripted_sequence(seed=5, steps=80):
        f.predict(u, dt)
        f.update(ids, z, Rk)
    ids = np.array(f.landmark_ids[:6])
    rng = np.random.default_rng(0)
    z = np.array([observe(f.pose, f.landmark(i)) for i in ids]) + rng.normal(0, 0.05, (6, 2))
    pv = f.preview(ids, z)
    x, P = f.x, f.P
    for j, mid in enumerate(ids):
        s = f.landmark_index(int(mid))
        Hp, Hl = observation_jacobians(x[:3], x[s:s + 2])
        H = np.zeros((2, x.size))
        H[:, :3], H[:, s:s + 2] = Hp, Hl
        S = H @ P @ H.T + R
        y = z[j] - observe(x[:3], x[s:s + 2])
        y[1] = wrap_angle(y[1])
        np.testing.assert_allclose(pv.S[j], S, rtol=1e-10, atol=1e-14)
        assert pv.d2[j] == pytest.approx(y @ np.linalg.solve(S, y), rel=1e-9)


def test_a_reading_model_override_is_used():
    class Flipped(EKFLocalization):                        # chapter 03's sign error
        def reading_model(self, pose, positions):
            h, Hp, Hl = super().reading_model(pose, positions)
            Hp[:, 1, 1] *= -1
            return h, Hp, Hl

    world = {1: np.array([2.0, 1.0]), 2: np.array([-1.0, 2.5])}
    f = Flipped(X0, np.diag([0.05, 0.02, 0.01]), Q, R, world)
    z = np.array([observe(X0, world[1]), observe(X0, world[2])]) + [[0.03, 0.02], [-0.02, 0.03]]
    pv = assert_preview_is_update(f, [1, 2], z, None)
    plain = EKFLocalization(X0, np.diag([0.05, 0.02, 0.01]), Q, R, world).preview([1, 2], z)
    assert not np.allclose(pv.S, plain.S)


def test_the_table_names_every_reading():
    f = EKFSLAM(X0, P0, Q, R)
    f.update([7], [[1.0, 0.3]])
    pv = f.preview([7, 8, 8], [[1.0, 0.31], [2.0, 0.0], [2.0, 0.01]])
    lines = pv.table().splitlines()
    assert lines[0] == "gate 0.95  threshold 5.991"
    assert [ln.split()[-1] for ln in lines[2:]] == ["accepted", "new", "duplicate"]
    assert pv.status == ("accepted", "new", "duplicate") and pv.new.tolist() == [0, 1, 0]


def test_filters_whose_update_does_more_are_refused():
    with pytest.raises(ValueError, match="ConfirmedSLAM"):
        ConfirmedSLAM(X0, P0, Q, R).preview([1], [[1.0, 0.0]])
    with pytest.raises(ValueError, match="association"):
        EKFSLAM(X0, P0, Q, R, association="nn").preview([1], [[1.0, 0.0]])


def test_bad_input_names_the_argument():
    f = EKFSLAM(X0, P0, Q, R)
    with pytest.raises(ValueError, match="ids"):
        f.preview([[1, 2]], [[1.0, 0.0], [1.0, 0.0]])
    with pytest.raises(ValueError, match="ids"):
        f.preview([1.5], [[1.0, 0.0]])
    with pytest.raises(ValueError, match="z"):
        f.preview([1, 2], [[1.0, 0.0]])
    with pytest.raises(ValueError, match="z"):
        f.preview([1], [[-1.0, 0.0]])
    with pytest.raises(ValueError, match=r"R\[1\]"):
        f.preview([1, 2], [[1.0, 0.0], [1.0, 0.1]], np.stack([R, -R]))
    with pytest.raises(ValueError, match="R"):
        f.preview([1], [[1.0, 0.0]], np.eye(3))
