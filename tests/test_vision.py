"""The camera pipeline (slamlib.vision, chapter 02): frames, rendering, detection, sensor.

Ground truth is computed independently of the pipeline, with
``slamlib.models.observe`` from the true poses.
"""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from slamlib import vision as V
from slamlib.models import observe
from slamlib.sensors import Observations
from slamlib.vision import detect
from slamlib.worlds import Marker, World, report_arena

CAM = V.default_camera()
ARENA = report_arena()


def range_tolerance(rho):
    """Raw pipeline range error allowed: 1 cm + 1 cm per m^2 (the measured bias is 0.54 cm/m^2)."""
    return 0.01 + 0.01 * rho ** 2


BEARING_TOL = math.radians(0.3)


# --------------------------------------------------------------------------- camera and frames
def test_default_camera_is_the_reports():
    assert (CAM.width, CAM.height) == (640, 480)
    assert CAM.fx == CAM.fy == 525.0
    assert (CAM.cx, CAM.cy) == (319.5, 239.5)
    np.testing.assert_allclose(CAM.T_base_cam[:3, 3], [0.122, -0.033, 0.082])
    assert CAM.camera_height == pytest.approx(0.148)
    np.testing.assert_allclose(CAM.T_base_cam @ CAM.T_cam_base, np.eye(4), atol=1e-12)


def test_optical_frame_maps_to_robot_frame_as_in_course():
    # x_B = z_C, y_B = x_C, z_B = y_C, plus the mount offset
    R = CAM.T_base_cam[:3, :3]
    np.testing.assert_array_equal(R @ [0, 0, 1], [1, 0, 0])      # optical axis -> forward
    np.testing.assert_array_equal(R @ [1, 0, 0], [0, 1, 0])      # image right -> robot right
    np.testing.assert_array_equal(R @ [0, 1, 0], [0, 0, 1])      # image down -> down
    # a point straight ahead on the optical axis, 2 m in front of the camera
    z = V.camera_to_range_bearing([0.0, 0.0, 2.0], CAM.T_base_cam)
    assert z[0] == pytest.approx(math.hypot(2.122, -0.033))
    assert z[1] == pytest.approx(math.atan2(-0.033, 2.122))
    assert z[1] < 0                 # the camera sits 3.3 cm to the left of B's origin
    # a point to the right in the image has a positive (rightward, z-down) bearing
    assert V.camera_to_range_bearing([0.5, 0.0, 2.0], CAM.T_base_cam)[1] > 0
    # the height of the point does not change the projected range
    a = V.camera_to_range_bearing([[0.3, -0.2, 1.0], [0.3, 0.4, 1.0]], CAM.T_base_cam)
    np.testing.assert_allclose(a[0], a[1])


def test_calibration_round_trip_and_errors(tmp_path):
    p = tmp_path / "cam.json"
    V.save_camera(CAM, p)
    cam = V.load_camera(p)
    np.testing.assert_array_equal(cam.K, CAM.K)
    np.testing.assert_array_equal(cam.T_base_cam, CAM.T_base_cam)
    d = json.loads(p.read_text())
    d["K"] = [[525, 0, 319.5], [0, 525, 239.5]]
    p.write_text(json.dumps(d))
    with pytest.raises(V.CalibrationFormatError, match="K"):
        V.load_camera(p)
    d = json.loads(json.dumps(CAM.to_dict()))
    del d["T_base_cam"]
    p.write_text(json.dumps(d))
    with pytest.raises(V.CalibrationFormatError, match="T_base_cam"):
        V.load_camera(p)
    p.write_text('{"format": "slamlib-camera/1",\n "K": [1, 2,]}')
    with pytest.raises(V.CalibrationFormatError, match="line 2"):
        V.load_camera(p)
    with pytest.raises(ValueError, match="T_base_cam"):
        V.Camera(CAM.K, None, np.diag([1.0, 1.0, 2.0, 1.0]), 640, 480)
    with pytest.raises(ValueError, match="width"):
        V.Camera(CAM.K, None, CAM.T_base_cam, 0, 480)


def test_opencv_version_parsing():
    assert V._opencv_version("4.8.1") < V.MIN_OPENCV
    assert V._opencv_version("4.9.0") >= V.MIN_OPENCV
    assert V._opencv_version("5.0.0-pre") >= V.MIN_OPENCV


