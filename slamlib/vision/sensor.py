"""The camera as a marker sensor for the simulator (chapter 02).

:class:`CameraMarkerSensor` renders the view from the true pose, detects the markers and
returns their readings with the noise model's R, a drop-in replacement for the analytic
sensor of :mod:`slamlib.sensors`; :func:`match_ground_truth` pairs readings with the
true markers.
"""

from __future__ import annotations

import numpy as np

from ..models import inverse_observe, observe
from ..sensors import Observations
from ..validate import as_finite_scalar, as_matrix, as_positive, as_vector
from ..worlds import World
from .camera import Camera, default_camera
from .detect import Detections, detect_markers, make_detector
from .noise import DEFAULT_NOISE_MODEL, NoiseModel
from .render import render_view

__all__ = ["CameraMarkerSensor", "match_ground_truth"]


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
