"""The camera pipeline: render a marker world, detect ArUco markers, range and bearing (chapter 02).

The report's robot sees its landmarks through a camera (report IV): OpenCV finds
the ArUco markers in the image, a perspective-n-point solver gives each
marker's centre ``^C p`` in the camera's optical frame C, the fixed mount
``^B T_C`` carries it into the robot frame B, and the filter is given the
*projected* range and bearing from B's origin::

    ^B p = ^B T_C ^C p,   rho = hypot(^B x, ^B y),   beta = atan2(^B y, ^B x)

Frames
------
- N, the world: z-down (x forward/north, y right, z into the floor).
- B, the robot: z-down (x forward, y right, z down); its origin stands
  ``base_height`` above the floor.
- C, the camera's optical frame (OpenCV): x right, y down, z forward along the
  optical axis; ``x_B = z_C, y_B = x_C, z_B = y_C``.
- A marker's own frame (OpenCV's ArUco convention): origin at the centre of the
  black square, x to the right and y up as seen by someone facing the printed
  side, z out of the printed side. Its corners are listed top-left,
  top-right, bottom-right, bottom-left.

What is here
------------
- :class:`Camera`, :func:`load_camera`, :func:`default_camera`: intrinsics and
  mount, stored as JSON in ``data/calibration``.
- :func:`render_view`: the camera's grayscale view of a :class:`~slamlib.worlds.World`
  from a robot pose (floor, markers with their white quiet zone on posts, in
  perspective, back faces culled, near/far clipping, painter's order,
  anti-aliasing by supersampling, optional blur and pixel noise).
- :func:`detect_markers`: OpenCV's ArUco detector with sub-pixel corner
  refinement, IPPE_SQUARE pose with an SQPNP fallback, range and bearing.
- :class:`CameraMarkerSensor`: render + detect as a drop-in marker sensor for
  the simulator.
- :func:`error_study`, :func:`fit_noise_model`, :class:`NoiseModel`: measure the
  bias and noise of range and bearing against ground truth and turn them into
  the filter's R (and a range-bias correction).
"""

from __future__ import annotations

import functools
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from .models import inverse_observe, observe, wrap_angle
from .sensors import Observations
from .validate import as_finite_scalar, as_matrix, as_positive, as_vector, read_json_file
from .worlds import DATA_DIR, Marker, World

__all__ = [
    "MIN_OPENCV", "R_BASE_CAM", "DEFAULT_BASE_HEIGHT", "CALIBRATION_DIR",
    "CalibrationFormatError", "Camera", "load_camera", "save_camera", "default_camera",
    "read_opencv_calibration", "CharucoCalibration", "calibrate_charuco",
    "camera_to_range_bearing", "base_pose_matrix",
    "get_dictionary", "read_dictionary", "marker_image", "marker_object_points",
    "marker_corners_world",
    "project_marker_corners", "visible_markers", "render_view",
    "Detections", "make_detector", "estimate_marker_pose", "detect_markers",
    "CameraMarkerSensor", "match_ground_truth",
    "single_marker_scene", "ErrorStudy", "error_study", "NoiseModel", "fit_noise_model",
    "DEFAULT_NOISE_MODEL", "draw_detections",
]

# --------------------------------------------------------------------------- OpenCV version
#: The oldest OpenCV this module supports (ArucoDetector API and IPPE_SQUARE behaviour).
MIN_OPENCV = (4, 9)


def _opencv_version(text: str) -> tuple[int, int]:
    m = re.match(r"(\d+)\.(\d+)", text)
    return (int(m.group(1)), int(m.group(2))) if m else (0, 0)


if _opencv_version(cv2.__version__) < MIN_OPENCV or not hasattr(cv2, "aruco") \
        or not hasattr(cv2.aruco, "ArucoDetector"):
    raise ImportError(
        f"slamlib.vision needs OpenCV >= {MIN_OPENCV[0]}.{MIN_OPENCV[1]} with the "
        f"cv2.aruco.ArucoDetector API; found OpenCV {cv2.__version__}. "
        "Install the pinned version: pip install -r environment.txt")

# --------------------------------------------------------------------------- camera
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
    if not path.is_file():
        raise CalibrationFormatError(f"{path}: missing file")
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
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


# --------------------------------------------------------------------------- markers
def _is_dictionary_file(dictionary) -> bool:
    return isinstance(dictionary, Path) or (
        isinstance(dictionary, str) and dictionary.lower().endswith((".yml", ".yaml")))


