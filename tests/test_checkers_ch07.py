"""Chapter 07's exercise checker for the goals of a return: right answers pass, each slip
gets its hint, and the checker's reference is what the library's Explorer does."""

import numpy as np
import pytest

from slamlib.course.checkers_ch07 import _waypoints, check_return_waypoints, return_waypoint_cases


def right(landmark, sightings, distance, approach, inner):
    # written from the chapter's words, with np.clip for the clamp
    side = np.mean(sightings, axis=0)
    side = side / np.linalg.norm(side)
    lo, hi = [inner[0], inner[2]], [inner[1], inner[3]]
    view = np.clip(landmark + distance * side, lo, hi)
    d = (landmark - view) / np.linalg.norm(landmark - view)
    return np.array([view, np.clip(view + approach * d, lo, hi)])


def test_accepts_an_independent_answer(capsys):
    assert check_return_waypoints(right) is True
    assert "correct" in capsys.readouterr().out


class _FakeFilter:
    """What Explorer.choose_anchor and _start_return read from a filter: one landmark known
    much better than the robot."""

    def __init__(self, lm):
        self.landmark_ids = [7]
        self._lm = lm
        self.pose = np.array([0.0, 0.0, 0.0])
        self.pose_cov = np.eye(3)

    def landmark(self, i):
        return self._lm.copy()

    def landmark_cov(self, i):
        return 1e-4 * np.eye(2)


def test_the_reference_is_what_the_explorer_does():
    from slamlib.explore import Explorer
    from slamlib.worlds import random_world

    world = random_world(extent=(0.0, 8.0, -4.0, 4.0), count=3, seed=1)
    for lm, u, dist, appr, inner in return_waypoint_cases():
        pol = Explorer(return_distance=dist, approach=appr, margin=0.5, min_sightings=1)
        pol.reset(world)
        assert tuple(pol.inner) == inner
        pol.sightings = {7: list(u)}
        assert pol._start_return(0.0, _FakeFilter(lm), 1.0)
        np.testing.assert_allclose(pol.ctl.waypoints, _waypoints(lm, u, dist, appr, inner),
                                   atol=1e-12)


def test_the_cases_exercise_each_slip():
    # around -x the mean angle points the other way; near the border the clamp bites
    cases = list(return_waypoint_cases())
    unbounded = (-np.inf, np.inf, -np.inf, np.inf)
    assert any(not np.allclose(_waypoints(*c, angles=True), _waypoints(*c)) for c in cases)
    assert any(not np.allclose(_waypoints(*c[:4], unbounded), _waypoints(*c)) for c in cases)


@pytest.mark.parametrize("kw, words", [({"normalise": False}, "normalise it"),
                                       ({"sign": -1.0}, "TOWARDS the robot"),
                                       ({"angles": True}, "averaged the angles")])
def test_names_the_slip(kw, words, capsys):
    assert check_return_waypoints(lambda *a: _waypoints(*a, **kw)) is False
    assert words in capsys.readouterr().out


def test_unclamped_wrong_approach_and_not_written(capsys):
    unbounded = (-np.inf, np.inf, -np.inf, np.inf)
    assert check_return_waypoints(lambda lm, u, d, a, inner: _waypoints(lm, u, d, a,
                                                                        unbounded)) is False
    assert "clamp" in capsys.readouterr().out

    def away(lm, u, d, a, inner):
        w = _waypoints(lm, u, d, a, inner)
        w[1] = w[0] - (w[1] - w[0])
        return w
    assert check_return_waypoints(away) is False
    assert "TOWARDS the landmark" in capsys.readouterr().out
    assert check_return_waypoints(lambda *a: None) is False
    assert "not written yet" in capsys.readouterr().out
    assert check_return_waypoints(lambda *a: np.zeros(2)) is False
    assert "(2, 2)" in capsys.readouterr().out
