"""The camera's noise model and the study that measures it (chapter 02).

:func:`error_study` renders single markers at known ranges and viewing angles, detects
them and records the errors of range and bearing against ground truth;
:func:`fit_noise_model` turns them into a :class:`NoiseModel`: the range bias (growing
with distance squared) and the standard deviations that give the filter's R(rho).
:data:`DEFAULT_NOISE_MODEL` is the one fitted in chapter 02, which the camera sensor uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..models import observe, wrap_angle
from ..validate import as_finite_scalar, as_positive, as_vector
from ..worlds import Marker, World
from .camera import Camera, default_camera
from .detect import detect_markers
from .markers import _marker_centre, get_dictionary
from .render import _cam_world, _to_camera, project_marker_corners, render_view

__all__ = ["single_marker_scene", "ErrorStudy", "error_study", "NoiseModel", "fit_noise_model",
           "DEFAULT_NOISE_MODEL"]


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