# --------------------------------------------------------------------------- markers and rendering
def test_marker_image_has_quiet_zone_and_decodes():
    img = V.marker_image(11, "DICT_ARUCO_ORIGINAL", cell_px=10, quiet_cells=1)
    assert img.shape == (90, 90) and img.dtype == np.uint8
    assert np.all(img[:10] == 255) and np.all(img[:, -10:] == 255)      # white margin
    assert np.all(img[10:20, 10:80] == 0)                                # black border
    det = cv2.aruco.ArucoDetector(V.get_dictionary("DICT_ARUCO_ORIGINAL"))
    _, ids, _ = det.detectMarkers(cv2.copyMakeBorder(img, 20, 20, 20, 20,
                                                     cv2.BORDER_CONSTANT, value=255))
    assert np.ravel(ids).tolist() == [11]
    with pytest.raises(ValueError, match="dictionary"):
        V.get_dictionary("ORIGINAL")


def test_render_is_deterministic_and_left_is_left():
    a = V.render_view(ARENA, ARENA.start_pose, CAM, rng=np.random.default_rng(5))
    b = V.render_view(ARENA, ARENA.start_pose, CAM, rng=np.random.default_rng(5))
    assert a.dtype == np.uint8 and a.shape == (480, 640)
    np.testing.assert_array_equal(a, b)
    # a marker at a positive bearing (to the robot's right) appears right of centre
    for bearing in (-0.3, 0.3):
        world, pose = V.single_marker_scene(2.0, 0.0, bearing, 7)
        uv = V.project_marker_corners(world, 7, pose, CAM)
        img = V.render_view(world, pose, CAM, blur_sigma=0.0)
        det = V.detect_markers(img, CAM, 0.15)
        assert det.ids.tolist() == [7]
        assert np.sign(det.corners[0, :, 0].mean() - CAM.cx) == np.sign(bearing)
        # the detected corners sit where the geometry puts them: no global offset (a
        # half-pixel convention error would show as 0.5 px), only the detector's
        # small inward pull
        err = det.corners[0] - uv
        assert np.linalg.norm(err.mean(axis=0)) < 0.15
        assert np.max(np.abs(err)) < 0.45


def test_marker_behind_camera_or_seen_from_back_is_not_drawn():
    world, pose = V.single_marker_scene(1.5, 0.0, 0.0, 3)
    empty = V.render_view(World("none", ()), pose, CAM)
    # seen from behind: turn the marker around; only a plain grey board is drawn
    back = World("back", (Marker(3, 0.0, 0.0, math.pi),))
    img = V.render_view(back, pose, CAM)
    assert len(V.detect_markers(img, CAM, 0.15)) == 0
    assert img.min() > 60                       # no black ink anywhere
    assert V.markers_in_image(back, pose, CAM).size == 0
    # behind the camera: the robot turned away
    away = pose + [0.0, 0.0, math.pi]
    img = V.render_view(world, away, CAM)
    np.testing.assert_array_equal(img, V.render_view(World("none", ()), away, CAM))
    # partly behind the camera (straddling the image plane at its side): not drawn
    side = World("side", (Marker(3, 1.6, 0.2, math.pi / 2 + 0.2),))
    pose_side = np.array([1.5, 0.0, 0.0])
    img = V.render_view(side, pose_side, CAM)
    np.testing.assert_array_equal(img, V.render_view(World("none", ()), pose_side, CAM))
    assert empty.shape == img.shape


def test_nearer_marker_occludes_farther_one():
    # two markers in line with the camera: only the near one is seen
    pose = np.array([0.0, 0.0, 0.0])
    world = World("line", (Marker(5, 3.0, 0.0, math.pi), Marker(6, 1.5, 0.0, math.pi)))
    det = V.detect_markers(V.render_view(world, pose, CAM), CAM, 0.15)
    assert det.ids.tolist() == [6]
    # in the arena: from here marker 31 hides most of 21 behind it
    pose = np.array([0.8, 0.5, 1.2])
    assert {21, 31} <= set(V.markers_in_image(ARENA, pose, CAM).tolist())
    det = V.detect_markers(V.render_view(ARENA, pose, CAM), CAM, 0.15)
    assert 31 in det.ids and 21 not in det.ids


