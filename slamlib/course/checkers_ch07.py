"""Chapter 07's exercise checkers: where a return goes, and is a point in view.

:func:`check_return_waypoints` (the chapter's exercise) checks the two goals of a
return to a landmark; :func:`check_in_field_of_view` (a "more to try") the
field-of-view test.

The verdicts follow :mod:`slamlib.course.harness`.
"""

from __future__ import annotations

import numpy as np

from ..models import wrap_angle
from .harness import attempt, name_of, printer

__all__ = ["check_in_field_of_view", "check_return_waypoints", "return_waypoint_cases"]


def _random_view_cases(n: int, seed: int):
    """Poses (a third of them facing close to +-pi, where the bearing must be wrapped),
    points around them, half angles and ranges."""
    rng = np.random.default_rng(seed)
    for i in range(n):
        heading = (np.pi - rng.uniform(0.0, 0.4)) * rng.choice([-1.0, 1.0]) if i % 3 == 0 \
            else rng.uniform(-np.pi, np.pi)
        pose = np.array([rng.uniform(-3, 3), rng.uniform(-3, 3), heading])
        half, max_range = float(rng.uniform(0.3, 1.2)), float(rng.uniform(1.0, 3.0))
        pts = pose[:2] + rng.uniform(-1.3 * max_range, 1.3 * max_range, (40, 2))
        yield pose, pts, half, max_range


def check_in_field_of_view(fn, n_cases: int = 12, seed: int = 7, verbose: bool = True) -> bool:
    """Check a student's ``fn(pose, points, half_angle, max_range) -> bool array`` (chapter 07).

    ``points`` is (n, 2); a point is in view when its distance from the robot
    is at most ``max_range`` and its bearing ``wrap(atan2(dy, dx) - theta)`` is
    at most ``half_angle`` in size. Compared with
    :func:`slamlib.explore.in_field_of_view` for ``n_cases`` random poses of 40
    points each; hints for a bearing that is not wrapped, ``+ theta`` instead of
    ``- theta``, ``atan2(dx, dy)``, the whole field of view used as the half
    angle, and the squared distance compared with the range.
    """
    from ..explore import in_field_of_view

    say = printer(verbose)
    name = name_of(fn)
    cases = list(_random_view_cases(n_cases, seed))
    got_all = []
    for pose, pts, half, rmax in cases:
        out = attempt(fn, pose.copy(), pts.copy(), half, rmax, say=say, what="the test")
        if out is None:
            return False
        got = np.asarray(out).reshape(-1) if np.ndim(out) else np.asarray(out)
        if got.shape != (pts.shape[0],):
            say(f"{name}: expected one True/False per point, shape ({pts.shape[0]},), "
                f"got shape {np.shape(out)}.")
            return False
        if got.dtype != bool and not np.isin(got, (0, 1)).all():
            say(f"{name}: expected True/False per point, got values such as {got[:3]}.")
            return False
        got_all.append(got.astype(bool))

    def variant(bearing_of, half_of=lambda h: h, dist_of=np.hypot):
        out = []
        for pose, pts, half, rmax in cases:
            dx, dy = pts[:, 0] - pose[0], pts[:, 1] - pose[1]
            out.append((dist_of(dx, dy) <= rmax)
                       & (np.abs(bearing_of(dx, dy, pose[2])) <= half_of(half)))
        return out

    want = [in_field_of_view(pose, pts, half, rmax) for pose, pts, half, rmax in cases]
    for k, ((pose, pts, half, rmax), g, w) in enumerate(zip(cases, got_all, want)):
        bad = np.flatnonzero(g != w)
        if bad.size == 0:
            continue
        i = bad[0]
        dx, dy = pts[i, 0] - pose[0], pts[i, 1] - pose[1]
        b = wrap_angle(np.arctan2(dy, dx) - pose[2])
        say(f"{name}: not right yet (case {k + 1} of {n_cases}: pose [{pose[0]:.2f}, "
            f"{pose[1]:.2f}, {pose[2]:.3f}], half_angle {half:.3f}, max_range {rmax:.2f}). "
            f"The point [{pts[i, 0]:.2f}, {pts[i, 1]:.2f}] at distance {np.hypot(dx, dy):.2f} m "
            f"and bearing {b:+.3f} rad is {'inside' if w[i] else 'outside'}; you said "
            f"{'inside' if g[i] else 'outside'} ({bad.size} of {len(g)} points wrong here).")
        hints = {
            "the bearing atan2(dy, dx) - theta must be wrapped to [-pi, pi): facing near +-pi, "
            "a point straight ahead can come out as almost 2 pi":
                variant(lambda dx, dy, th: np.arctan2(dy, dx) - th),
            "the bearing is atan2(dy, dx) - theta (the direction to the point minus the "
            "heading), not + theta":
                variant(lambda dx, dy, th: wrap_angle(np.arctan2(dy, dx) + th)),
            "wrap the bearing to [-pi, pi) (a point a little to the left has a small "
            "negative bearing), not to [0, 2 pi) with a plain modulo":
                variant(lambda dx, dy, th: np.mod(np.arctan2(dy, dx) - th, 2 * np.pi)),
            "numpy's arctan2 takes (dy, dx): y first":
                variant(lambda dx, dy, th: wrap_angle(np.arctan2(dx, dy) - th)),
            "half_angle is HALF the field of view: compare |bearing| with half_angle itself":
                variant(lambda dx, dy, th: wrap_angle(np.arctan2(dy, dx) - th),
                        half_of=lambda h: 2 * h),
            "half_angle is already half the field of view: do not halve it again":
                variant(lambda dx, dy, th: wrap_angle(np.arctan2(dy, dx) - th),
                        half_of=lambda h: h / 2),
            "compare the distance sqrt(dx^2 + dy^2) with max_range, not its square":
                variant(lambda dx, dy, th: wrap_angle(np.arctan2(dy, dx) - th),
                        dist_of=lambda dx, dy: dx * dx + dy * dy),
        }
        fits = [why for why, v in hints.items()
                if all(np.array_equal(a, b) for a, b in zip(v, got_all))]
        for why in fits or ["a point is in view when distance <= max_range AND "
                            "|wrap(atan2(dy, dx) - theta)| <= half_angle"]:
            say(f"  Hint: {why}.")
        return False
    say(f"{name}: correct. Right for {sum(len(g) for g in got_all)} points around "
        f"{n_cases} poses, including headings near +-pi.")
    return True


