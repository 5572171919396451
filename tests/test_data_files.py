"""Data files fail at the line that is wrong (issue 24, point 5).

Each malformed file gets a ValueError (the loader's own: RunFormatError,
CalibrationFormatError, ValueError) whose message names the file and the line
or the field, never a UnicodeDecodeError, RecursionError, OverflowError,
AttributeError or OpenCV's SystemError, and never a run that loads wrong.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from slamlib import vision as V
from slamlib.runs import RUNS_DIR, RunFormatError, load_run
from slamlib.validate import read_json_file, read_text_file
from slamlib.worlds import DATA_DIR, WORLDS_DIR, WorldFormatError, load_world

PHOTOS = DATA_DIR / "aruco_photos"


@pytest.fixture
def run_copy(tmp_path):
    dst = tmp_path / "arena_loop"
    shutil.copytree(RUNS_DIR / "arena_loop", dst)
    return dst


def lines_of(path: Path) -> list[str]:
    return path.read_text(encoding="utf-8").split("\n")


def refused(folder: Path, file: str, *parts: str) -> str:
    with pytest.raises(RunFormatError) as exc:
        load_run(folder)
    msg = str(exc.value)
    assert file in msg, msg
    for p in parts:
        assert p in msg, msg
    return msg


# ----------------------------------------------------------------- runs: cut and inconsistent files
def test_an_encoder_file_cut_inside_its_last_number_is_refused(run_copy):
    # today it loads, and the last tick count (22099 -> 220) moves the final pose by a metre
    p = run_copy / "encoders.csv"
    text = p.read_text(encoding="utf-8")
    p.write_text(text[:-3], encoding="utf-8")
    n = len(text.splitlines())
    refused(run_copy, "encoders.csv", f"line {n}", "cut")


@pytest.mark.parametrize("file", ["truth.csv", "camera.csv"])
def test_any_csv_cut_inside_its_last_line_is_refused(run_copy, file):
    p = run_copy / file
    text = p.read_text(encoding="utf-8")
    p.write_text(text[:-2], encoding="utf-8")
    refused(run_copy, file, f"line {len(text.splitlines())}", "cut")


def test_encoders_that_end_before_the_camera_rows_are_refused(run_copy):
    # encoders to 30 s, camera rows to 60 s
    p = run_copy / "encoders.csv"
    lines = lines_of(p)
    keep = [ln for ln in lines[1:] if ln and float(ln.split(",")[0]) <= 30.0]
    p.write_text("\n".join([lines[0], *keep]) + "\n", encoding="utf-8")
    refused(run_copy, "meta.json", "duration", "encoders.csv")
    meta = json.loads((run_copy / "meta.json").read_text())
    del meta["duration"]                              # without it, the camera's rows tell
    (run_copy / "meta.json").write_text(json.dumps(meta, indent=2))
    cam = lines_of(run_copy / "camera.csv")
    first_late = next(i for i, ln in enumerate(cam[1:], start=2)
                      if ln and float(ln.split(",")[0]) > 30.0)
    refused(run_copy, "camera.csv", f"line {first_late}", "after the last encoder reading")


def test_a_camera_row_far_after_the_encoders_is_refused(run_copy):
    # a row at t = 9999 was fused with no prediction before it
    p = run_copy / "camera.csv"
    text = p.read_text(encoding="utf-8")
    p.write_text(text + "9999,9999,21,1.0,0.1,21,1.0,0.1\n", encoding="utf-8")
    refused(run_copy, "camera.csv", f"line {len(text.splitlines()) + 1}", "t_capture",
            "after the last encoder reading")


def test_a_late_camera_still_loads(tmp_path):
    # frames captured within the encoders may arrive after their end (a camera 0.3 s late)
    from slamlib.runs import save_run
    from slamlib.sim import scenario

    run = scenario("arena_loop", latency=0.3)
    assert run.camera.t_arrival.max() > run.enc_t[-1]
    save_run(run, tmp_path / "late")
    back = load_run(tmp_path / "late")
    assert np.array_equal(back.camera.t_arrival, run.camera.t_arrival)


def test_truth_that_ends_before_the_encoders_is_refused(run_copy):
    p = run_copy / "truth.csv"
    lines = lines_of(p)
    keep = [ln for ln in lines[1:] if ln and float(ln.split(",")[0]) <= 30.0]
    p.write_text("\n".join([lines[0], *keep]) + "\n", encoding="utf-8")
    refused(run_copy, "truth.csv", f"line {len(keep) + 1}", "encoder")


# ----------------------------------------------------------------- runs: bytes, digits, types
@pytest.mark.parametrize("file, old, new, line", [
    ("truth.csv", b"t,x", b"t\xff,x", 1),                       # in the header
    ("truth.csv", b"\n0,3,-0.78", b"\n0,3,-0.7\xe98", 2),      # Latin-1 in a number
    ("encoders.csv", b"\n0,65300", b"\n0,65\xc0\xaf300", 2),    # an overlong encoding
    ("camera.csv", b"t_capture", b"t_\xed\xa0\x80capture", 1),  # a surrogate
    ("meta.json", b'"world"', b'"wor\x80ld"', 4),                # a lone continuation byte
    ("meta.json", b'"name"', b'"na\xf4\x90\x80\x80me"', 3),      # beyond U+10FFFF
])
def test_invalid_utf8_names_the_file_and_line(run_copy, file, old, new, line):
    p = run_copy / file
    raw = p.read_bytes()
    assert old in raw
    p.write_bytes(raw.replace(old, new, 1))
    refused(run_copy, file, f"line {line}", "UTF-8")


@pytest.mark.parametrize("file", ["truth.csv", "meta.json"])
def test_a_byte_order_mark_is_named(run_copy, file):
    p = run_copy / file
    p.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    refused(run_copy, file, "line 1", "byte-order mark")


def test_deeply_nested_json_is_refused_with_its_line(run_copy):
    meta = json.loads((run_copy / "meta.json").read_text())
    text = json.dumps(meta, indent=2)
    text = text[:-2] + ',\n  "extra":\n' + "[" * 100_000 + "]" * 100_000 + "\n}"
    (run_copy / "meta.json").write_text(text)
    refused(run_copy, "meta.json", f"line {text.count(chr(10), 0, text.index('[[')) + 1}",
            "nested")


def test_a_5000_digit_integer_is_refused(run_copy):
    text = (run_copy / "meta.json").read_text()
    (run_copy / "meta.json").write_text(text.replace('"seed": 1', '"seed": ' + "1" * 5000))
    msg = refused(run_copy, "meta.json", "line 5", "5000 digits")
    assert len(msg) < 300


def test_a_5000_digit_count_in_a_csv_is_refused_briefly(run_copy):
    p = run_copy / "encoders.csv"
    lines = lines_of(p)
    lines[5] = "0.1," + "1" * 5000 + ",100"
    p.write_text("\n".join(lines))
    msg = refused(run_copy, "encoders.csv", "line 6", "ticks_R")
    assert len(msg) < 300


@pytest.mark.parametrize("value", [2**70, 2**63, -(2**63) - 1])
def test_ticks_beyond_int64_are_refused(run_copy, value):
    p = run_copy / "encoders.csv"
    lines = lines_of(p)
    lines[5] = f"0.1,{value},100"
    p.write_text("\n".join(lines))
    refused(run_copy, "encoders.csv", "line 6", "ticks_R")


def test_an_id_beyond_int64_in_the_camera_rows_is_refused(run_copy):
    p = run_copy / "camera.csv"
    lines = lines_of(p)
    f = lines[3].split(",")
    f[2] = str(2**64)
    lines[3] = ",".join(f)
    p.write_text("\n".join(lines))
    refused(run_copy, "camera.csv", "line 4", "id")


@pytest.mark.parametrize("key, value", [("motion", 5), ("motion", [0.02]), ("sensor", 5),
                                        ("sensor", "AnalyticMarkerSensor"),
                                        ("controller", 5), ("encoder", None),
                                        ("duration", "59.8"), ("duration", -1),
                                        ("seed", 1.5), ("seed", True), ("description", 7)])
def test_meta_fields_of_the_wrong_type_are_refused(run_copy, key, value):
    meta = json.loads((run_copy / "meta.json").read_text())
    meta[key] = value
    (run_copy / "meta.json").write_text(json.dumps(meta, indent=2))
    refused(run_copy, "meta.json", f"'{key}'")


def test_the_recorded_runs_still_load():
    for folder in sorted(RUNS_DIR.iterdir()):
        run = load_run(folder)
        assert run.camera.t_capture.max() <= run.enc_t[-1]


# ----------------------------------------------------------------- the shared readers
def test_read_text_file_names_the_line_and_column_of_a_bad_byte(tmp_path):
    p = tmp_path / "f.txt"
    p.write_bytes(b"first\nsecond \xff line\n")
    with pytest.raises(ValueError, match=r"f.txt: line 2, column 8: not valid UTF-8"):
        read_text_file(p)
    p.write_bytes(b"")
    assert read_text_file(p) == ""


def test_read_json_file_refuses_what_json_loads_raises_on(tmp_path):
    p = tmp_path / "w.json"
    for text, reason in [('{"a": [' + "[" * 5000 + "]" * 5000 + "]}", "line 1"),
                         ('{\n"a":\n' + "9" * 5000 + "}", "line 3"),
                         ("", "empty file")]:
        p.write_text(text)
        with pytest.raises(ValueError, match=reason) as exc:
            read_json_file(p)
        assert "w.json" in str(exc.value) and len(str(exc.value)) < 300


# ----------------------------------------------------------------- worlds and the camera's JSON
def test_world_and_camera_json_with_bad_bytes_are_named(tmp_path):
    w = tmp_path / "arena.json"
    raw = (WORLDS_DIR / "report_arena.json").read_bytes()
    w.write_bytes(raw.replace(b"report", b"rep\xffort", 1))
    with pytest.raises(WorldFormatError, match=r"arena.json: line \d+.*UTF-8"):
        load_world(w)
    c = tmp_path / "cam.json"
    c.write_bytes(b"\xef\xbb\xbf" + (V.CALIBRATION_DIR / "realsense_640x480.json").read_bytes())
    with pytest.raises(V.CalibrationFormatError, match="cam.json: line 1: .*byte-order mark"):
        V.load_camera(c)
    c.write_text("[" * 100_000)
    with pytest.raises(V.CalibrationFormatError, match="cam.json: line 1"):
        V.load_camera(c)


@pytest.mark.parametrize("key, value, reason", [("id", 2**70, "id"), ("id", -1, "id"),
                                               ("x", 10**4000, "x")])
def test_world_numbers_out_of_range_are_named(tmp_path, key, value, reason):
    d = json.loads((WORLDS_DIR / "report_arena.json").read_text())
    d["markers"][2][key] = value
    w = tmp_path / "w.json"
    w.write_text(json.dumps(d, indent=2))
    with pytest.raises(WorldFormatError, match=rf"w.json.markers\[2\].{reason}") as exc:
        load_world(w)
    assert len(str(exc.value)) < 300


# ----------------------------------------------------------------- OpenCV's yml files
YML = PHOTOS / "tutorial_camera_params.yml"
DICT_YML = PHOTOS / "tutorial_dict.yml"


def _variants(src: Path, tmp_path: Path) -> dict[str, tuple[Path, str]]:
    raw = src.read_bytes()
    out = {"empty": (b"", "empty file"),
           "truncated": (raw[:100] if src == YML else raw[: len(raw) // 2 + 7], "line "),
           "bom": (b"\xef\xbb\xbf" + raw, "byte-order mark"),
           "utf8": (raw.replace(b"\n", b"\n\xff", 1), "UTF-8"),
           "spaces": (b"   \n\n", "empty file")}
    paths = {}
    for name, (data, reason) in out.items():
        p = tmp_path / f"{name}.yml"
        p.write_bytes(data)
        paths[name] = (p, reason)
    return paths


@pytest.mark.parametrize("case", ["empty", "truncated", "bom", "utf8", "spaces"])
def test_opencv_calibration_files_fail_with_their_line(tmp_path, case):
    p, reason = _variants(YML, tmp_path)[case]
    with pytest.raises(V.CalibrationFormatError) as exc:
        V.read_opencv_calibration(p, 640, 480)
    msg = str(exc.value)
    assert str(p) in msg and reason in msg, msg
    assert case == "empty" or case == "spaces" or re.search(r"line \d+", msg), msg


@pytest.mark.parametrize("case", ["empty", "truncated", "bom", "utf8"])
def test_opencv_dictionary_files_fail_with_their_line(tmp_path, case):
    p, reason = _variants(DICT_YML, tmp_path)[case]
    with pytest.raises(ValueError) as exc:
        V.read_dictionary(p)
    msg = str(exc.value)
    assert str(p) in msg and reason in msg, msg


def test_the_shipped_opencv_files_still_read():
    cam = V.read_opencv_calibration(YML, 640, 480)
    assert cam.K[0, 0] == pytest.approx(628.158)
    assert V.read_dictionary(DICT_YML).markerSize > 0


# ----------------------------------------------------------------- dictionaries
@pytest.mark.parametrize("code", [999, -1, 22, 2**40, np.int64(999)])
def test_unknown_dictionary_codes_are_refused(code):
    # 999 silently gave a 4x4 dictionary
    cam = V.load_camera()
    with pytest.raises(ValueError, match="dictionary"):
        V.detect_markers(np.zeros((480, 640), np.uint8), cam, 0.15, dictionary=code)
    with pytest.raises(ValueError, match="dictionary"):
        V.get_dictionary(code)


def test_known_dictionary_codes_still_work():
    import cv2

    for name in ("DICT_ARUCO_ORIGINAL", "DICT_4X4_50", "DICT_APRILTAG_36h11"):
        code = getattr(cv2.aruco, name)
        assert V.get_dictionary(code).markerSize == V.get_dictionary(name).markerSize