# --------------------------------------------------------------------------- detection
ARENA_POSES = [ARENA.start_pose, (2.0, 0.0, 0.3), (3.0, 1.5, 2.4), (1.0, 1.0, 2.2),
               (3.5, -0.5, -0.6), (2.5, 0.3, -2.8), (1.5, 1.8, 2.5)]


@pytest.mark.parametrize("pose", ARENA_POSES)
def test_arena_markers_detected_with_right_ids_and_ranges(pose):
    pose = np.asarray(pose, dtype=float)
    rng = np.random.default_rng(42)
    img = V.render_view(ARENA, pose, CAM, rng=rng)
    det = V.detect_markers(img, CAM, ARENA.marker_length, ARENA.dictionary)
    expected = set(V.markers_in_image(ARENA, pose, CAM, margin=5).tolist())
    # everything fully in view and within 4 m must be found; nothing else may be
    near = {i for i in expected if observe(pose, ARENA.marker(i).position)[0] < 4.0}
    assert near <= set(det.ids.tolist()) <= expected | set(
        V.markers_in_image(ARENA, pose, CAM).tolist())
    assert len(det) > 0
    assert det.z.shape == (len(det), 2) and det.p_cam.shape == (len(det), 3)
    for i, z in zip(det.ids, det.z):
        zt = observe(pose, ARENA.marker(i).position)
        assert abs(z[0] - zt[0]) < range_tolerance(zt[0]), (i, z, zt)
        assert abs(z[1] - zt[1]) < BEARING_TOL, (i, z, zt)
    # the range comes out long, not short, beyond a metre (the bias the chapter measures)
    far = det.z[:, 0] > 1.5
    zt = np.array([observe(pose, ARENA.marker(i).position) for i in det.ids])
    assert np.all(det.z[far, 0] - zt[far, 0] > -0.02)


def test_p_cam_is_marker_centre_in_camera_frame():
    world, pose = V.single_marker_scene(1.2, 0.3, 0.1, 42)
    det = V.detect_markers(V.render_view(world, pose, CAM), CAM, 0.15)
    T_nc = CAM.world_from_camera(pose)
    centre = np.linalg.inv(T_nc) @ [0.0, 0.0, -0.15, 1.0]
    np.testing.assert_allclose(det.p_cam[0], centre[:3], atol=0.01)
    np.testing.assert_allclose(det.p_base[0], (CAM.T_base_cam @ [*det.p_cam[0], 1])[:3])


def test_image_without_markers_gives_empty_result():
    img = V.render_view(World("none", ()), (0.0, 0.0, 0.0), CAM, rng=np.random.default_rng(0))
    det = V.detect_markers(img, CAM, 0.15)
    assert len(det) == 0
    assert det.ids.shape == (0,) and det.z.shape == (0, 2) and det.p_cam.shape == (0, 3)
    assert len(V.detect_markers(np.zeros((480, 640), np.uint8), CAM, 0.15)) == 0


def test_colour_image_is_converted():
    world, pose = V.single_marker_scene(1.0, 0.0, 0.0, 9)
    gray = V.render_view(world, pose, CAM)
    bgr = cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR)
    a, b = V.detect_markers(gray, CAM, 0.15), V.detect_markers(bgr, CAM, 0.15)
    assert a.ids.tolist() == b.ids.tolist() == [9]
    np.testing.assert_allclose(a.z, b.z)


@pytest.mark.parametrize("bad, what", [
    (np.zeros((480, 640), np.float64), "dtype float64"),
    (np.zeros(640, np.uint8), r"shape \(640,\)"),
    (np.zeros((0, 0), np.uint8), "empty"),
    (np.zeros((240, 320), np.uint8), "camera's image size"),
    (np.zeros((480, 640, 2), np.uint8), "shape"),
    ([[0, 1], [2, 3]], "numpy"),
])
def test_bad_image_raises_value_error_naming_gray(bad, what):
    with pytest.raises(ValueError, match=rf"gray: .*{what}"):
        V.detect_markers(bad, CAM, 0.15)


def test_bad_other_arguments():
    img = np.zeros((480, 640), np.uint8)
    with pytest.raises(ValueError, match="marker_length"):
        V.detect_markers(img, CAM, -0.15)
    with pytest.raises(ValueError, match="dictionary"):
        V.detect_markers(img, CAM, 0.15, dictionary="DICT_NOPE")
    with pytest.raises(ValueError, match="camera"):
        V.detect_markers(img, None, 0.15)


