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

What is where
-------------
- :mod:`~slamlib.vision.camera`: :class:`Camera`, :func:`load_camera`, :func:`default_camera`,
  calibration I/O (JSON in ``data/calibration``, OpenCV's YAML, ChArUco), the mount and
  :func:`camera_to_range_bearing`.
- :mod:`~slamlib.vision.markers`: ArUco dictionaries, marker images, the markers' corners.
- :mod:`~slamlib.vision.render`: :func:`render_view`, the camera's view of a
  :class:`~slamlib.worlds.World` from a robot pose.
- :mod:`~slamlib.vision.detect`: :func:`detect_markers`, OpenCV's ArUco detector with sub-pixel
  corner refinement, IPPE_SQUARE pose with an SQPNP fallback, range and bearing.
- :mod:`~slamlib.vision.noise`: :func:`error_study`, :func:`fit_noise_model`,
  :class:`NoiseModel`: the bias and noise of range and bearing measured against ground truth
  and turned into the filter's R (and a range-bias correction).
- :mod:`~slamlib.vision.sensor`: :class:`CameraMarkerSensor`, render + detect as a drop-in
  marker sensor for the simulator.

Every name is importable from ``slamlib.vision`` itself (``from slamlib.vision import Camera,
detect_markers, NoiseModel``).
"""

from __future__ import annotations

import re

import cv2

__all__ = [
    "MIN_OPENCV", "R_BASE_CAM", "DEFAULT_BASE_HEIGHT", "CALIBRATION_DIR",
    "CalibrationFormatError", "Camera", "load_camera", "save_camera", "default_camera",
    "read_opencv_calibration", "CharucoCalibration", "calibrate_charuco",
    "camera_to_range_bearing", "base_pose_matrix",
    "get_dictionary", "read_dictionary", "marker_image", "marker_object_points",
    "marker_corners_world",
    "project_marker_corners", "markers_in_image", "render_view",
    "Detections", "make_detector", "estimate_marker_pose", "detect_markers",
    "CameraMarkerSensor", "match_ground_truth",
    "single_marker_scene", "ErrorStudy", "error_study", "NoiseModel", "fit_noise_model",
    "DEFAULT_NOISE_MODEL", "draw_detections",
]

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

from .camera import (  # noqa: E402
    CALIBRATION_DIR,
    DEFAULT_BASE_HEIGHT,
    R_BASE_CAM,
    CalibrationFormatError,
    Camera,
    CharucoCalibration,
    base_pose_matrix,
    calibrate_charuco,
    camera_to_range_bearing,
    default_camera,
    load_camera,
    read_opencv_calibration,
    save_camera,
)
from .detect import (  # noqa: E402
    Detections,
    detect_markers,
    draw_detections,
    estimate_marker_pose,
    make_detector,
)
from .markers import (  # noqa: E402
    get_dictionary,
    marker_corners_world,
    marker_image,
    marker_object_points,
    read_dictionary,
)
from .noise import (  # noqa: E402
    DEFAULT_NOISE_MODEL,
    ErrorStudy,
    NoiseModel,
    error_study,
    fit_noise_model,
    single_marker_scene,
)
from .render import (  # noqa: E402
    markers_in_image,
    project_marker_corners,
    render_view,
)
from .sensor import (  # noqa: E402
    CameraMarkerSensor,
    match_ground_truth,
)
