"""ConfirmedSLAM: a new id enters the map only after a second consistent sighting (chapter 05).

The references are computed here independently: the landmark position with
the inverse observation written out (x + rho cos(theta + beta), ...), the
plain EKFSLAM driven on a copy of the same state, the misread rows of a
recorded run.
"""

import copy

import numpy as np
import pytest

from slamlib import runner
from slamlib.confirmation import ConfirmedSLAM, confirmed_slam
from slamlib.ekf import EKFSLAM
from slamlib.models import motion_model
from slamlib.runs import load_run

Q = np.diag([0.02**2, 0.02**2])
R = np.diag([0.03**2, np.radians(1.0) ** 2])
P0 = np.diag([1e-6, 1e-6, 1e-6])
POSE = np.array([1.0, 2.0, 0.4])
MARKERS = {3: np.array([2.5, 2.8]), 7: np.array([2.2, 1.1]), 9: np.array([3.0, 2.0])}


def reading(pose, p):
    """Exact [range, bearing] of point p from pose, written out (not slamlib.models)."""
    d = np.asarray(p, float) - pose[:2]
    b = np.arctan2(d[1], d[0]) - pose[2]
    return np.array([np.hypot(*d), np.arctan2(np.sin(b), np.cos(b))])


def frame(pose, ids):
    return np.array(ids), np.array([reading(pose, MARKERS[i]) for i in ids])


def make(cls=ConfirmedSLAM, **kw):
    return cls(POSE, P0, Q, R, gate=0.95, **kw)


def test_a_true_marker_seen_twice_enters_the_map_from_the_second_reading():
    f = make()
    ids, z = frame(POSE, [3, 7])
    rep = f.update(ids, z)
    assert rep.status == ("candidate", "candidate") and not rep.new.any()
    assert f.landmark_ids == [] and set(f.candidates) == {3, 7}
    rep = f.update(ids, z)
    assert rep.status == ("new", "new") and rep.new.all()
    assert f.landmark_ids == [3, 7] and f.candidates == {}
    # added from the (unchanged) pose with the second reading: x + rho [cos, sin](theta + beta)
    for mid, (rho, b) in zip(ids, z):
        expected = POSE[:2] + rho * np.array([np.cos(POSE[2] + b), np.sin(POSE[2] + b)])
        np.testing.assert_allclose(f.landmark(mid), expected, atol=1e-12)
    assert f.state_size == 7


def test_a_single_misread_id_never_enters_the_map():
    f = make()
    for k in range(6):
        ids, z = frame(POSE, [3, 7])
        if k == 2:                         # one frame reads marker 9 as id 42, once
            ids = np.r_[ids, 42]
            z = np.vstack([z, reading(POSE, MARKERS[9])])
        rep = f.update(ids, z)
        if k == 2:
            assert rep.status[-1] == "candidate"
    assert 42 not in f.landmark_ids
    assert sorted(f.landmark_ids) == [3, 7]
    # the stale candidate cannot be confirmed later by a sighting more than max_gap frames on
    for _ in range(f.max_gap + 1):
        f.update(*frame(POSE, [3, 7]))
    rep = f.update(np.array([42]), np.array([reading(POSE, MARKERS[9])]))
    assert rep.status == ("candidate",) and 42 not in f.landmark_ids


def test_a_confirmed_landmark_is_initialised_once():
    """The inverse observation of a confirmed reading is computed once, where it is tested
    against its candidate, and added with those numbers (no second call of the hook)."""

    class Counting(ConfirmedSLAM):
        calls = 0

        def jacobians(self, link, ids=None, z=None, u=None, dt=None):
            Counting.calls += link == "initialisation"
            return super().jacobians(link, ids=ids, z=z, u=u, dt=dt)

    f = make(Counting)
    ids, z = frame(POSE, [3, 7])
    f.update(ids, z)
    Counting.calls = 0
    assert f.update(ids, z).status == ("new", "new")
    assert Counting.calls == 1 and f.landmark_ids == [3, 7]


def test_a_candidate_not_seen_within_max_gap_is_dropped():
    """With ids too: a one-off misread leaves no candidate behind once it is too old."""
    f = make(max_gap=2)
    f.update(*frame(POSE, [3]))                             # frame 1: candidate 3
    for _ in range(2):
        f.update(np.array([], dtype=int), np.zeros((0, 2)))  # frames 2, 3: nothing
    assert set(f.candidates) == {3}                         # gap 2: may still be confirmed
    f.update(*frame(POSE, [7]))                             # frame 4: 3 is 3 frames old
    assert set(f.candidates) == {7}


def test_two_inconsistent_sightings_of_one_id_do_not_confirm_it():
    # id 3 read first at marker 3's place, then at marker 7's (a misread twice, 1.7 m apart)
    f = make()
    f.update(np.array([3]), np.array([reading(POSE, MARKERS[3])]))
    rep = f.update(np.array([3]), np.array([reading(POSE, MARKERS[7])]))
    assert rep.status == ("candidate",)
    assert f.landmark_ids == [] and f.candidates[3].sightings == 1
    rep = f.update(np.array([3]), np.array([reading(POSE, MARKERS[7])]))   # now consistent
    assert rep.status == ("new",)
    np.testing.assert_allclose(f.landmark(3), MARKERS[7], atol=1e-9)