def test_ids_from_opencv_4_column_shape_are_raveled(monkeypatch):
    """OpenCV 4.x returns ids as (N, 1): the result must still be (k,)."""
    world, pose = V.single_marker_scene(1.0, 0.0, 0.0, 12)
    img = V.render_view(world, pose, CAM)
    real = V.make_detector("DICT_ARUCO_ORIGINAL", "subpix")

    class Shim:
        def detectMarkers(self, gray):
            corners, ids, rej = real.detectMarkers(gray)
            return corners, ids.reshape(-1, 1), rej

    monkeypatch.setattr(detect, "make_detector", lambda *a, **k: Shim())  # detect_markers calls it
    det = V.detect_markers(img, CAM, 0.15)
    assert det.ids.shape == (1,) and det.ids[0] == 12


# --------------------------------------------------------------------------- pose fallback
def test_ippe_nan_falls_back_to_sqpnp(monkeypatch):
    world, pose = V.single_marker_scene(1.5, 0.4, 0.1, 21)
    img = V.render_view(world, pose, CAM)
    ref = V.detect_markers(img, CAM, 0.15)
    assert not ref.fallback.any()
    real = cv2.solvePnP

    def nan_ippe(obj, img_pts, K, dist, flags=cv2.SOLVEPNP_ITERATIVE, **kw):
        if flags == cv2.SOLVEPNP_IPPE_SQUARE:       # what IPPE does on degenerate input
            return True, np.full((3, 1), np.nan), np.full((3, 1), np.nan)
        return real(obj, img_pts, K, dist, flags=flags, **kw)

    monkeypatch.setattr(cv2, "solvePnP", nan_ippe)
    det = V.detect_markers(img, CAM, 0.15)
    assert det.fallback.tolist() == [True]
    np.testing.assert_allclose(det.z, ref.z, atol=2e-3)
    zt = observe(pose, world.markers[0].position)
    assert abs(det.z[0, 0] - zt[0]) < range_tolerance(zt[0])


def test_symmetric_corner_set_gives_finite_pose():
    """A perfectly symmetric, fronto-parallel square on the optical axis."""
    h = 0.5 * 0.15 * CAM.fx / 1.0
    c = np.array([[CAM.cx - h, CAM.cy - h], [CAM.cx + h, CAM.cy - h],
                  [CAM.cx + h, CAM.cy + h], [CAM.cx - h, CAM.cy + h]])
    rvec, tvec, _ = V.estimate_marker_pose(c, CAM, 0.15)
    assert np.all(np.isfinite(rvec)) and np.all(np.isfinite(tvec))
    np.testing.assert_allclose(tvec, [0.0, 0.0, 1.0], atol=1e-6)


def test_both_solvers_failing_drops_the_marker(monkeypatch):
    world, pose = V.single_marker_scene(1.0, 0.0, 0.0, 2)
    img = V.render_view(world, pose, CAM)
    monkeypatch.setattr(cv2, "solvePnP", lambda *a, **k: (False, None, None))
    assert len(V.detect_markers(img, CAM, 0.15)) == 0


# --------------------------------------------------------------------------- sensor
def test_camera_sensor_reads_arena_with_ground_truth():
    sensor = V.CameraMarkerSensor()
    obs = sensor.read(ARENA, ARENA.start_pose, np.random.default_rng(3))
    assert isinstance(obs, Observations)
    assert len(obs) >= 2
    np.testing.assert_array_equal(obs.true_ids, obs.ids)
    for i, z, zt in zip(obs.ids, obs.z, obs.z_true):
        np.testing.assert_allclose(zt, observe(ARENA.start_pose, ARENA.marker(i).position))
        # bias-corrected: well inside the raw tolerance
        assert abs(z[0] - zt[0]) < 0.5 * range_tolerance(zt[0]) + 0.02
        assert abs(z[1] - zt[1]) < BEARING_TOL
    R = sensor.R(3.0)
    assert R.shape == (2, 2) and R[0, 0] > R[1, 1] > 0
    assert sensor.params()["type"] == "CameraMarkerSensor"
    json.dumps(sensor.params())


