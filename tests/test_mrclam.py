"""The MRCLAM loader on hand-made files, and the pipeline on the shipped excerpt."""

import math
from pathlib import Path

import numpy as np
import pytest

from slamlib.datasets import mrclam
from slamlib.models import wrap_angle

HEAD = "# UTIAS Multi-Robot Cooperative Localization and Mapping Dataset\n# made by a test\n" \
       "# Data Format:\n# columns\n"

BARCODES = [(1, 5), (2, 14), (3, 41), (4, 32), (5, 23), (6, 63), (7, 81)]
LANDMARKS = [(6, 3.0, 4.0, 0.0001, 0.0002), (7, -1.0, 2.0, 0.0001, 0.0002)]
# z-up Vicon: the robot turns counter-clockwise (w > 0) while moving along +x
GROUNDTRUTH = [(t, 0.1 * t, 0.02 * t * t, 0.2 * t) for t in np.arange(0.0, 3.01, 0.1)]
ODOMETRY = [(0.25, 0.1, 0.2), (0.5, 0.1, 0.2), (1.0, 0.2, -0.4), (2.0, 0.0, 0.0)]
MEASUREMENTS = [(0.75, 63, 5.0, 0.3), (0.75, 14, 1.0, 0.1), (1.5, 81, 2.0, -0.25)]


def write(path: Path, rows):
    lines = [HEAD]
    for r in rows:
        lines.append(" \t ".join(str(v) for v in r) + "\n")
    path.write_text("".join(lines), encoding="utf-8")


def make_dataset(folder: Path, **override) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    tables = {"Barcodes.dat": BARCODES, "Landmark_Groundtruth.dat": LANDMARKS,
              "Robot1_Groundtruth.dat": GROUNDTRUTH, "Robot1_Odometry.dat": ODOMETRY,
              "Robot1_Measurement.dat": MEASUREMENTS}
    tables.update(override)
    for name, rows in tables.items():
        write(folder / name, rows)
    return folder


@pytest.fixture
def folder(tmp_path):
    return make_dataset(tmp_path / "set")


# --------------------------------------------------------------------------- malformed files
@pytest.mark.parametrize("name, rows, line, reason", [
    ("Robot1_Odometry.dat", ODOMETRY[:2] + [(1.0, 0.2)] + ODOMETRY[3:], 7, "2 columns"),
    ("Robot1_Odometry.dat", ODOMETRY[:1] + [(0.5, "fast", 0.2)] + ODOMETRY[2:], 6,
     "expected a number, got 'fast'"),
    ("Robot1_Odometry.dat", ODOMETRY[:3] + [(0.9, 0.0, 0.0)], 8, "time goes backwards"),
    ("Robot1_Measurement.dat", MEASUREMENTS[:2] + [(1.5, 99, 2.0, -0.25)], 7,
     "unknown barcode 99"),
    ("Robot1_Measurement.dat", MEASUREMENTS[:1] + [(0.7, 14, 1.0, 0.1)], 6,
     "time goes backwards"),
    ("Robot1_Measurement.dat", [(0.75, "63a", 5.0, 0.3)], 5, "expected an integer"),
    ("Robot1_Groundtruth.dat", GROUNDTRUTH[:3] + [(0.3, 1.0, "nan", 0.0)], 8,
     "expected a finite number"),
    ("Robot1_Groundtruth.dat", GROUNDTRUTH[:3] + [(0.15, 1.0, 1.0, 0.0)], 8,
     "time goes backwards"),
    ("Landmark_Groundtruth.dat", LANDMARKS + [(9, 1.0, 1.0, 0.0, 0.0)], 7, "has no barcode"),
    ("Landmark_Groundtruth.dat", [(6, 3.0, 4.0, 0.0001)], 5, "4 columns"),
    ("Landmark_Groundtruth.dat", LANDMARKS[:1] + [(7, -1.0, 2.0, -0.0001, 0.0002)], 6,
     "column x std-dev: expected a value from 0 to 1000 m, got '-0.0001'"),
    ("Robot1_Measurement.dat", MEASUREMENTS[:1] + [(0.75, 14, 1e300, 0.1)], 6,
     "column range: expected a value from 0 to 1000 m, got '1e+300'"),
    ("Robot1_Measurement.dat", MEASUREMENTS[:1] + [(0.75, 14, -0.5, 0.1)], 6,
     "column range: expected a value from 0 to 1000 m, got '-0.5'"),
    ("Robot1_Odometry.dat", ODOMETRY[:1] + [(0.5, 1e300, 0.2)] + ODOMETRY[2:], 6,
     "column forward velocity: expected a value from -100 to 100 m/s, got '1e+300'"),
    ("Robot1_Odometry.dat", ODOMETRY[:1] + [(0.5, 0.1, -1e300)] + ODOMETRY[2:], 6,
     "column angular velocity: expected a value from -100 to 100 rad/s, got '-1e+300'"),
    ("Robot1_Groundtruth.dat", GROUNDTRUTH[:3] + [(0.3, 1e300, 1.0, 0.0)], 8,
     "column x: expected a value from -10000 to 10000 m"),
    ("Barcodes.dat", BARCODES + [(8, 10 ** 40)], 12, "column barcode: expected a value from 0"),
    ("Barcodes.dat", BARCODES + [(8, 63)], 12, "barcode 63 listed twice"),
    ("Barcodes.dat", BARCODES[1:], 10, "no barcode for robot subject(s) [1]"),
])
def test_a_malformed_file_is_rejected_with_its_name_line_and_reason(tmp_path, name, rows, line,
                                                                     reason):
    folder = make_dataset(tmp_path / "bad", **{name: rows})
    with pytest.raises(ValueError) as err:
        mrclam.load(folder, 1, unknown_barcodes="error")
    msg = str(err.value)
    assert isinstance(err.value, mrclam.MRCLAMFormatError)
    assert str(folder / name) in msg and f"line {line}:" in msg and reason in msg, msg