def test_n_confirm_and_max_gap():
    f = make(n_confirm=3)
    ids, z = frame(POSE, [9])
    assert [f.update(ids, z).status[0] for _ in range(3)] == ["candidate", "candidate", "new"]
    f = make(n_confirm=1)                 # one sighting: plain EKF SLAM
    assert f.update(ids, z).status == ("new",)
    f = make(max_gap=1)
    f.update(ids, z)
    f.update(np.array([], dtype=int), np.zeros((0, 2)))    # a frame without id 9
    assert f.update(ids, z).status == ("candidate",)        # gap 2 > max_gap = 1
    assert f.update(ids, z).status == ("new",)


def test_a_duplicate_reading_in_one_frame_counts_once():
    f = make()
    z = reading(POSE, MARKERS[9])
    rep = f.update(np.array([9, 9]), np.array([z, z]))
    assert rep.status == ("candidate", "duplicate")
    assert f.candidates[9].sightings == 1


def test_with_nothing_pending_it_is_plain_ekf_slam():
    f = make()
    f.update(*frame(POSE, [3, 7, 9]))
    f.update(*frame(POSE, [3, 7, 9]))
    assert f.candidates == {} and sorted(f.landmark_ids) == [3, 7, 9]
    rng = np.random.default_rng(0)
    pose = POSE.copy()
    for _ in range(5):
        u = np.array([0.21, 0.19])
        f.predict(u, 0.1)
        pose = motion_model(pose, u, 0.1)                   # roughly where the robot is
        ids, z = frame(pose, [9, 3, 7])
        z = z + rng.normal(0.0, [0.03, 0.017], size=z.shape)
        plain = copy.deepcopy(f)
        ref = EKFSLAM.update(plain, ids, z)                # the base class on the same state
        rep = f.update(ids, z)
        np.testing.assert_array_equal(f.x, plain.x)
        np.testing.assert_array_equal(f.P, plain.P)
        assert rep.status == ref.status and ref.n_accepted > 0
        np.testing.assert_array_equal(rep.d2, ref.d2)
        np.testing.assert_array_equal(rep.accepted, ref.accepted)


def test_mapped_and_new_readings_mixed_keep_the_given_order():
    f = make()
    f.update(*frame(POSE, [3]))
    f.update(*frame(POSE, [3]))                             # 3 is mapped now
    ids = np.array([9, 3, 7])
    z = np.array([reading(POSE, MARKERS[i]) for i in ids])
    rep = f.update(ids, z)
    assert rep.status == ("candidate", "accepted", "candidate")
    assert np.isnan(rep.d2[0]) and np.isfinite(rep.d2[1]) and np.isnan(rep.d2[2])
    np.testing.assert_array_equal(rep.ids, ids)
    np.testing.assert_array_equal(rep.z, z)


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="n_confirm"):
        make(n_confirm=0)
    with pytest.raises(ValueError, match="max_gap"):
        make(max_gap=1.5)
    with pytest.raises(ValueError, match="confirm"):
        make(confirm=1.0)
    f = make()
    with pytest.raises(ValueError, match="z"):
        f.update(np.array([3, 7]), np.zeros((3, 2)))
    assert f.frame == 0                                     # nothing changed


@pytest.fixture(scope="module")
def misread_run():
    return load_run("arena_loop_misreads")


def test_on_the_misread_run_no_misread_id_is_mapped(misread_run):
    world = misread_run.world()
    tr = confirmed_slam(misread_run, gate=0.95)
    mapped = set(tr.filter.landmark_ids)
    assert mapped <= set(world.landmarks())                 # no id that is not in the world
    # every mapped landmark is near its true marker (plain EKF SLAM misplaces seven by metres)
    for mid, p in tr.filter.landmarks.items():
        assert np.hypot(*(p - world.landmarks()[mid])) < 0.3, mid
    cam = misread_run.camera
    assert np.count_nonzero(cam.id != cam.true_id) > 20      # the run does contain misreads
    plain = set(runner.slam(misread_run, gate=0.95).filter.landmark_ids)
    assert len(plain - set(world.landmarks())) > 10


@pytest.mark.parametrize("bad", [{"confirm": "0.9"}, {"confirm": 1.0}, {"n_confirm": 0},
                                 {"max_gap": 1.5}, {"n_confirm": True}])
def test_confirmation_parameters_are_checked_when_given_and_when_set(bad):
    args = ([0.0, 0.0, 0.0], np.eye(3) * 1e-4, np.eye(2) * 1e-4, np.eye(2) * 1e-3)
    with pytest.raises(ValueError, match=next(iter(bad))):
        ConfirmedSLAM(*args, **bad)
    f = ConfirmedSLAM(*args)
    name, value = next(iter(bad.items()))
    if name != "confirm":
        with pytest.raises(ValueError, match=name):
            setattr(f, name, value)
        assert getattr(f, name) >= 1