def test_ground_truth_matching_of_misread_ids():
    pose = np.array(ARENA.start_pose)
    z41 = observe(pose, ARENA.marker(41).position)
    ids, z = [41, 999, 21, 998], np.array([z41, z41, z41, [1.0, 0.0]])
    true_ids, z_true = V.match_ground_truth(ARENA, pose, ids, z)
    # right id; unknown id at 41's place; a world id read at 41's place; nothing there
    assert true_ids.tolist() == [41, 41, 41, -1]
    np.testing.assert_allclose(z_true[:3], [z41] * 3)
    assert np.all(np.isnan(z_true[3]))


def test_simulator_can_use_the_camera_sensor():
    sim = pytest.importorskip("slamlib.sim")
    controller = sim.WaypointController(np.array([[3.0, 0.2]]))
    run = sim.simulate(ARENA, controller, sensor=V.CameraMarkerSensor(rate=2.0), seed=0,
                       max_duration=1.5)
    frames = [o for o in run.camera.frames() if len(o)]
    assert frames, "the camera sensor produced no reading along the path"
    assert run.meta["sensor"]["type"] == "CameraMarkerSensor"
    assert all(np.all(o.true_ids >= 0) for o in frames)


# --------------------------------------------------------------------------- noise model
def test_noise_model_correction_inverts_the_bias():
    nm = V.NoiseModel(0.0054, 0.004, 0.0025, 3e-4)
    rho = np.array([0.5, 1.0, 3.0, 5.0])
    z = np.column_stack([rho + nm.range_bias(rho), np.full(4, 0.2)])
    np.testing.assert_allclose(nm.correct(z), np.column_stack([rho, np.full(4, 0.2)]))
    np.testing.assert_allclose(nm.R(2.0), np.diag([(0.004 + 0.01) ** 2, 9e-8]))
    # with a cubic term (solved by Newton)
    nm3 = V.NoiseModel(0.0035, 0.001, 0.0027, 2.4e-4, True, 2.4e-4)
    np.testing.assert_allclose(nm3.range_bias(2.0), 0.0035 * 4 + 2.4e-4 * 8)
    z = np.column_stack([rho + 0.0035 * rho ** 2 + 2.4e-4 * rho ** 3, np.full(4, -0.3)])
    np.testing.assert_allclose(nm3.correct(z), np.column_stack([rho, np.full(4, -0.3)]),
                               atol=1e-12)
    np.testing.assert_allclose(nm3.correct(z[1]), [1.0, -0.3], atol=1e-12)


def test_correction_along_the_line_of_sight_fixes_the_bearing():
    # a detector that overestimates the depth along the camera's ray: the point is
    # pushed away from the camera, which sits beside B's origin, so seen from B
    # both the range and the bearing are off
    nm = V.NoiseModel(0.0035, 0.001, 0.0027, 2.4e-4, True, 2.4e-4)
    o = CAM.T_base_cam[:2, 3]
    rng = np.random.default_rng(5)
    rho = rng.uniform(1.0, 5.0, 200)
    beta = rng.uniform(-0.5, 0.5, 200)
    p = np.column_stack([rho * np.cos(beta), rho * np.sin(beta)])
    v = p - o
    q = p + v / np.linalg.norm(v, axis=1, keepdims=True) * nm.range_bias(rho)[:, None]
    zm = np.column_stack([np.hypot(q[:, 0], q[:, 1]), np.arctan2(q[:, 1], q[:, 0])])
    assert np.mean(zm[:, 1] - beta) > 2e-5                 # the bearing offset (positive)
    plain = nm.correct(zm)
    along = nm.correct(zm, origin=o)
    assert np.max(np.abs(along[:, 1] - beta)) < 0.05 * np.max(np.abs(plain[:, 1] - beta))
    assert np.max(np.abs(along[:, 0] - rho)) < 1e-3
    assert np.max(np.abs(plain[:, 0] - rho)) < 1e-3
    np.testing.assert_array_equal(plain[:, 1], zm[:, 1])  # no origin: bearing untouched


