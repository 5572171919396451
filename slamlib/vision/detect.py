"""Detecting ArUco markers and their pose (chapter 02).

:func:`detect_markers` runs OpenCV's ``ArucoDetector`` (sub-pixel corner refinement by
default), :func:`estimate_marker_pose` solves each marker's pose with IPPE_SQUARE and falls
back to SQPNP when it fails or returns NaN, and the marker centres become range and
bearing from the robot's origin (:func:`~slamlib.vision.camera.camera_to_range_bearing`).
:func:`draw_detections` draws the outlines, ids and axes.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..validate import as_positive
from .camera import Camera, _as_gray, camera_to_range_bearing
from .markers import _is_dictionary_file, get_dictionary, marker_object_points, read_dictionary

__all__ = ["Detections", "make_detector", "estimate_marker_pose", "detect_markers",
           "draw_detections"]


@dataclass
class Detections:
    """What :func:`detect_markers` found, one row per marker, sorted by id.

    Attributes
    ----------
    ids : (k,) int
    corners : (k, 4, 2) float, pixel corners in OpenCV's order (TL, TR, BR, BL)
    rvecs, tvecs : (k, 3) float, marker pose in the camera frame (Rodrigues, m)
    p_cam : (k, 3) marker centres in the camera frame C (equal to ``tvecs``)
    p_base : (k, 3) marker centres in the robot frame B
    z : (k, 2) ``[range, bearing]`` from B's origin, in B
    fallback : (k,) bool, True where IPPE_SQUARE failed and SQPNP was used
    """

    ids: np.ndarray
    corners: np.ndarray
    rvecs: np.ndarray
    tvecs: np.ndarray
    p_cam: np.ndarray
    p_base: np.ndarray
    z: np.ndarray
    fallback: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    @classmethod
    def empty(cls) -> Detections:
        return cls(np.zeros(0, int), np.zeros((0, 4, 2)), np.zeros((0, 3)), np.zeros((0, 3)),
                   np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0, bool))

@functools.lru_cache(maxsize=16)
def _detector(key, refine: str):
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = {
        "none": cv2.aruco.CORNER_REFINE_NONE, "subpix": cv2.aruco.CORNER_REFINE_SUBPIX,
        "contour": cv2.aruco.CORNER_REFINE_CONTOUR, "apriltag": cv2.aruco.CORNER_REFINE_APRILTAG,
    }[refine]
    return cv2.aruco.ArucoDetector(get_dictionary(key), params)

def make_detector(dictionary="DICT_ARUCO_ORIGINAL", refine: str = "subpix"):
    """A ``cv2.aruco.ArucoDetector`` for ``dictionary`` (cached for names and codes).

    ``refine``: corner refinement, ``"subpix"`` (default, OpenCV's default is
    none), ``"none"``, ``"contour"`` or ``"apriltag"``.
    """
    if refine not in ("none", "subpix", "contour", "apriltag"):
        raise ValueError(f"refine: expected 'none', 'subpix', 'contour' or 'apriltag', "
                         f"got {refine!r}")
    if _is_dictionary_file(dictionary):
        dictionary = read_dictionary(dictionary)
    get_dictionary(dictionary)                 # check it
    if isinstance(dictionary, str):
        return _detector(dictionary, refine)
    if isinstance(dictionary, (int, np.integer)):   # a code (an object's id key is not one)
        return _detector(int(dictionary), refine)
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = getattr(cv2.aruco, f"CORNER_REFINE_{refine.upper()}")
    return cv2.aruco.ArucoDetector(dictionary, params)

def estimate_marker_pose(corners, camera: Camera, marker_length: float
                         ) -> tuple[np.ndarray, np.ndarray, bool]:
    """Pose of one square marker from its four pixel corners (OpenCV's order).

    ``cv2.solvePnP`` with ``SOLVEPNP_IPPE_SQUARE``; if that fails or returns a
    non-finite answer (it can give NaN with ok=True on perfectly symmetric
    corner sets), ``SOLVEPNP_SQPNP`` instead.

    Returns
    -------
    rvec (3,), tvec (3,), used_fallback (bool)
        NaN vectors if both solvers fail.
    """
    c = np.asarray(corners, dtype=np.float64).reshape(4, 2)
    obj = marker_object_points(marker_length).astype(np.float64)
    K, dist = camera.K, camera.dist_coeffs
    try:
        ok, rvec, tvec = cv2.solvePnP(obj, c, K, dist, flags=cv2.SOLVEPNP_IPPE_SQUARE)
    except cv2.error:
        ok, rvec, tvec = False, None, None
    if ok and np.all(np.isfinite(rvec)) and np.all(np.isfinite(tvec)) and tvec.ravel()[2] > 0:
        return rvec.ravel(), tvec.ravel(), False
    try:
        ok, rvec, tvec = cv2.solvePnP(obj, c, K, dist, flags=cv2.SOLVEPNP_SQPNP)
    except cv2.error:
        ok = False
    if ok and np.all(np.isfinite(rvec)) and np.all(np.isfinite(tvec)):
        return rvec.ravel(), tvec.ravel(), True
    return np.full(3, np.nan), np.full(3, np.nan), True

def detect_markers(gray, camera: Camera, marker_length: float,
                   dictionary="DICT_ARUCO_ORIGINAL", *, refine: str = "subpix") -> Detections:
    """Find ArUco markers in an image and measure their range and bearing from the robot.

    1. ``cv2.aruco.ArucoDetector(dictionary, params).detectMarkers(gray)`` with
       sub-pixel corner refinement (``ids`` is (N,) in OpenCV 5 and (N, 1) in
       4.x: raveled; None means nothing found, an empty result).
    2. Each marker's pose in C by :func:`estimate_marker_pose` (IPPE_SQUARE,
       SQPNP fallback); its centre ``^C p`` is the translation.
    3. ``^B p = ^B T_C ^C p`` and ``z = [hypot(x, y), atan2(y, x)]`` in B.

    Parameters
    ----------
    gray : numpy.ndarray
        uint8 image of the camera's size, (H, W); a (H, W, 3) BGR image is converted.
    camera : Camera
    marker_length : float
        Side of the black square (m).
    dictionary : str, int, cv2.aruco.Dictionary or path
        A predefined dictionary's name or cv2 constant, a dictionary object,
        or the path of an OpenCV yml file with a custom dictionary.

    Returns
    -------
    Detections
        Sorted by id; markers whose pose cannot be computed are dropped.

    Raises
    ------
    ValueError
        ``gray`` not a non-empty uint8 image of the camera's size; bad
        ``marker_length`` or ``dictionary``.
    """
    if not isinstance(camera, Camera):
        raise ValueError(f"camera: expected a slamlib.vision.Camera, got {type(camera).__name__}")
    img = _as_gray(gray)
    if img.shape != (camera.height, camera.width):
        raise ValueError(f"gray: expected the camera's image size (H, W) = "
                         f"({camera.height}, {camera.width}), got {img.shape}")
    length = as_positive("marker_length", marker_length)
    detector = make_detector(dictionary, refine)
    corners, ids, _ = detector.detectMarkers(img)
    if ids is None or len(ids) == 0:
        return Detections.empty()
    ids = np.ravel(ids).astype(int)
    corners = np.array([np.asarray(c, dtype=np.float64).reshape(4, 2) for c in corners])
    order = np.argsort(ids, kind="stable")
    ids, corners = ids[order], corners[order]
    rv, tv, fb = [], [], []
    for c in corners:
        r, t, f = estimate_marker_pose(c, camera, length)
        rv.append(r)
        tv.append(t)
        fb.append(f)
    rv, tv, fb = np.array(rv), np.array(tv), np.array(fb, bool)
    keep = np.all(np.isfinite(tv), axis=1) & np.all(np.isfinite(rv), axis=1)
    ids, corners, rv, tv, fb = ids[keep], corners[keep], rv[keep], tv[keep], fb[keep]
    if ids.size == 0:
        return Detections.empty()
    T = camera.T_base_cam
    p_base = tv @ T[:3, :3].T + T[:3, 3]
    z = camera_to_range_bearing(tv, T).reshape(-1, 2)
    return Detections(ids, corners, rv, tv, tv.copy(), p_base, z, fb)

def draw_detections(gray, det: Detections, camera: Camera, marker_length: float, *,
                    axis_length: float | None = None, ids: bool = True) -> np.ndarray:
    """A BGR copy of ``gray`` with the detected outlines, ids and pose axes drawn.

    Outlines and ids by ``cv2.aruco.drawDetectedMarkers``, each marker's frame
    by ``cv2.drawFrameAxes`` (x red, y green, z blue, ``axis_length`` m long,
    default half the marker's side).
    """
    img = _as_gray(gray)
    out = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    if len(det) == 0:
        return out
    corners = [c.reshape(1, 4, 2).astype(np.float32) for c in det.corners]
    cv2.aruco.drawDetectedMarkers(out, corners,
                                  det.ids.reshape(-1, 1).astype(np.int32) if ids else None)
    length = 0.5 * marker_length if axis_length is None else axis_length
    for r, t in zip(det.rvecs, det.tvecs):
        cv2.drawFrameAxes(out, camera.K, camera.dist_coeffs, r, t, length, 2)
    return out