def read_dictionary(path) -> cv2.aruco.Dictionary:
    """A custom ArUco dictionary from an OpenCV yml file (``nmarkers``, ``markersize``,
    ``marker_0``...), as OpenCV writes it (chapter 02's real photos)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"dictionary: no such dictionary file {str(path)!r}")
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        d = cv2.aruco.Dictionary()
        ok = fs.isOpened() and d.readDictionary(fs.root())
    finally:
        fs.release()
    if not ok:
        raise ValueError(f"dictionary: {str(path)!r} is not an ArUco dictionary file "
                         f"(expected nmarkers, markersize and marker_0...)")
    return d


def get_dictionary(dictionary="DICT_ARUCO_ORIGINAL"):
    """An ArUco dictionary from its name (``"DICT_ARUCO_ORIGINAL"``), cv2 constant, object,
    or the path of a yml file holding a custom one (:func:`read_dictionary`)."""
    if isinstance(dictionary, cv2.aruco.Dictionary):
        return dictionary
    if _is_dictionary_file(dictionary):
        return read_dictionary(dictionary)
    if isinstance(dictionary, str):
        code = getattr(cv2.aruco, dictionary, None)
        if not dictionary.startswith("DICT_") or not isinstance(code, int):
            raise ValueError(f"dictionary: expected an ArUco dictionary name such as "
                             f"'DICT_ARUCO_ORIGINAL', got {dictionary!r}")
        return _predefined(code)
    if isinstance(dictionary, (int, np.integer)) and not isinstance(dictionary, bool):
        return _predefined(int(dictionary))
    raise ValueError(f"dictionary: expected a name, a cv2.aruco constant or a "
                     f"cv2.aruco.Dictionary, got {dictionary!r}")


@functools.cache
def _predefined(code: int):
    return cv2.aruco.getPredefinedDictionary(code)


def _dict_key(dictionary):
    """A hashable key for caches (names and codes; objects by id)."""
    return dictionary if isinstance(dictionary, (str, int)) else id(dictionary)


@functools.lru_cache(maxsize=4096)
def _marker_texture(key, marker_id: int, cell_px: int, quiet_cells: float) -> np.ndarray:
    d = get_dictionary(key)
    cells = d.markerSize + 2                      # the code plus its black border
    img = cv2.aruco.generateImageMarker(d, int(marker_id), cells * cell_px, borderBits=1)
    q = int(round(quiet_cells * cell_px))
    img = cv2.copyMakeBorder(img, q, q, q, q, cv2.BORDER_CONSTANT, value=255)
    img.setflags(write=False)
    return img


def marker_image(marker_id: int, dictionary="DICT_ARUCO_ORIGINAL", cell_px: int = 16,
                 quiet_cells: float = 1.0) -> np.ndarray:
    """The printed marker: black square with its code, and a white quiet zone around it.

    Made with ``cv2.aruco.generateImageMarker``; the quiet zone is ``quiet_cells``
    code cells wide on each side (the detector needs white around the black
    border to find it). Returns a uint8 image, 0 black, 255 white.
    """
    d = get_dictionary(dictionary)
    mid = int(marker_id)
    if mid < 0 or mid >= d.bytesList.shape[0]:
        raise ValueError(f"marker_id: expected 0..{d.bytesList.shape[0] - 1} for this "
                         f"dictionary, got {marker_id}")
    key = _dict_key(dictionary) if not isinstance(dictionary, cv2.aruco.Dictionary) else d
    if not isinstance(key, (str, int)):
        cells = d.markerSize + 2
        img = cv2.aruco.generateImageMarker(d, mid, cells * cell_px, borderBits=1)
        q = int(round(quiet_cells * cell_px))
        return cv2.copyMakeBorder(img, q, q, q, q, cv2.BORDER_CONSTANT, value=255)
    return _marker_texture(key, mid, int(cell_px), float(quiet_cells)).copy()


def marker_object_points(marker_length: float) -> np.ndarray:
    """The four corners of the black square in the marker's frame, OpenCV's ArUco order.

    Top-left, top-right, bottom-right, bottom-left, with x right and y up as
    seen facing the printed side, z = 0: shape (4, 3), float32.
    """
    h = 0.5 * as_positive("marker_length", marker_length)
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]], dtype=np.float32)


def _marker_axes(yaw: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The marker frame's x (right), y (up) and z (out of the face) axes in N (z-down)."""
    c, s = math.cos(yaw), math.sin(yaw)
    n = np.array([c, s, 0.0])
    up = np.array([0.0, 0.0, -1.0])
    right = np.cross(up, n)                      # (s, -c, 0): x = y cross z
    return right, up, n


def _marker_centre(marker: Marker, height: float) -> np.ndarray:
    return np.array([marker.x, marker.y, -height])


def marker_corners_world(marker: Marker, marker_length: float, marker_height: float,
                         scale: float = 1.0) -> np.ndarray:
    """Corners (4, 3) in N of a marker's square of side ``scale * marker_length``, ArUco order."""
    right, up, _ = _marker_axes(marker.yaw)
    h = 0.5 * marker_length * scale
    c = _marker_centre(marker, marker_height)
    return np.array([c - h * right + h * up, c + h * right + h * up,
                     c + h * right - h * up, c - h * right - h * up])


def _to_camera(T_cam_world: np.ndarray, pts: np.ndarray) -> np.ndarray:
    return pts @ T_cam_world[:3, :3].T + T_cam_world[:3, 3]


def _cam_world(camera: Camera, pose) -> tuple[np.ndarray, np.ndarray]:
    """(``^C T_N``, camera centre in N)."""
    T_wc = camera.world_from_camera(pose)
    R, t = T_wc[:3, :3], T_wc[:3, 3]
    T = np.eye(4)
    T[:3, :3] = R.T
    T[:3, 3] = -R.T @ t
    return T, t


def project_marker_corners(world: World, marker_id: int, pose, camera: Camera) -> np.ndarray:
    """True pixel positions (4, 2) of a marker's black-square corners (ArUco order).

    NaN when a corner lies behind the camera.
    """
    m = world.marker(marker_id)
    T_cw, _ = _cam_world(camera, pose)
    pc = _to_camera(T_cw, marker_corners_world(m, world.marker_length, world.marker_height))
    uv = np.full((4, 2), np.nan)
    front = pc[:, 2] > 1e-9
    if np.any(front):
        uv[front] = camera.project(pc[front])
    return uv


@dataclass
class _Face:
    """One thing to paint: a planar quad in N with a texture."""

    depth: float
    order: int
    corners: np.ndarray            # (4, 3) in N, texture order TL, TR, BR, BL
    texture: np.ndarray            # uint8
    marker_id: int = -1
    front: bool = False


def _quiet_scale(world: World, quiet_cells: float) -> float:
    cells = get_dictionary(world.dictionary).markerSize + 2
    return (cells + 2.0 * quiet_cells) / cells


