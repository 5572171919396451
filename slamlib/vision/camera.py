"""The camera and its calibration (chapter 02): intrinsics, the mount ^B T_C, calibration I/O.

:class:`Camera` holds K, the distortion, the mount and the image size; :func:`load_camera`,
:func:`save_camera` and :func:`default_camera` read and write it as JSON in
``data/calibration`` (``slamlib-camera/1``), :func:`read_opencv_calibration` reads OpenCV's
YAML files and :func:`calibrate_charuco` calibrates from ChArUco photos.
:func:`camera_to_range_bearing` carries a point of the optical frame C through the mount
into the robot's [range, bearing]. The frames are described in :mod:`slamlib.vision`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ..validate import as_matrix, as_positive, as_vector, read_json_file
from ..worlds import DATA_DIR
from .markers import get_dictionary
from .opencv_files import open_storage

__all__ = ["R_BASE_CAM", "DEFAULT_BASE_HEIGHT", "CALIBRATION_DIR", "CalibrationFormatError",
           "Camera", "base_pose_matrix", "camera_from_dict", "load_camera",
           "read_opencv_calibration", "CharucoCalibration", "calibrate_charuco", "save_camera",
           "default_camera", "camera_to_range_bearing"]


#: Rotation block of ^B T_C: columns are C's axes in B (x_B = z_C, y_B = x_C, z_B = y_C).
R_BASE_CAM = np.array([[0.0, 0.0, 1.0],
                       [1.0, 0.0, 0.0],
                       [0.0, 1.0, 0.0]])

#: Height (m) of the robot frame's origin above the floor (not in the report; a choice
#: that puts the camera at 0.148 m, level with the marker centres).
DEFAULT_BASE_HEIGHT = 0.23

CALIBRATION_DIR = DATA_DIR / "calibration"

CAMERA_FORMAT = "slamlib-camera/1"

class CalibrationFormatError(ValueError):
    """A calibration file is malformed; the message names the file and the field."""

class Camera:
    """A calibrated pinhole camera mounted on the robot.

    Parameters
    ----------
    K : array_like, shape (3, 3)
        Intrinsics ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` in pixels (OpenCV's
        convention: pixel (0, 0)'s centre is at (0, 0)).
    dist : array_like, shape (5,), or None
        OpenCV distortion ``[k1, k2, p1, p2, k3]``; None for none. The renderer
        draws an ideal pinhole image and ignores it; the detector uses it.
    T_base_cam : array_like, shape (4, 4)
        ``^B T_C``: camera optical frame to robot frame.
    width, height : int
        Image size in pixels.
    base_height : float
        Height (m) of B's origin above the floor (used by the renderer).
    name : str
        Free text.
    """

    def __init__(self, K, dist, T_base_cam, width: int, height: int, *,
                 base_height: float = DEFAULT_BASE_HEIGHT, name: str = ""):
        K = as_matrix("K", K, (3, 3))
        if not (K[0, 0] > 0 and K[1, 1] > 0 and np.allclose(K[2], [0, 0, 1])
                and K[1, 0] == 0 and K[0, 1] == 0):
            raise ValueError("K: expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0, "
                             f"got {K.tolist()}")
        if dist is not None:
            dist = as_vector("dist", dist, 5)
        T = as_matrix("T_base_cam", T_base_cam, (4, 4))
        R = T[:3, :3]
        if not (np.allclose(T[3], [0, 0, 0, 1]) and np.allclose(R.T @ R, np.eye(3), atol=1e-6)
                and np.linalg.det(R) > 0):
            raise ValueError("T_base_cam: expected a rigid transform (rotation block orthonormal "
                             "with det +1, last row [0, 0, 0, 1])")
        for nm, v in (("width", width), ("height", height)):
            if isinstance(v, bool) or int(v) != v or v <= 0:
                raise ValueError(f"{nm}: expected a positive integer, got {v!r}")
        self.K = K
        self.dist = dist
        self.T_base_cam = T
        self.width, self.height = int(width), int(height)
        self.base_height = as_positive("base_height", base_height)
        if self.base_height - T[2, 3] <= 0:
            raise ValueError(f"base_height: the camera would be below the floor "
                             f"(base_height {self.base_height} - z_B {T[2, 3]} <= 0)")
        self.name = str(name)

    # convenience -------------------------------------------------------------
    fx = property(lambda self: float(self.K[0, 0]), doc="Focal length along x (px).")
    fy = property(lambda self: float(self.K[1, 1]), doc="Focal length along y (px).")
    cx = property(lambda self: float(self.K[0, 2]), doc="Principal point x (px).")
    cy = property(lambda self: float(self.K[1, 2]), doc="Principal point y (px).")

    @property
    def dist_coeffs(self) -> np.ndarray:
        """Distortion as OpenCV wants it (zeros when ``dist`` is None)."""
        return np.zeros(5) if self.dist is None else self.dist

    @property
    def T_cam_base(self) -> np.ndarray:
        """``^C T_B``, the inverse of :attr:`T_base_cam`."""
        R, t = self.T_base_cam[:3, :3], self.T_base_cam[:3, 3]
        T = np.eye(4)
        T[:3, :3] = R.T
        T[:3, 3] = -R.T @ t
        return T

    @property
    def camera_height(self) -> float:
        """Height (m) of the optical centre above the floor."""
        return self.base_height - float(self.T_base_cam[2, 3])

    @property
    def hfov(self) -> float:
        """Horizontal field of view (rad)."""
        return 2.0 * math.atan2(self.width / 2.0, self.fx)

    def world_from_camera(self, pose) -> np.ndarray:
        """``^N T_C`` for a robot at planar ``pose = [x, y, theta]`` in N."""
        return base_pose_matrix(pose, self.base_height) @ self.T_base_cam

    def project(self, p_cam) -> np.ndarray:
        """Pixel coordinates (n, 2) of camera-frame points (n, 3) with z > 0 (pinhole + dist)."""
        p = as_matrix("p_cam", np.atleast_2d(p_cam), (None, 3))
        if self.dist is None or not np.any(self.dist):
            return (p[:, :2] / p[:, 2:3]) * [self.fx, self.fy] + [self.cx, self.cy]
        uv, _ = cv2.projectPoints(p, np.zeros(3), np.zeros(3), self.K, self.dist)
        return uv.reshape(-1, 2)

    def to_dict(self) -> dict:
        """The JSON object of this camera (format ``slamlib-camera/1``)."""
        return {"format": CAMERA_FORMAT, "name": self.name, "width": self.width,
                "height": self.height, "K": self.K.tolist(),
                "dist": None if self.dist is None else self.dist.tolist(),
                "T_base_cam": self.T_base_cam.tolist(), "base_height": self.base_height}

    def __repr__(self) -> str:
        t = self.T_base_cam[:3, 3]
        return (f"Camera({self.name or 'unnamed'}: {self.width}x{self.height}, "
                f"fx={self.fx:g}, fy={self.fy:g}, cx={self.cx:g}, cy={self.cy:g}, "
                f"at B ({t[0]:g}, {t[1]:g}, {t[2]:g}), base_height={self.base_height:g})")

def base_pose_matrix(pose, base_height: float = DEFAULT_BASE_HEIGHT) -> np.ndarray:
    """``^N T_B`` (4x4) of a robot at ``[x, y, theta]``; B's origin ``base_height`` above the floor.

    N is z-down, so the origin is at ``z = -base_height``.
    """
    pose = as_vector("pose", pose, 3)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    T = np.eye(4)
    T[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    T[:3, 3] = [pose[0], pose[1], -float(base_height)]
    return T

def _field(where: str, d: dict, key: str):
    if key not in d:
        raise CalibrationFormatError(f"{where}: missing field '{key}'")
    return d[key]

def camera_from_dict(d: dict, where: str = "camera") -> Camera:
    """Build a :class:`Camera` from its JSON object, checking every field."""
    if not isinstance(d, dict):
        raise CalibrationFormatError(f"{where}: expected a JSON object at the top level")
    if d.get("format") != CAMERA_FORMAT:
        raise CalibrationFormatError(f"{where}.format: expected '{CAMERA_FORMAT}', "
                                     f"got {d.get('format')!r}")
    kw = {}
    for key in ("K", "dist", "T_base_cam", "width", "height"):
        kw[key] = _field(where, d, key)
    try:
        return Camera(kw["K"], kw["dist"], kw["T_base_cam"], kw["width"], kw["height"],
                      base_height=d.get("base_height", DEFAULT_BASE_HEIGHT),
                      name=str(d.get("name", "")))
    except (ValueError, TypeError) as exc:
        raise CalibrationFormatError(f"{where}: {exc}") from exc

def load_camera(path="realsense_640x480") -> Camera:
    """Load a camera from a JSON file (a bare name is looked up in ``data/calibration``).

    Raises
    ------
    CalibrationFormatError
        With the file and the offending field in the message.
    """
    d, p = read_json_file(path, CalibrationFormatError, CALIBRATION_DIR)
    return camera_from_dict(d, where=str(p))

def read_opencv_calibration(path, width: int | None = None, height: int | None = None,
                            T_base_cam=None) -> Camera:
    """A camera from an OpenCV calibration yml (``camera_matrix``, ``distortion_coefficients``,
    optionally ``image_width``/``image_height``), e.g. OpenCV's tutorial files (chapter 02).

    ``T_base_cam`` defaults to the identity (the camera frame is the "robot" frame);
    ``width``/``height`` are needed when the file does not give them.
    """
    path = Path(path)
    fs = open_storage(path, CalibrationFormatError)
    try:
        K = fs.getNode("camera_matrix").mat()
        dist = fs.getNode("distortion_coefficients").mat()
        w = fs.getNode("image_width")
        h = fs.getNode("image_height")
        w = int(w.real()) if not w.empty() else width
        h = int(h.real()) if not h.empty() else height
    finally:
        fs.release()
    if K is None or K.shape != (3, 3):
        raise CalibrationFormatError(f"{path}: field 'camera_matrix': expected a 3x3 matrix")
    if dist is None or dist.size not in (4, 5):
        raise CalibrationFormatError(f"{path}: field 'distortion_coefficients': expected "
                                     f"4 or 5 coefficients [k1, k2, p1, p2(, k3)]")
    if w is None or h is None:
        raise CalibrationFormatError(f"{path}: no image_width/image_height: pass width and "
                                     f"height")
    T = np.eye(4) if T_base_cam is None else T_base_cam
    try:
        return Camera(K, np.r_[dist.reshape(-1), 0.0][:5], T, w, h, name=path.stem)
    except (ValueError, TypeError) as exc:
        raise CalibrationFormatError(f"{path}: {exc}") from exc

@dataclass(frozen=True)
class CharucoCalibration:
    """What :func:`calibrate_charuco` found: ``rms`` reprojection error (px), ``K``, ``dist``
    (5,), the ChArUco corners found in each image, and the image size ``(width, height)``."""

    rms: float
    K: np.ndarray
    dist: np.ndarray
    corners_per_image: tuple
    size: tuple

def calibrate_charuco(images, squares=(5, 7), square_length: float = 0.04,
                      marker_length: float = 0.02, dictionary="DICT_6X6_250",
                      min_corners: int = 6) -> CharucoCalibration:
    """Calibrate a camera from photos of a ChArUco board with OpenCV (chapter 02).

    ``cv2.aruco.CharucoDetector(board).detectBoard`` finds the chessboard
    corners between the markers in each image, ``board.matchImagePoints``
    pairs them with the board's 3-D points, and ``cv2.calibrateCamera`` fits
    ``K`` and the distortion ``[k1, k2, p1, p2, k3]``. Images with fewer than
    ``min_corners`` corners are left out.
    """
    board = cv2.aruco.CharucoBoard(tuple(int(n) for n in squares), float(square_length),
                                   float(marker_length), get_dictionary(dictionary))
    detector = cv2.aruco.CharucoDetector(board)
    objs, pix, counts, size = [], [], [], None
    for img in images:
        gray = _as_gray(img)
        size = (gray.shape[1], gray.shape[0]) if size is None else size
        if (gray.shape[1], gray.shape[0]) != size:
            raise ValueError(f"images: expected all of size {size}, got {gray.shape[::-1]}")
        cc, ci, _, _ = detector.detectBoard(gray)
        n = 0 if ci is None else len(ci)
        counts.append(n)
        if n >= min_corners:
            o, p = board.matchImagePoints(cc, ci)
            objs.append(o)
            pix.append(p)
    if len(objs) < 1:
        raise ValueError(f"images: no image shows at least {min_corners} ChArUco corners")
    rms, K, dist, _, _ = cv2.calibrateCamera(objs, pix, size, None, None)
    return CharucoCalibration(float(rms), K, dist.reshape(-1)[:5], tuple(counts), size)

def save_camera(camera: Camera, path) -> None:
    """Write a camera as indented JSON."""
    Path(path).write_text(json.dumps(camera.to_dict(), indent=2) + "\n", encoding="utf-8")

def default_camera() -> Camera:
    """The report's RealSense colour camera (``data/calibration/realsense_640x480.json``)."""
    return load_camera("realsense_640x480")

def camera_to_range_bearing(p_cam, T_base_cam) -> np.ndarray:
    """Range and bearing in B of point(s) given in the camera frame (report IV).

    ``^B p = ^B T_C [^C p, 1]``, ``rho = hypot(^B x, ^B y)`` (the range projected on
    the floor plane, from B's origin), ``beta = atan2(^B y, ^B x)``.

    Parameters
    ----------
    p_cam : array_like, shape (3,) or (k, 3)
    T_base_cam : array_like, shape (4, 4)

    Returns
    -------
    numpy.ndarray, shape (2,) or (k, 2)
    """
    T = as_matrix("T_base_cam", T_base_cam, (4, 4))
    p = np.asarray(p_cam, dtype=float)
    single = p.ndim == 1
    p = as_matrix("p_cam", p.reshape(1, -1) if single else p, (None, 3))
    pb = p @ T[:3, :3].T + T[:3, 3]
    z = np.column_stack([np.hypot(pb[:, 0], pb[:, 1]), np.arctan2(pb[:, 1], pb[:, 0])])
    return z[0] if single else z

def _as_gray(gray) -> np.ndarray:
    if not isinstance(gray, np.ndarray):
        raise ValueError(f"gray: expected a numpy uint8 image of shape (H, W), "
                         f"got {type(gray).__name__}")
    want = "a uint8 image of shape (H, W) (a (H, W, 3) BGR image is converted)"
    if gray.dtype != np.uint8:
        raise ValueError(f"gray: expected {want}, got dtype {gray.dtype}")
    if gray.size == 0:
        raise ValueError(f"gray: expected {want}, got an empty array of shape {gray.shape}")
    if gray.ndim == 3 and gray.shape[2] == 1:
        gray = gray[:, :, 0]
    elif gray.ndim == 3 and gray.shape[2] == 3:
        gray = cv2.cvtColor(gray, cv2.COLOR_BGR2GRAY)
    elif gray.ndim == 3 and gray.shape[2] == 4:
        gray = cv2.cvtColor(gray, cv2.COLOR_BGRA2GRAY)
    if gray.ndim != 2:
        raise ValueError(f"gray: expected {want}, got shape {gray.shape}")
    return np.ascontiguousarray(gray)