def test_camera_sensor_has_no_bearing_offset_after_the_correction():
    # the raw pipeline reads bearings a little to the right (the range bias seen from
    # beside the camera); the sensor's correction removes it
    rng = np.random.default_rng(4)
    raw, fixed = [], []
    for k in range(24):
        d, b = 2.0 + 0.125 * k, rng.uniform(-0.3, 0.3)
        world, pose = V.single_marker_scene(d, 0.0, b, int(rng.integers(1024)))
        det = V.detect_markers(V.render_view(world, pose, CAM, rng=rng), CAM, 0.15)
        if len(det) == 1:
            zt = observe(pose, world.markers[0].position)
            raw.append(det.z[0, 1] - zt[1])
            fixed.append(V.DEFAULT_NOISE_MODEL.correct(det.z[0], CAM.T_base_cam[:2, 3])[1]
                         - zt[1])
    assert len(raw) >= 20
    assert np.mean(raw) > 8e-5 and abs(np.mean(fixed)) < 0.4 * np.mean(raw)


def _synthetic_study(bias, sigma, n=400, dists=(1.0, 2.0, 3.0, 4.0), seed=0):
    rng = np.random.default_rng(seed)
    dists = np.array(dists)
    cell = np.array([(i, 0) for i in range(dists.size) for _ in range(n)])
    rho = dists[cell[:, 0]]
    zt = np.column_stack([rho, np.zeros_like(rho)])
    zm = zt + np.column_stack([bias(rho) + sigma(rho) * rng.standard_normal(rho.size),
                               1e-3 * rng.standard_normal(rho.size)])
    nan = np.full(rho.size, np.nan)
    return V.ErrorStudy(dists, np.zeros(1), n, cell, zt, zm, nan, nan, nan, nan, {})


def test_fit_noise_model_recovers_a_synthetic_study():
    st = _synthetic_study(lambda r: 0.005 * r ** 2, lambda r: 0.002 + 0.003 * r ** 2)
    nm = V.fit_noise_model(st, cubic=False)
    assert nm.bias_coef == pytest.approx(0.005, rel=0.05) and nm.bias_coef3 == 0.0
    assert nm.sigma_range_b == pytest.approx(0.003, rel=0.1)
    assert nm.sigma_bearing == pytest.approx(1e-3, rel=0.1)
    assert np.allclose(st.detection_rate(), 1.0)


def test_fit_noise_model_recovers_a_cubic_bias_and_leaves_out_far_samples():
    st = _synthetic_study(lambda r: 0.003 * r ** 2 + 0.0004 * r ** 3,
                          lambda r: 0.001 + 0.002 * r ** 2, n=2000, dists=(1.0, 2.0, 3.0, 4.0, 6.0))
    # the 6 m samples carry a wild extra error: max_range must leave them out
    st.z_meas[st.z_true[:, 0] > 5, 0] += 1.0
    nm = V.fit_noise_model(st, max_range=5.0)
    assert nm.bias_coef == pytest.approx(0.003, rel=0.1)
    assert nm.bias_coef3 == pytest.approx(0.0004, rel=0.15)
    assert nm.sigma_range_b == pytest.approx(0.002, rel=0.1)
    # a quadratic alone cannot follow it: it over-corrects at short range
    nm2 = V.fit_noise_model(st, max_range=5.0, cubic=False)
    assert nm2.range_bias(1.0) > 1.2 * nm.range_bias(1.0)


def test_small_error_study_shows_long_ranges_and_fading_detection():
    st = V.error_study(distances=(1.0, 3.0, 7.0), angles_deg=(0.0,), samples=6, seed=2)
    rate = st.detection_rate()[:, 0]
    assert rate[0] == 1.0 and rate[1] >= 5 / 6 and rate[2] < 1.0
    bias = st.range_bias()[:, 0]
    assert 0.0 < bias[0] < 0.01 and 0.01 < bias[1] < 0.1         # long, and ~ rho^2
    assert np.all(st.mean_corner_shift()[:2, 0] < 0)              # the square looks smaller


def test_projected_corners_behind_the_camera_are_nan_not_an_error():
    # marker 61 is behind the robot at the start pose; 41 is in front
    behind = V.project_marker_corners(ARENA, 61, ARENA.start_pose, CAM)
    assert behind.shape == (4, 2) and np.all(np.isnan(behind))
    front = V.project_marker_corners(ARENA, 41, ARENA.start_pose, CAM)
    assert np.all(np.isfinite(front))