def _scene_faces(world: World, pose, camera: Camera, *, quiet_cells: float, near: float,
                 far: float, post_width: float, cell_px: int) -> tuple[list, np.ndarray]:
    """The quads to paint (front faces, backs, posts), culled and clipped; and ^C T_N."""
    T_cw, cam_pos = _cam_world(camera, pose)
    scale = _quiet_scale(world, quiet_cells)
    board_half = 0.5 * world.marker_length * scale
    key = _dict_key(world.dictionary)
    faces = []
    back_tex = np.full((2, 2), 150, np.uint8)
    post_tex = np.full((2, 2), 70, np.uint8)
    for k, m in enumerate(world.markers):
        right, up, n = _marker_axes(m.yaw)
        centre = _marker_centre(m, world.marker_height)
        dist = float(np.linalg.norm(centre - cam_pos))
        if dist > far:
            continue
        board = marker_corners_world(m, world.marker_length, world.marker_height, scale)
        # the post: from the board's lower edge to the floor, just behind the board
        bottom = world.marker_height - board_half
        pc = centre - 0.004 * n
        hw = 0.5 * post_width
        post = np.array([pc[:2].tolist() + [-bottom]] * 4)
        post[[0, 3], :2] -= hw * right[:2]
        post[[1, 2], :2] += hw * right[:2]
        post[[2, 3], 2] = 0.0
        front = float(np.dot(cam_pos - centre, n)) > 0.0
        if front:
            tex = _marker_texture(key, m.id, cell_px, float(quiet_cells))
            quad, order = board, 2
        else:
            # seen from behind: the plain back of the board (mirrored corners keep the
            # quad's winding irrelevant for a uniform texture)
            tex, quad, order = back_tex, board - 0.002 * n, 2
        for corners, texture, o, is_front in ((post, post_tex, 1, False),
                                              (quad, tex, order, front)):
            zc = _to_camera(T_cw, corners)[:, 2]
            if np.any(zc <= near):          # partly behind the camera: not drawn
                continue
            faces.append(_Face(dist, k * 4 + o, corners, texture,
                               m.id if is_front else -1, is_front))
    # painter's order: far first; for one marker its post before its board
    faces.sort(key=lambda f: (-round(f.depth, 9), f.order))
    return faces, T_cw


def visible_markers(world: World, pose, camera: Camera, *, near: float = 0.05,
                    far: float = 30.0, margin: float = 0.0) -> np.ndarray:
    """Ids of markers whose printed face is drawn and lies fully inside the image.

    Occlusion by other markers is not considered. ``margin`` (px) shrinks the image.
    """
    faces, T_cw = _scene_faces(world, pose, camera, quiet_cells=1.0, near=near, far=far,
                               post_width=0.03, cell_px=4)
    out = []
    for f in faces:
        if not f.front:
            continue
        corners = marker_corners_world(world.marker(f.marker_id), world.marker_length,
                                       world.marker_height)
        uv = camera.project(_to_camera(T_cw, corners))
        if (np.all(uv >= margin - 0.5) and np.all(uv[:, 0] <= camera.width - 0.5 - margin)
                and np.all(uv[:, 1] <= camera.height - 0.5 - margin)):
            out.append(f.marker_id)
    return np.array(sorted(out), dtype=int)


#: Floor texture: metres per tile, texture pixels per metre, half extent (m).
_FLOOR_TILE, _FLOOR_RES, _FLOOR_HALF = 0.5, 40.0, 16.0
_FLOOR_FAR = 105.0


@functools.lru_cache(maxsize=1)
def _floor_texture() -> np.ndarray:
    """A low-contrast checker floor around a grid point, fading with distance (uint8)."""
    n = int(2 * _FLOOR_HALF * _FLOOR_RES) + 1
    x = (np.arange(n) - (n - 1) / 2) / _FLOOR_RES
    X, Y = np.meshgrid(x, x)
    # texel centres sit between tile edges: +0.5 texel keeps the edges off the samples
    checker = (np.floor((X + 0.5 / _FLOOR_RES) / _FLOOR_TILE)
               + np.floor((Y + 0.5 / _FLOOR_RES) / _FLOOR_TILE)) % 2.0
    r = np.hypot(X, Y)
    val = (_FLOOR_FAR + 10.0 * np.clip(1.0 - r / 12.0, 0, 1) * (2.0 * checker - 1.0)
           + 20.0 * np.clip(1.0 - r / 6.0, 0, 1))
    tex = np.clip(np.rint(val), 0, 255).astype(np.uint8)
    tex.setflags(write=False)
    return tex


def _background(camera: Camera, T_cw: np.ndarray, T_wc: np.ndarray) -> np.ndarray:
    """Wall (above the horizon) and a tiled floor (a homography of a floor texture), float32."""
    h, w = camera.height, camera.width
    rows = np.arange(h, dtype=np.float32)
    img = np.empty((h, w), np.float32)
    img[:] = (175.0 + 25.0 * (rows / h))[:, None]
    # the floor texture is centred on the grid point (a whole number of 2 tiles) nearest
    # the camera, so the same cached texture serves every pose
    step = 2.0 * _FLOOR_TILE
    x0 = round(T_wc[0, 3] / step) * step
    y0 = round(T_wc[1, 3] / step) * step
    tex = _floor_texture()
    c = (tex.shape[0] - 1) / 2
    A = np.array([[1 / _FLOOR_RES, 0, x0 - c / _FLOOR_RES],
                  [0, 1 / _FLOOR_RES, y0 - c / _FLOOR_RES],
                  [0, 0, 1.0]])                      # texel (j, i, 1) -> floor (X, Y, 1)
    P = camera.K @ np.column_stack([T_cw[:3, 0], T_cw[:3, 1], T_cw[:3, 3]])
    Hm = P @ A
    floor = cv2.warpPerspective(tex, Hm, (w, h), flags=cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_CONSTANT, borderValue=_FLOOR_FAR)
    # which pixels look down at the floor: the ray's z in N is positive
    R = T_wc[:3, :3]
    xu = ((np.arange(w, dtype=np.float32) - camera.cx) / camera.fx)[None, :]
    yv = ((rows - camera.cy) / camera.fy)[:, None]
    below = (R[2, 0] * xu + R[2, 1] * yv + R[2, 2]) > 1e-6
    np.copyto(img, floor, where=below, casting="unsafe")
    return img


