"""Rendering the robot camera's view of a marker world (chapter 02).

:func:`render_view` draws the grayscale view of a :class:`~slamlib.worlds.World` from a
robot pose: floor, markers with their white quiet zone on posts, in perspective, back
faces culled, near/far clipping, painter's order, anti-aliasing by supersampling,
optional blur and pixel noise. :func:`project_marker_corners` and
:func:`markers_in_image` give the exact corners and the markers in view.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..validate import as_finite_scalar, as_vector
from ..worlds import World
from .camera import Camera, default_camera
from .markers import (
    _dict_key,
    _marker_axes,
    _marker_centre,
    _marker_texture,
    get_dictionary,
    marker_corners_world,
)

__all__ = ["project_marker_corners", "markers_in_image", "render_view"]


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

def markers_in_image(world: World, pose, camera: Camera, *, near: float = 0.05,
                    far: float = 30.0, margin: float = 0.0) -> np.ndarray:
    """Ids of markers whose printed face is drawn and lies fully inside the image.

    The camera's view (corners projected into the image), not the analytic
    sensor's rule (:func:`slamlib.sensors.visible_markers`: field of view,
    range and viewing angle). Occlusion by other markers is not considered. ``margin`` (px)
    shrinks the image.
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