# --------------------------------------------------------------------------- where a return goes
def _clamp(p, inner):
    x0, x1, y0, y1 = inner
    return np.array([min(max(p[0], x0), x1), min(max(p[1], y0), y1)])


def _waypoints(landmark, sightings, distance, approach, inner, *, normalise=True, sign=1.0,
               angles=False):
    """The two goals of a return, as the chapter describes them (and the usual slips)."""
    u = np.asarray(sightings, dtype=float)
    if angles:                                     # the mean of the angles, not of the vectors
        a = np.mean(np.arctan2(u[:, 1], u[:, 0]))
        side = np.array([np.cos(a), np.sin(a)])
    else:
        side = u.mean(axis=0)
        if normalise:
            side = side / np.hypot(*side)
    side = sign * side
    view = _clamp(landmark + distance * side, inner)
    d = landmark - view
    closer = _clamp(view + approach * d / np.hypot(*d), inner)
    return np.array([view, closer])


def return_waypoint_cases(n: int = 10, seed: int = 5):
    """Seeded cases ``(landmark, sightings, distance, approach, inner)``: sightings spread
    around a side (some around the -x direction, where angles jump at +-pi), some landmarks
    near the border (the goals must be clamped)."""
    rng = np.random.default_rng(seed)
    inner = (0.5, 7.5, -3.5, 3.5)
    for c in range(n):
        if c % 3 == 0:
            side = np.pi * rng.choice([-1.0, 1.0]) + rng.uniform(-0.2, 0.2)   # around -x
        else:
            side = rng.uniform(-np.pi, np.pi)
        k = int(rng.integers(3, 15))
        ang = side + rng.uniform(-0.6, 0.6, k)
        sightings = np.column_stack([np.cos(ang), np.sin(ang)])
        if c % 4 == 1:                                  # near the border: clamping matters
            lm = np.array([rng.choice([0.7, 7.3]), rng.uniform(-3.0, 3.0)])
        else:
            lm = np.array([rng.uniform(2.0, 6.0), rng.uniform(-2.0, 2.0)])
        yield lm, sightings, 1.5, 0.3, inner