@pytest.mark.parametrize("name", ["Robot1_Odometry.dat", "Barcodes.dat",
                                  "Landmark_Groundtruth.dat"])
def test_a_byte_order_mark_is_named_not_miscounted_as_columns(tmp_path, name):
    folder = make_dataset(tmp_path / "bom")
    path = folder / name
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())      # what some editors prepend
    with pytest.raises(mrclam.MRCLAMFormatError) as err:
        mrclam.load(folder, 1)
    msg = str(err.value)
    assert str(path) in msg and "line 1:" in msg and "byte-order mark" in msg, msg
    assert "columns" not in msg


def test_a_missing_file_and_bad_arguments(tmp_path, folder):
    (folder / "Robot1_Odometry.dat").unlink()
    with pytest.raises(ValueError, match="Robot1_Odometry.dat: missing file"):
        mrclam.load(folder, 1)
    with pytest.raises(ValueError, match="robot: expected"):
        mrclam.load(folder, 6)
    with pytest.raises(ValueError, match="unknown_barcodes"):
        mrclam.load(folder, 1, unknown_barcodes="keep")


def test_misread_barcodes_are_dropped_by_default_counted_and_warned_about_once(tmp_path):
    misreads = [(1.6, 99, 2.0, 0.0), (1.7, 98, 2.5, 0.1), (1.8, 99, 2.0, 0.0)]
    folder = make_dataset(tmp_path / "u", **{"Robot1_Measurement.dat": MEASUREMENTS + misreads})
    with pytest.warns(mrclam.MRCLAMWarning) as record:
        log = mrclam.load(folder, 1)
    assert len(record) == 1                                    # one warning, with the count
    msg = str(record[0].message)
    assert "Robot1_Measurement.dat: 3 reading(s)" in msg and "[98, 99]" in msg, msg
    assert log.dropped["unknown_barcode_readings"] == 3
    assert log.dropped["robot_readings"] == 1
    assert list(log.camera.id) == [63, 81]                    # the good readings all kept
    strict = pytest.raises(mrclam.MRCLAMFormatError, match=r"line 8: unknown barcode 99")
    with strict:
        mrclam.load(folder, 1, unknown_barcodes="error")


def test_a_clean_folder_loads_without_a_warning(folder):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        log = mrclam.load(folder, 1)
    assert log.dropped["unknown_barcode_readings"] == 0


# --------------------------------------------------------------------------- frame and content
def test_vicon_landmarks_and_bearings_are_mirrored_into_z_down(folder):
    log = mrclam.load(folder, 1)
    for t, x, y, th in GROUNDTRUTH[3:21]:          # the log keeps Vicon over its timeline
        np.testing.assert_allclose(log.truth_at(t), [x, -y, wrap_angle(-th)], atol=1e-9)
    lm = log.world().landmarks()
    assert sorted(lm) == [63, 81]                       # ids are the barcodes
    np.testing.assert_allclose(lm[63], [3.0, -4.0])
    np.testing.assert_allclose(lm[81], [-1.0, -2.0])
    np.testing.assert_allclose(log.camera.bearing, [-0.3, 0.25])
    np.testing.assert_allclose(log.camera.rho, [5.0, 2.0])


