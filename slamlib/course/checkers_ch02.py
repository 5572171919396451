"""Chapter 02's exercise checker: a marker centre in the camera frame to [range, bearing].

The verdicts follow :mod:`slamlib.course.harness`.
"""

from __future__ import annotations

import numpy as np

from ..models import wrap_angle
from .harness import attempt, name_of, printer, vector_answer

__all__ = ["check_camera_to_range_bearing"]


def _random_mount(rng) -> np.ndarray:
    """A camera mount ``^B T_C``: the forward-looking axes, turned a little, moved a little."""
    from ..vision import R_BASE_CAM

    yaw, pitch, roll = rng.uniform(-0.5, 0.5), rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2)
    cz, sz, cy, sy, cx, sx = (np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch),
                              np.cos(roll), np.sin(roll))
    Rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    Ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    T = np.eye(4)
    T[:3, :3] = Rz @ Ry @ Rx @ R_BASE_CAM
    T[:3, 3] = [rng.uniform(0.0, 0.3), rng.uniform(-0.15, 0.15), rng.uniform(-0.2, 0.2)]
    return T


def check_camera_to_range_bearing(fn, n_points: int = 8, seed: int = 2,
                                  verbose: bool = True) -> bool:
    """Check a student's ``fn(p_cam, T_base_cam) -> [rho, bearing]`` (chapter 02).

    ``p_cam`` is a marker centre (3,) in the camera's optical frame and
    ``T_base_cam`` the 4x4 ``^B T_C``; the answer is the range projected on the
    floor and the bearing (rad), both from the robot's origin, as
    :func:`slamlib.vision.camera_to_range_bearing` computes them. The first
    point uses the course's camera, the others other mounts (turned and moved),
    so an answer that ignores ``T_base_cam`` fails. Common mistakes are named:
    measuring from the camera, ``^C T_B`` used for ``^B T_C``, the rotation
    transposed or forgotten, a 3-D range, the bearing in degrees, atan2's
    arguments swapped, a flipped bearing, the optical axes taken as the robot's.
    """
    from ..vision import camera_to_range_bearing, default_camera

    say = printer(verbose)

    name = name_of(fn)
    rng = np.random.default_rng(seed)
    cases = []
    for k in range(n_points):
        T = default_camera().T_base_cam if k == 0 else _random_mount(rng)
        p = np.array([rng.uniform(-1.0, 1.0), rng.uniform(-0.1, 0.1), rng.uniform(0.5, 4.0)])
        cases.append((p, T))

    def rb(q):
        return np.array([np.hypot(q[0], q[1]), np.arctan2(q[1], q[0])])

    def same(a, b):
        return abs(a[0] - b[0]) < 1e-6 and abs(wrap_angle(a[1] - b[1])) < 1e-6

    for p, T in cases:
        out = attempt(fn, p.copy(), T.copy(), say=say)
        if out is None:
            return False
        got, problem = vector_answer(out, 2, "[rho, bearing]")
        if problem:
            say(f"{name}: {problem}")
            return False
        want = camera_to_range_bearing(p, T)
        if np.all(np.isfinite(got)) and same(got, want):
            continue
        R, t = T[:3, :3], T[:3, 3]
        pb = R @ p + t
        # whole answers that a known mistake produces
        wrong_answers = [
            (rb(R @ p), "the range and bearing are measured from the camera: add the mount "
                        "offset t = T_base_cam[:3, 3] to get the point from B's origin"),
            (rb(R.T @ (p - t)), "you used ^C T_B (the inverse) instead of ^B T_C: T_base_cam "
                                "already carries camera points into B, ^B p = R ^C p + t"),
            (rb(R.T @ p + t), "the rotation is transposed: ^B p = R ^C p + t with "
                              "R = T_base_cam[:3, :3] (its columns are C's axes in B)"),
            (rb(p + t), "the rotation is forgotten: the camera's axes are not the robot's "
                        "(x_B = z_C, y_B = x_C, z_B = y_C for the course's camera), "
                        "^B p = R ^C p + t"),
            (rb(p), "the point is used as it is: carry it into B first, ^B p = R ^C p + t"),
        ]
        T0 = default_camera().T_base_cam
        if not np.allclose(T, T0):
            wrong_answers.append((rb(T0[:3, :3] @ p + T0[:3, 3]),
                                  "the answer ignores T_base_cam (it is right for the course's "
                                  "camera only): use the matrix you are given"))
        hints = [h for z, h in wrong_answers if np.all(np.isfinite(got)) and same(got, z)]
        if not hints:
            if np.isclose(got[0], np.linalg.norm(pb)):
                hints.append("the range includes the height: project on the floor, "
                             "hypot(x_B, y_B)")
            if np.isclose(got[0], np.hypot(pb[0], pb[2])) or np.isclose(got[0],
                                                                      np.hypot(p[0], p[1])):
                hints.append("the axes are mixed up: use the rotation T_base_cam[:3, :3]")
            if np.isclose(got[1], np.degrees(want[1])):
                hints.append("the bearing is in degrees: the filters work in radians")
            elif np.isclose(got[1], np.arctan2(pb[0], pb[1])):
                hints.append("atan2's arguments are swapped: the bearing is atan2(y_B, x_B)")
            elif np.isclose(got[1], -want[1]):
                hints.append("the bearing's sign is flipped: in the z-down frame a point to "
                             "the right has a positive bearing, atan2(y_B, x_B)")
        hint = (" Hint: " + "; ".join(hints) + ".") if hints else ""
        mount = ("the course's camera" if np.allclose(T, T0)
                 else f"a camera mounted at t = [{t[0]:.3f}, {t[1]:.3f}, {t[2]:.3f}], turned")
        say(f"{name}: wrong for p_cam = [{p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}] and {mount}: "
            f"got [{got[0]:.4f}, {got[1]:.4f}], expected [{want[0]:.4f}, {want[1]:.4f}].{hint}")
        return False
    say(f"{name}: correct at {len(cases)} points, with the course's camera and "
        f"{len(cases) - 1} other mounts.")
    return True