def check_return_waypoints(fn, n_cases: int = 10, seed: int = 5, verbose: bool = True) -> bool:
    """Check a student's ``fn(landmark, sightings, distance, approach, inner) -> (2, 2)``.

    The two goals of a return to ``landmark`` (2,): ``view``, ``distance`` from it on the
    side it was seen from (the mean of the unit vectors ``sightings`` (k, 2), from the
    landmark towards the robot, normalised), then ``closer``, ``approach`` from ``view``
    towards the landmark; each clamped to ``inner = (xmin, xmax, ymin, ymax)``. Computed
    here at seeded cases (:func:`return_waypoint_cases`); hints for a mean not normalised,
    the side reversed, the mean of the angles (wrong where they jump at +-pi), goals not
    clamped, and an approach away from the landmark.
    """
    say = printer(verbose)
    name = name_of(fn)
    for lm, u, dist, appr, inner in return_waypoint_cases(n_cases, seed):
        out = attempt(fn, lm.copy(), u.copy(), dist, appr, inner, say=say)
        if out is None:
            return False
        try:
            got = np.asarray(out, dtype=float)
        except (TypeError, ValueError):
            say(f"{name}: expected a (2, 2) array [view, closer], got {type(out).__name__}.")
            return False
        if got.shape != (2, 2):
            say(f"{name}: expected a (2, 2) array [view, closer], got shape {got.shape}.")
            return False
        want = _waypoints(lm, u, dist, appr, inner)
        if np.allclose(got, want, atol=1e-9):
            continue
        say(f"{name}: wrong for the landmark at {np.round(lm, 2).tolist()} seen in {len(u)} "
            f"frames: got {np.round(got, 3).tolist()}, expected {np.round(want, 3).tolist()}.")
        slips = [
            ({"normalise": False}, "the mean of unit vectors is shorter than 1 when they "
             "spread: normalise it, or the view point is closer than `distance`"),
            ({"sign": -1.0}, "the sightings point from the landmark TOWARDS the robot: the view "
             "point is landmark + distance * side, on the printed side, not behind the marker"),
            ({"angles": True}, "you averaged the angles: directions around -x have angles near "
             "+pi and -pi, whose mean points the other way. Average the unit vectors"),
        ]
        for kw, why in slips:
            if np.allclose(got, _waypoints(lm, u, dist, appr, inner, **kw), atol=1e-9):
                say(f"  Hint: {why}.")
                break
        else:
            unclamped = _waypoints(lm, u, dist, appr, (-np.inf, np.inf, -np.inf, np.inf))
            if np.allclose(got, unclamped, atol=1e-9):
                say("  Hint: both goals must be kept inside `inner` (clamp x and y), or a "
                    "landmark near the border sends the robot out of the world.")
            elif np.allclose(got[0], want[0], atol=1e-9):
                say("  Hint: the view point is right; `closer` moves `approach` metres from "
                    "it TOWARDS the landmark (the unit vector landmark - view), then is clamped.")
            else:
                say("  Hint: side = mean of the sightings, normalised; view = clamp(landmark + "
                    "distance * side); closer = clamp(view + approach * unit(landmark - view)).")
        return False
    say(f"{name}: correct. The two goals match at {n_cases} returns, some with sightings "
        f"around -x and some near the border.")
    return True
