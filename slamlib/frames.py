"""Bringing z-up (ROS REP-103) data into the course's z-down frame (chapter 00).

The report's world frame N is z-down: x forward, y to the right, z into the
floor. ROS uses z-up: x forward, y to the left, z up. The two share x and
differ by a half turn about it, which in the plane is a mirror of y: a point
``(x, y)`` becomes ``(x, -y)`` and every angle (heading, bearing, yaw rate)
changes sign. Wheel speeds are physical and need no change; only the formula
for the yaw rate flips, ``w_zup = (V_R - V_L)/b`` against ``w_zdown = (V_L - V_R)/b``.
"""

from __future__ import annotations

import numpy as np

from .models import wrap_angle
from .validate import as_matrix

__all__ = ["pose_from_zup", "points_from_zup", "angles_from_zup", "pose_to_zup"]


def pose_from_zup(poses) -> np.ndarray:
    """Mirror pose(s) ``[x, y, yaw]`` (shape (3,) or (n, 3)) from z-up into z-down."""
    p = np.array(poses, dtype=float)
    single = p.ndim == 1
    p = as_matrix("poses", p.reshape(1, -1) if single else p, (None, 3)).copy()
    p[:, 1] = -p[:, 1]
    p[:, 2] = wrap_angle(-p[:, 2])
    return p[0] if single else p


#: The mirror is its own inverse.
pose_to_zup = pose_from_zup


def points_from_zup(points) -> np.ndarray:
    """Mirror point(s) ``[x, y]`` (shape (2,) or (n, 2)) from z-up into z-down."""
    p = np.array(points, dtype=float)
    single = p.ndim == 1
    p = as_matrix("points", p.reshape(1, -1) if single else p, (None, 2)).copy()
    p[:, 1] = -p[:, 1]
    return p[0] if single else p


def angles_from_zup(angles):
    """Negate (and wrap) angles, bearings or yaw rates measured in a z-up frame."""
    return wrap_angle(-np.asarray(angles, dtype=float))