def _paint(canvas: np.ndarray, texture: np.ndarray, quad_uv: np.ndarray, ss: int,
           lo: float, hi: float) -> None:
    """Composite a textured quad (pixel corners TL, TR, BR, BL) into ``canvas`` in place.

    The quad is warped at ``ss`` times the resolution with nearest-neighbour
    sampling (exact texel edges) and box-filtered down, which anti-aliases its
    edges; only its bounding box is touched. Texture values 0..255 map to lo..hi.
    """
    H, W = canvas.shape
    x0 = max(int(math.floor(quad_uv[:, 0].min())) - 1, 0)
    y0 = max(int(math.floor(quad_uv[:, 1].min())) - 1, 0)
    x1 = min(int(math.ceil(quad_uv[:, 0].max())) + 2, W)
    y1 = min(int(math.ceil(quad_uv[:, 1].max())) + 2, H)
    if x1 <= x0 or y1 <= y0:
        return
    th, tw = texture.shape
    src = np.array([[-0.5, -0.5], [tw - 0.5, -0.5], [tw - 0.5, th - 0.5], [-0.5, th - 0.5]],
                   np.float32)
    # native pixel centre u -> supersampled pixel centre ss*(u + 0.5) - 0.5, patch-relative
    dst = (ss * (quad_uv + 0.5) - 0.5 - [ss * x0, ss * y0]).astype(np.float32)
    Hm = cv2.getPerspectiveTransform(src, dst)
    size = (ss * (x1 - x0), ss * (y1 - y0))
    both = np.dstack([texture, np.full_like(texture, 255)])
    warped = cv2.warpPerspective(both, Hm, size, flags=cv2.INTER_NEAREST,
                                 borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0, 0))
    small = cv2.resize(warped.astype(np.float32), (x1 - x0, y1 - y0),
                       interpolation=cv2.INTER_AREA) / 255.0
    alpha, val = small[..., 1], small[..., 0]           # val is premultiplied by alpha
    roi = canvas[y0:y1, x0:x1]
    roi *= 1.0 - alpha
    roi += lo * alpha + (hi - lo) * val


def render_view(world: World, pose, camera: Camera | None = None, *, rng=None,
                noise_sigma: float = 2.0, blur_sigma: float = 0.5, supersample: int = 4,
                quiet_cells: float = 1.0, near: float = 0.05, far: float = 30.0,
                post_width: float = 0.03, cell_px: int = 16, floor: bool = True,
                black: float = 25.0, white: float = 235.0) -> np.ndarray:
    """The robot camera's grayscale view of a marker world.

    Each marker is drawn from the image that ``cv2.aruco.generateImageMarker``
    makes (with ``quiet_cells`` cells of white margin), in perspective (a
    homography of its four corners), on a dark post that reaches the floor.
    A marker seen from behind shows the plain back of its board; anything with
    a corner closer than ``near`` to the camera plane (or behind it) is not
    drawn, nor anything farther than ``far``; nearer things are painted over
    farther ones. Edges are anti-aliased by ``supersample`` x ``supersample``
    sampling. Then an optional Gaussian blur (``blur_sigma`` px) and Gaussian
    pixel noise (``noise_sigma`` grey levels, drawn from ``rng``; no noise when
    ``rng`` is None).

    Parameters
    ----------
    world : World
    pose : array_like, shape (3,)
        Robot pose ``[x, y, theta]`` in N.
    camera : Camera, optional
        Defaults to :func:`default_camera`. Distortion is ignored (an ideal
        pinhole image is drawn).
    rng : numpy.random.Generator, optional

    Returns
    -------
    numpy.ndarray, shape (height, width), uint8
    """
    camera = default_camera() if camera is None else camera
    pose = as_vector("pose", pose, 3)
    ss = int(supersample)
    if ss < 1:
        raise ValueError(f"supersample: expected an integer >= 1, got {supersample!r}")
    noise_sigma = as_finite_scalar("noise_sigma", noise_sigma)
    blur_sigma = as_finite_scalar("blur_sigma", blur_sigma)
    if noise_sigma < 0 or blur_sigma < 0:
        raise ValueError("noise_sigma, blur_sigma: expected non-negative numbers")
    faces, T_cw = _scene_faces(world, pose, camera, quiet_cells=quiet_cells, near=near,
                               far=far, post_width=post_width, cell_px=cell_px)
    T_wc = camera.world_from_camera(pose)
    if floor:
        canvas = _background(camera, T_cw, T_wc)
    else:
        canvas = np.full((camera.height, camera.width), 180.0, np.float32)
    for f in faces:
        pc = _to_camera(T_cw, f.corners)
        uv = (pc[:, :2] / pc[:, 2:3]) * [camera.fx, camera.fy] + [camera.cx, camera.cy]
        if f.front:
            _paint(canvas, f.texture, uv, ss, black, white)
        else:
            _paint(canvas, f.texture, uv, ss, 0.0, 255.0)
    if blur_sigma > 0:
        canvas = cv2.GaussianBlur(canvas, (0, 0), blur_sigma)
    if rng is not None and noise_sigma > 0:
        canvas += noise_sigma * rng.standard_normal(canvas.shape, dtype=np.float32)
    return np.clip(np.rint(canvas), 0, 255).astype(np.uint8)


# --------------------------------------------------------------------------- detection
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