def test_commands_become_wheel_speeds_exactly(folder):
    b = 0.3
    log = mrclam.load(folder, 1, wheel_base=b)
    u, dt = log.controls()
    v = 0.5 * (u[:, 0] + u[:, 1])
    w_down = (u[:, 1] - u[:, 0]) / b                   # the course's convention
    # intervals start at 0.25, 0.5, 0.75 (a reading), 1.0, 1.5 (a reading)
    np.testing.assert_allclose(log.enc_t, [0.25, 0.5, 0.75, 1.0, 1.5, 2.0])
    np.testing.assert_allclose(dt, [0.25, 0.25, 0.25, 0.5, 0.5])
    np.testing.assert_allclose(v, [0.1, 0.1, 0.1, 0.2, 0.2], atol=1e-15)
    np.testing.assert_allclose(w_down, [-0.2, -0.2, -0.2, 0.4, 0.4], atol=1e-14)
    assert log.wheel_base == b


def test_other_robots_are_dropped_and_readings_are_fused_at_their_own_time(folder):
    log = mrclam.load(folder, 1)
    assert list(log.camera.id) == [63, 81]              # barcode 14 is robot 2
    assert log.meta["dropped"]["robot_readings"] == 1
    events = list(log.events())
    kinds = [(e.kind, round(e.t, 9)) for e in events]
    assert kinds == [("predict", 0.5), ("predict", 0.75), ("update", 0.75), ("predict", 1.0),
                     ("predict", 1.5), ("update", 1.5), ("predict", 2.0)]
    # the prediction that ends at the reading's time uses the command logged before it
    np.testing.assert_allclose(events[1].u.mean(), 0.1)
    np.testing.assert_allclose(events[1].dt, 0.25)


def test_the_start_is_the_first_command_inside_vicon_and_duration_cuts(folder):
    log = mrclam.load(folder, 1, duration=1.0)
    np.testing.assert_allclose(log.enc_t, [0.25, 0.5, 0.75, 1.0])   # t0 + 1 s = 1.25
    # the filter starts at Vicon's pose at the first command (0.25 s, halfway between two
    # Vicon samples: y is interpolated linearly), mirrored
    np.testing.assert_allclose(log.start_pose, [0.025, -0.0013, -0.05], atol=1e-12)


def test_dead_reckoning_on_hand_made_files_matches_a_hand_integration(folder):
    log = mrclam.load(folder, 1)
    tr = mrclam.dead_reckoning(log)
    # integrate the z-up commands with an Euler loop, then mirror
    x, y, th = 0.025, 0.0013, 0.05                  # Vicon at 0.25 s, z-up
    steps = [(0.25, 0.1, 0.2), (0.25, 0.1, 0.2), (0.25, 0.1, 0.2), (0.5, 0.2, -0.4),
             (0.5, 0.2, -0.4)]                        # split at the readings' times
    for dt, v, w in steps:
        x, y, th = x + v * math.cos(th) * dt, y + v * math.sin(th) * dt, th + w * dt
    np.testing.assert_allclose(tr.x[-1], [x, -y, -th], atol=1e-12)
    np.testing.assert_allclose(tr.truth[-1], [0.2, -0.08, -0.4], atol=1e-9)


def test_an_excerpt_is_a_verbatim_prefix_and_loads_like_its_source(tmp_path, folder):
    for r in (2, 3, 4, 5):   # write_excerpt copies all five robots
        for kind, rows in (("Groundtruth", GROUNDTRUTH), ("Odometry", ODOMETRY),
                           ("Measurement", [])):
            write(folder / f"Robot{r}_{kind}.dat", rows)
    out = tmp_path / "excerpt"
    counts = mrclam.write_excerpt(folder, out, seconds=1.6)
    assert counts["Robot1_Odometry.dat"] == 3 and counts["Robot1_Measurement.dat"] == 3
    for name in ("Robot1_Odometry.dat", "Robot1_Groundtruth.dat", "Barcodes.dat"):
        assert (folder / name).read_text().startswith((out / name).read_text())
    a, b = mrclam.load(out, 1), mrclam.load(folder, 1, duration=0.75)
    np.testing.assert_array_equal(a.enc_t, b.enc_t)
    np.testing.assert_array_equal(a.u, b.u)


# --------------------------------------------------------------------------- the shipped excerpt
@pytest.fixture(scope="module")
def excerpt_logs():
    with pytest.warns(mrclam.MRCLAMWarning, match="Robot4_Measurement.dat: 3 reading"):
        return {r: mrclam.load(mrclam.EXCERPT_DIR, r) for r in mrclam.ROBOTS}


def _raw(robot, kind):
    return np.loadtxt(mrclam.EXCERPT_DIR / f"Robot{robot}_{kind}.dat", comments="#", ndmin=2)


