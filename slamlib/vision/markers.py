"""ArUco markers (chapter 02): dictionaries, marker images and the markers' geometry.

:func:`get_dictionary` and :func:`read_dictionary` give OpenCV dictionaries (predefined or
from a file), :func:`marker_image` a marker with its white quiet zone,
:func:`marker_object_points` the four corners in the marker's own frame (OpenCV's order:
top-left, top-right, bottom-right, bottom-left) and :func:`marker_corners_world` a
world marker's corners in N.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import cv2
import numpy as np

from ..validate import as_positive
from ..worlds import Marker
from .opencv_files import open_storage

__all__ = ["read_dictionary", "get_dictionary", "marker_image", "marker_object_points",
           "marker_corners_world"]


#: OpenCV's predefined dictionaries: name -> code (``cv2.aruco.DICT_*``).
PREDEFINED = {name: code for name, code in vars(cv2.aruco).items()
              if name.startswith("DICT_") and isinstance(code, int)}


def _is_dictionary_file(dictionary) -> bool:
    return isinstance(dictionary, Path) or (
        isinstance(dictionary, str) and dictionary.lower().endswith((".yml", ".yaml")))

def read_dictionary(path) -> cv2.aruco.Dictionary:
    """A custom ArUco dictionary from an OpenCV yml file (``nmarkers``, ``markersize``,
    ``marker_0``...), as OpenCV writes it (chapter 02's real photos)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"dictionary: no such dictionary file {str(path)!r}")
    fs = open_storage(path, lambda msg: ValueError(f"dictionary: {msg}"))
    try:
        d = cv2.aruco.Dictionary()
        ok = d.readDictionary(fs.root())
    except cv2.error:
        ok = False
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
        if int(dictionary) not in PREDEFINED.values():
            raise ValueError(f"dictionary: {dictionary!r} is not one of OpenCV's predefined "
                             f"ArUco dictionaries (codes {min(PREDEFINED.values())}.."
                             f"{max(PREDEFINED.values())}, cv2.aruco.DICT_*); pass a name "
                             f"such as 'DICT_ARUCO_ORIGINAL'")
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