# --------------------------------------------------------------------------- sensor
class CameraMarkerSensor:
    """A marker sensor that sees through the camera pipeline (render, detect, estimate).

    Same interface as :class:`slamlib.sensors.AnalyticMarkerSensor`:
    ``read(world, pose, rng) -> Observations``, the attributes ``rate`` and
    ``latency``, and ``R(rho)``. Each frame is rendered with
    :func:`render_view` (pixel noise drawn from ``rng``), measured with
    :func:`detect_markers`, and optionally bias-corrected with
    ``noise_model.correct``. Ground truth is attached for evaluation: a reading
    whose id is a marker of the world near the estimated position gets that
    marker as ``true_id``; otherwise (a misread id) the nearest marker within
    ``match_radius`` of the estimated position (``max(match_radius, 0.2 rho)``)
    or -1 (spurious). ``z_true`` is :func:`slamlib.models.observe` of the true
    marker (NaN for -1).

    Parameters
    ----------
    camera : Camera, optional
        Default :func:`default_camera`.
    noise_model : NoiseModel, optional
        Gives ``R(rho)`` and the bias correction; default :data:`DEFAULT_NOISE_MODEL`.
    correct_bias : bool
        Subtract the fitted range bias from each reading.
    noise_sigma, blur_sigma : float
        Rendering noise (grey levels) and blur (px).
    max_range : float
        Readings farther than this (m) are dropped (the detector still finds
        some markers beyond, with large errors).
    rate, latency : float
        Frames per second; seconds from capture to arrival.
    """

    def __init__(self, camera: Camera | None = None, noise_model: NoiseModel | None = None, *,
                 correct_bias: bool = True, noise_sigma: float = 2.0, blur_sigma: float = 0.5,
                 max_range: float = 5.0, match_radius: float = 0.3, refine: str = "subpix",
                 rate: float = 10.0, latency: float = 0.0):
        self.camera = default_camera() if camera is None else camera
        if not isinstance(self.camera, Camera):
            raise ValueError(f"camera: expected a slamlib.vision.Camera, "
                             f"got {type(camera).__name__}")
        self.noise_model = DEFAULT_NOISE_MODEL if noise_model is None else noise_model
        self.correct_bias = bool(correct_bias)
        self.noise_sigma = as_finite_scalar("noise_sigma", noise_sigma)
        self.blur_sigma = as_finite_scalar("blur_sigma", blur_sigma)
        if self.noise_sigma < 0 or self.blur_sigma < 0:
            raise ValueError("noise_sigma, blur_sigma: expected non-negative numbers")
        self.max_range = as_positive("max_range", max_range)
        self.match_radius = as_positive("match_radius", match_radius)
        make_detector("DICT_ARUCO_ORIGINAL", refine)            # checks refine
        self.refine = refine
        self.rate = as_positive("rate", rate)
        self.latency = as_finite_scalar("latency", latency)
        if self.latency < 0:
            raise ValueError(f"latency: expected >= 0 s, got {latency}")

    def R(self, rho: float) -> np.ndarray:
        """The 2x2 covariance a filter should use for a reading at range ``rho``."""
        return self.noise_model.R(rho)

    def params(self) -> dict:
        """The parameters as a JSON-ready dict (for a run's ``meta.json``)."""
        nm = self.noise_model
        return {"type": type(self).__name__, "camera": self.camera.to_dict(),
                "noise_model": {"bias_coef": nm.bias_coef, "bias_coef3": nm.bias_coef3,
                                "sigma_range_a": nm.sigma_range_a,
                                "sigma_range_b": nm.sigma_range_b,
                                "sigma_bearing": nm.sigma_bearing, "corrected": nm.corrected},
                "correct_bias": self.correct_bias, "noise_sigma": self.noise_sigma,
                "blur_sigma": self.blur_sigma, "max_range": self.max_range,
                "match_radius": self.match_radius, "refine": self.refine,
                "rate": self.rate, "latency": self.latency}

    def detect(self, world: World, pose, rng: np.random.Generator | None
               ) -> tuple[np.ndarray, Detections]:
        """The rendered frame and its raw detections (no bias correction, no range cut)."""
        img = render_view(world, pose, self.camera, rng=rng, noise_sigma=self.noise_sigma,
                          blur_sigma=self.blur_sigma)
        return img, detect_markers(img, self.camera, world.marker_length, world.dictionary,
                                   refine=self.refine)

    def read(self, world: World, pose, rng: np.random.Generator) -> Observations:
        """One camera frame from ``pose`` in ``world`` (capture time left NaN), sorted by id."""
        pose = as_vector("pose", pose, 3)
        _, det = self.detect(world, pose, rng)
        z = det.z.copy()
        if self.correct_bias and len(det):
            z = self.noise_model.correct(z, origin=self.camera.T_base_cam[:2, 3])
        keep = z[:, 0] <= self.max_range
        ids, z = det.ids[keep], z[keep]
        true_ids, z_true = match_ground_truth(world, pose, ids, z, self.match_radius)
        return Observations(float("nan"), ids.astype(np.int64), z, true_ids, z_true)