def test_the_excerpt_has_all_five_robots_and_its_misread_barcode(excerpt_logs):
    for log in excerpt_logs.values():
        assert log.enc_t[-1] - log.enc_t[0] > 100.0
        assert len(log.camera) > 50
        assert set(log.camera.id) <= set(log.world().landmarks())
    # robot 4 reads barcode 50, which no subject carries: dropped and counted by default,
    # rejected on request
    assert excerpt_logs[4].dropped["unknown_barcode_readings"] == 3
    with pytest.raises(ValueError, match=r"Robot4_Measurement.dat: line \d+: unknown barcode 50"):
        mrclam.load(mrclam.EXCERPT_DIR, 4, unknown_barcodes="error")


@pytest.mark.parametrize("robot", [1, 3])
def test_dead_reckoning_on_the_excerpt_matches_a_plain_loop_over_the_raw_file(excerpt_logs,
                                                                             robot):
    log = excerpt_logs[robot]
    tr = mrclam.dead_reckoning(log)
    odo, gt = _raw(robot, "Odometry"), _raw(robot, "Groundtruth")
    k0 = int(np.searchsorted(odo[:, 0], gt[0, 0]))
    t = odo[k0:, 0]
    t = t[t <= min(odo[-1, 0], gt[-1, 0])]
    # start: Vicon at the first command, by hand (z-up), heading unwrapped
    th_gt = np.unwrap(gt[:, 3])
    x, y, th = (np.interp(t[0], gt[:, 0], gt[:, 1]), np.interp(t[0], gt[:, 0], gt[:, 2]),
                np.interp(t[0], gt[:, 0], th_gt))
    est = {}
    for k in range(k0, k0 + t.size - 1):
        dt = odo[k + 1, 0] - odo[k, 0]
        v, w = odo[k, 1], odo[k, 2]
        x, y, th = x + v * math.cos(th) * dt, y + v * math.sin(th) * dt, th + w * dt
        est[round(odo[k + 1, 0], 6)] = (x, -y, wrap_angle(-th))
    # compare at the odometry times (the log also splits steps at reading times)
    at = {round(float(s), 6): i for i, s in enumerate(tr.t)}
    keys = [s for s in est if s in at]
    assert len(keys) > 0.9 * len(est)
    mine = np.array([tr.x[at[s]] for s in keys])
    hand = np.array([est[s] for s in keys])
    err = np.hypot(*(mine[:, :2] - hand[:, :2]).T)
    assert err.max() < 0.01, err.max()                 # splitting steps moves Euler by < 1 cm
    assert np.max(np.abs(wrap_angle(mine[:, 2] - hand[:, 2]))) < 1e-6
    # the truth beside it is Vicon's, mirrored
    s = keys[len(keys) // 2]
    np.testing.assert_allclose(tr.truth[at[s], :2], [np.interp(s, gt[:, 0], gt[:, 1]),
                                                     -np.interp(s, gt[:, 0], gt[:, 2])],
                               atol=1e-5)


def test_the_known_map_beats_dead_reckoning_on_every_robot(excerpt_logs):
    for r, log in excerpt_logs.items():
        dr = mrclam.dead_reckoning(log).metrics()
        lo = mrclam.localization(log).metrics()
        assert lo["ate_xy"] < 0.5 and lo["ate_xy"] < dr["ate_xy"], (r, lo, dr)


def test_the_logs_noise_reaches_the_runners(folder):
    from slamlib.models import motion_jacobians

    Q = np.array([[0.01, 0.008], [0.008, 0.01]])
    log = mrclam.load(folder, 1).with_noise(Q=Q, sigma_range0=0.1, sigma_range_per_m=0.02,
                                            sigma_bearing=0.01)
    np.testing.assert_array_equal(log.Q(), Q)
    np.testing.assert_allclose(log.sensor().R(2.0), np.diag([0.14 ** 2, 0.01 ** 2]))
    tr = mrclam.dead_reckoning(log)
    # the covariance propagated by hand: P <- A P A^T + W Q W^T at every step
    P = np.diag([1e-6, 1e-6, 1e-6])
    u, dt = log.controls()
    for k in range(dt.size):
        A, W = motion_jacobians(tr.x[k], u[k], dt[k], log.wheel_base)
        P = A @ P @ A.T + W @ Q @ W.T
    np.testing.assert_allclose(tr.P[-1], P, rtol=1e-10, atol=1e-15)
    assert mrclam.load(folder, 1).with_noise(sigma_wheel=0.2).Q()[0, 0] == pytest.approx(0.04)


def test_select_readings_keeps_the_timeline(folder):
    log = mrclam.load(folder, 1)
    near = log.select_readings(log.camera.rho < 3.0)
    assert list(near.camera.id) == [81]
    np.testing.assert_array_equal(near.enc_t, log.enc_t)
    with pytest.raises(ValueError, match="keep: expected 2"):
        log.select_readings([True])