def match_ground_truth(world: World, pose, ids, z, match_radius: float = 0.3
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Which marker produced each reading, and its noise-free ``[rho, beta]``.

    A reading's estimated position is ``inverse_observe(pose, z)``. If its id
    is a marker of ``world`` within ``max(match_radius, 0.2 rho)`` of that
    position, that marker is the truth; otherwise (a misread id) the nearest
    marker within that radius, or -1 (spurious) if none.

    Returns
    -------
    true_ids : (k,) int64
    z_true : (k, 2), NaN rows for -1
    """
    pose = as_vector("pose", pose, 3)
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    z = as_matrix("z", np.asarray(z, dtype=float).reshape(-1, 2), (ids.size, 2))
    radius = as_positive("match_radius", match_radius)
    world_ids = {int(i) for i in world.ids}
    pos = world.positions
    true_ids = np.full(ids.shape, -1, np.int64)
    z_true = np.full(z.shape, np.nan)
    for k, (i, zk) in enumerate(zip(ids, z)):
        est = inverse_observe(pose, [max(zk[0], 0.0), zk[1]])
        tol = max(radius, 0.2 * float(zk[0]))
        tid = -1
        if int(i) in world_ids and np.hypot(*(world.marker(int(i)).position - est)) <= tol:
            tid = int(i)
        elif pos.shape[0]:
            dist = np.hypot(pos[:, 0] - est[0], pos[:, 1] - est[1])
            j = int(np.argmin(dist))
            if dist[j] <= tol:
                tid = int(world.ids[j])
        if tid >= 0:
            true_ids[k] = tid
            z_true[k] = observe(pose, world.marker(tid).position)
    return true_ids, z_true


# --------------------------------------------------------------------------- error study
def single_marker_scene(distance: float, viewing_angle: float, bearing: float = 0.0,
                        marker_id: int = 0, *, marker_length: float = 0.15,
                        marker_height: float = 0.15,
                        dictionary: str = "DICT_ARUCO_ORIGINAL") -> tuple[World, np.ndarray]:
    """A one-marker world and a robot pose that sees it at a given range, bearing and angle.

    The marker stands at the origin of N; the robot's origin is ``distance``
    from it, the marker appears at ``bearing`` (rad, from B's origin), and the
    marker's face normal makes ``viewing_angle`` (rad, signed) with the line
    from the marker to the robot (0: seen face-on).

    Returns
    -------
    (World, pose)
    """
    d = as_positive("distance", distance)
    a = as_finite_scalar("viewing_angle", viewing_angle)
    b = as_finite_scalar("bearing", bearing)
    world = World(name="single_marker", markers=(Marker(int(marker_id), 0.0, 0.0, a),),
                  marker_length=marker_length, marker_height=marker_height,
                  dictionary=dictionary, bounds=(-1.0, d + 1.0, -d - 1.0, d + 1.0))
    return world, np.array([d, 0.0, wrap_angle(math.pi - b)])


@dataclass
class ErrorStudy:
    """Range and bearing errors of the camera pipeline against ground truth.

    One row per sample in the flat arrays; grid summaries are ``(n_distances, n_angles)``.

    Attributes
    ----------
    distances, angles : (nd,), (na,)
        The grid: true ranges (m) and viewing angles (rad, magnitude).
    samples : int
        Samples per grid cell.
    cell : (N, 2) int
        Grid indices (distance, angle) of each sample.
    z_true, z_meas : (N, 2)
        True and measured ``[range, bearing]``; ``z_meas`` is NaN where the
        marker was not detected.
    corner_shift : (N,)
        Mean outward displacement (px) of the four detected corners from the
        true projected corners, along the direction from the marker's centre
        (negative: the detected square is smaller than the true one).
    side_px, side_det : (N,)
        Mean side (px) of the true projected square and of the detected one (NaN if missed).
    depth : (N,)
        True depth (m) of the marker's centre along the optical axis.
    settings : dict
        The rendering and detection settings used.
    """

    distances: np.ndarray
    angles: np.ndarray
    samples: int
    cell: np.ndarray
    z_true: np.ndarray
    z_meas: np.ndarray
    corner_shift: np.ndarray
    side_px: np.ndarray
    side_det: np.ndarray
    depth: np.ndarray
    settings: dict

    @property
    def detected(self) -> np.ndarray:
        """(N,) bool: the marker was detected with its right id."""
        return np.isfinite(self.z_meas[:, 0])

    @property
    def error(self) -> np.ndarray:
        """(N, 2) measured minus true ``[range, bearing]`` (bearing wrapped), NaN if missed."""
        e = self.z_meas - self.z_true
        e[:, 1] = np.where(np.isfinite(e[:, 1]), wrap_angle(np.nan_to_num(e[:, 1])), np.nan)
        return e

    def _grid(self, values: np.ndarray, fn) -> np.ndarray:
        out = np.full((self.distances.size, self.angles.size), np.nan)
        for i in range(self.distances.size):
            for j in range(self.angles.size):
                sel = (self.cell[:, 0] == i) & (self.cell[:, 1] == j) & np.isfinite(values)
                if np.count_nonzero(sel) >= 2:
                    out[i, j] = fn(values[sel])
        return out

    def detection_rate(self) -> np.ndarray:
        """(nd, na) fraction of samples detected."""
        out = np.zeros((self.distances.size, self.angles.size))
        for i in range(self.distances.size):
            for j in range(self.angles.size):
                sel = (self.cell[:, 0] == i) & (self.cell[:, 1] == j)
                out[i, j] = np.mean(self.detected[sel]) if np.any(sel) else np.nan
        return out

    def range_bias(self) -> np.ndarray:
        """(nd, na) mean range error (m)."""
        return self._grid(self.error[:, 0], np.mean)

    def range_std(self) -> np.ndarray:
        """(nd, na) standard deviation of the range error (m)."""
        return self._grid(self.error[:, 0], lambda v: np.std(v, ddof=1))

    def bearing_bias(self) -> np.ndarray:
        """(nd, na) mean bearing error (rad)."""
        return self._grid(self.error[:, 1], np.mean)

    def bearing_std(self) -> np.ndarray:
        """(nd, na) standard deviation of the bearing error (rad)."""
        return self._grid(self.error[:, 1], lambda v: np.std(v, ddof=1))

    def size_predicted_range_error(self) -> np.ndarray:
        """(N,) the range error a pinhole would make from the detected side alone (m).

        Depth is inversely proportional to the apparent side, so a square that
        looks ``side_det`` instead of ``side_px`` wide puts the marker
        ``depth * (side_px / side_det - 1)`` farther away.
        """
        return self.depth * (self.side_px / self.side_det - 1.0)

    def mean_corner_shift(self) -> np.ndarray:
        """(nd, na) mean outward corner displacement (px) of detected markers."""
        shift = np.where(self.detected, self.corner_shift, np.nan)
        return self._grid(shift, np.mean)


def _mean_side(quad: np.ndarray) -> float:
    return float(np.mean(np.linalg.norm(quad - np.roll(quad, -1, axis=0), axis=1)))


def error_study(distances=(0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0),
                angles_deg=(0.0, 20.0, 40.0, 60.0, 75.0), samples: int = 10, *,
                camera: Camera | None = None, seed: int = 0, noise_sigma: float = 2.0,
                blur_sigma: float = 0.5, refine: str = "subpix", marker_length: float = 0.15,
                marker_height: float = 0.15, dictionary: str = "DICT_ARUCO_ORIGINAL",
                max_bearing: float = 0.35, border_px: float = 4.0) -> ErrorStudy:
    """Measure the camera pipeline's range and bearing errors against ground truth.

    For every (distance, viewing angle) cell, ``samples`` scenes
    (:func:`single_marker_scene`) with a random marker id, a random bearing
    (uniform within ``max_bearing``, redrawn until the marker lies fully inside
    the image with ``border_px`` to spare), a random sign of the viewing angle
    and fresh pixel noise are rendered with :func:`render_view` and measured
    with :func:`detect_markers`; the truth is :func:`slamlib.models.observe`.
    Same seed, same numbers.
    """
    camera = default_camera() if camera is None else camera
    dists = np.array([as_positive("distances", d) for d in np.ravel(distances)])
    angles = np.radians([as_finite_scalar("angles_deg", a) for a in np.ravel(angles_deg)])
    n = int(samples)
    if n < 1:
        raise ValueError(f"samples: expected a positive integer, got {samples!r}")
    rng = np.random.default_rng(seed)
    n_ids = get_dictionary(dictionary).bytesList.shape[0]
    cell, zt, zm, shift, side, side_det, depth = [], [], [], [], [], [], []
    for i, d in enumerate(dists):
        for j, a in enumerate(angles):
            for _ in range(n):
                mid = int(rng.integers(n_ids))
                sign = 1.0 if rng.random() < 0.5 else -1.0
                for _try in range(50):
                    b = rng.uniform(-max_bearing, max_bearing)
                    world, pose = single_marker_scene(d, sign * a, b, mid,
                                                      marker_length=marker_length,
                                                      marker_height=marker_height,
                                                      dictionary=dictionary)
                    uv = project_marker_corners(world, mid, pose, camera)
                    if (np.all(np.isfinite(uv)) and np.all(uv >= border_px)
                            and np.all(uv[:, 0] <= camera.width - 1 - border_px)
                            and np.all(uv[:, 1] <= camera.height - 1 - border_px)):
                        break
                img = render_view(world, pose, camera, rng=rng, noise_sigma=noise_sigma,
                                  blur_sigma=blur_sigma)
                det = detect_markers(img, camera, marker_length, dictionary, refine=refine)
                cell.append((i, j))
                zt.append(observe(pose, world.markers[0].position))
                side.append(_mean_side(uv))
                T_cw, _ = _cam_world(camera, pose)
                depth.append(float(_to_camera(T_cw, _marker_centre(world.markers[0],
                                                                   marker_height)[None])[0, 2]))
                hit = np.flatnonzero(det.ids == mid)
                if hit.size:
                    k = hit[0]
                    zm.append(det.z[k])
                    centre = uv.mean(axis=0)
                    out = (uv - centre) / np.linalg.norm(uv - centre, axis=1, keepdims=True)
                    shift.append(float(np.mean(np.sum((det.corners[k] - uv) * out, axis=1))))
                    side_det.append(_mean_side(det.corners[k]))
                else:
                    zm.append(np.full(2, np.nan))
                    shift.append(np.nan)
                    side_det.append(np.nan)
    settings = dict(noise_sigma=noise_sigma, blur_sigma=blur_sigma, refine=refine,
                    marker_length=marker_length, marker_height=marker_height,
                    dictionary=dictionary, seed=seed, max_bearing=max_bearing)
    return ErrorStudy(dists, angles, n, np.array(cell, int).reshape(-1, 2),
                      np.array(zt).reshape(-1, 2), np.array(zm).reshape(-1, 2),
                      np.array(shift), np.array(side), np.array(side_det), np.array(depth),
                      settings)


@dataclass(frozen=True)
class NoiseModel:
    """The measurement model the filters use, fitted to an :class:`ErrorStudy`.

    ``range bias(rho) = bias_coef * rho**2 + bias_coef3 * rho**3`` (the detected
    range minus the true one), ``sigma_range(rho) = sigma_range_a + sigma_range_b * rho**2``
    and a constant ``sigma_bearing``. With ``corrected=True`` the sigmas describe the
    error left after :meth:`correct`; otherwise they include the bias.
    """

    bias_coef: float
    sigma_range_a: float
    sigma_range_b: float
    sigma_bearing: float
    corrected: bool = True
    bias_coef3: float = 0.0

    def range_bias(self, rho):
        """Expected range error (m) at true range ``rho``."""
        rho = np.asarray(rho, dtype=float)
        return self.bias_coef * rho ** 2 + self.bias_coef3 * rho ** 3

    def sigma_range(self, rho):
        """Standard deviation (m) of the range at range ``rho``."""
        return self.sigma_range_a + self.sigma_range_b * np.asarray(rho, dtype=float) ** 2

    def R(self, rho) -> np.ndarray:
        """The 2x2 measurement covariance ``diag(sigma_range(rho)^2, sigma_bearing^2)``."""
        s = float(self.sigma_range(as_finite_scalar("rho", rho)))
        return np.diag([s * s, self.sigma_bearing ** 2])

    def true_range(self, rho_meas):
        """The range ``rho`` with ``rho + range_bias(rho) = rho_meas`` (Newton, monotone)."""
        rm = np.asarray(rho_meas, dtype=float)
        c2, c3 = self.bias_coef, self.bias_coef3
        if c3 == 0.0:
            if c2 == 0.0:
                return rm.copy()
            return (-1.0 + np.sqrt(np.maximum(1.0 + 4.0 * c2 * rm, 0.0))) / (2.0 * c2)
        r = rm.copy()
        for _ in range(30):
            f = r + c2 * r ** 2 + c3 * r ** 3 - rm
            r = r - f / np.maximum(1.0 + 2.0 * c2 * r + 3.0 * c3 * r ** 2, 1e-6)
        return r

    def correct(self, z, origin=None) -> np.ndarray:
        """Remove the range bias from readings ``z`` ((2,) or (k, 2)).

        Solves ``rho_meas = rho + range_bias(rho)`` for rho. The detector
        overestimates the *depth along the camera's line of sight*; seen from
        B's origin, which is beside the camera, that also turns the bearing a
        little. Given ``origin``, the camera's position ``(x_B, y_B)`` in B
        (``camera.T_base_cam[:2, 3]``), the point is moved back along the line
        of sight by the same amount, which corrects the bearing too; without it
        the bearing is left unchanged.
        """
        z = np.array(z, dtype=float)
        rc = self.true_range(z[..., 0])
        if origin is None:
            z[..., 0] = rc
            return z
        o = as_vector("origin", origin, 2)
        p = z[..., 0:1] * np.stack([np.cos(z[..., 1]), np.sin(z[..., 1])], axis=-1)
        v = p - o
        d = np.linalg.norm(v, axis=-1, keepdims=True)
        shrink = (z[..., 0] - rc)[..., None]
        q = o + v * (1.0 - shrink / np.maximum(d, 1e-9))
        z[..., 0] = np.hypot(q[..., 0], q[..., 1])
        z[..., 1] = np.arctan2(q[..., 1], q[..., 0])
        return z


def fit_noise_model(study: ErrorStudy, *, corrected: bool = True,
                    max_angle_deg: float | None = None, max_range: float | None = None,
                    cubic: bool = True, origin=None) -> NoiseModel:
    """Fit a :class:`NoiseModel` to a study's detected samples.

    The bias by least squares of the range error on ``rho**2`` and ``rho**3``
    (through the origin; ``rho**2`` alone if not ``cubic``); then, per distance,
    the RMS of the range error (after removing the fitted bias if ``corrected``)
    and a least-squares fit ``a + b rho^2`` to it (clipped at >= 0);
    ``sigma_bearing`` is the RMS bearing error (after the correction, which
    also turns the bearing when the camera's ``origin`` in B is given, see
    :meth:`NoiseModel.correct`). Samples at viewing angles above
    ``max_angle_deg`` or true ranges above ``max_range`` are left out if given.
    """
    e = study.error
    ok = study.detected.copy()
    if max_angle_deg is not None:
        ok &= study.angles[study.cell[:, 1]] <= math.radians(max_angle_deg) + 1e-12
    if max_range is not None:
        ok &= study.z_true[:, 0] <= max_range + 1e-12
    if np.count_nonzero(ok) < 3:
        raise ValueError("study: fewer than 3 detected samples to fit")
    rho = study.z_true[ok, 0]
    er, eb = e[ok, 0], e[ok, 1]
    if cubic:
        (c, c3), *_ = np.linalg.lstsq(np.column_stack([rho ** 2, rho ** 3]), er, rcond=None)
        c, c3 = float(c), float(c3)
        if c3 < 0.0 or c < 0.0:       # keep the bias monotone: fall back to rho^2 alone
            c, c3 = float(np.sum(er * rho ** 2) / np.sum(rho ** 4)), 0.0
    else:
        c, c3 = float(np.sum(er * rho ** 2) / np.sum(rho ** 4)), 0.0
    if corrected:
        zc = NoiseModel(c, 0.0, 0.0, 0.0, True, c3).correct(study.z_meas[ok], origin)
        res = zc[:, 0] - rho
        eb = wrap_angle(zc[:, 1] - study.z_true[ok, 1])
    else:
        res = er
    di = study.cell[ok, 0]
    rows = [(study.distances[i], math.sqrt(float(np.mean(res[di == i] ** 2))))
            for i in np.unique(di) if np.count_nonzero(di == i) >= 2]
    d = np.array([r[0] for r in rows])
    s = np.array([r[1] for r in rows])
    A = np.column_stack([np.ones_like(d), d ** 2])
    (a, b), *_ = np.linalg.lstsq(A, s, rcond=None)
    if a < 0:
        a, b = 0.0, float(np.sum(s * d ** 2) / np.sum(d ** 4))
    if b < 0:
        a, b = float(np.mean(s)), 0.0
    sb = math.sqrt(float(np.mean(eb ** 2)))
    return NoiseModel(c, float(a), float(b), sb, corrected, c3)


#: The noise model the course recommends for the default camera, 0.15 m markers and
#: :func:`render_view`'s default noise (2 grey levels, 0.5 px blur), sub-pixel corners:
#: ``fit_noise_model(error_study(distances=(0.5, 1, ..., 6) every 0.5 m and 7,
#: angles_deg=(0, 15, 30, 45, 60, 70, 80), samples=30, seed=1), max_angle_deg=60,
#: max_range=5, origin=default_camera().T_base_cam[:2, 3])``, rounded. Range bias
#: 0.0035 rho^2 + 0.00024 rho^3 (3.8 cm at 3 m, 11.7 cm at 5 m); after correcting it
#: along the camera's line of sight the range sigma is 0.001 + 0.0027 rho^2 m (2.5 cm at 3 m;
#: the fitted constant is 0, set to 1 mm so that R stays positive definite at any
#: range); bearing sigma 0.24 mrad (0.014 deg). Chapter 02 checks it on fresh data.
DEFAULT_NOISE_MODEL = NoiseModel(bias_coef=0.0035, sigma_range_a=0.001, sigma_range_b=0.0027,
                                 sigma_bearing=0.00024, corrected=True, bias_coef3=0.00024)


# --------------------------------------------------------------------------- drawing
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
