"""Worlds: the report's arena as COURSE.md gives it, the loader's errors, random worlds."""

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest

from slamlib.sim import arena_loop_waypoints
from slamlib.worlds import (
    WORLDS_DIR,
    WorldFormatError,
    load_world,
    random_world,
    report_arena,
    save_world,
)

ARENA = {0: (0.30, 0.00), 1: (1.40, -0.20), 11: (3.99, 0.605), 21: (2.715, 2.50),
         31: (2.535, 2.39), 41: (2.10, 1.20), 51: (1.99, 1.20), 61: (4.57, -1.69),
         71: (0.283, 1.70), 81: (0.80, 2.86)}


def test_report_arena_is_the_reports():
    w = report_arena()
    assert sorted(w.ids.tolist()) == sorted(ARENA)
    for mid, (x, y) in ARENA.items():
        assert w.marker(mid).position.tolist() == pytest.approx([x, y])
    assert w.marker_length == 0.15 and w.marker_height == 0.15
    assert w.dictionary == "DICT_ARUCO_ORIGINAL"
    assert np.allclose(w.start_pose, [3.0, -0.78, math.pi / 2])


def test_arena_markers_face_the_loop():
    """Every marker but 51 (back to back with 41, facing away from the loop) faces
    a point of the loop from less than 75 degrees off its normal."""
    w = report_arena()
    path = arena_loop_waypoints()
    facing = 0
    for m in w.markers:
        d = path - m.position
        cosang = (d @ [math.cos(m.yaw), math.sin(m.yaw)]) / np.hypot(*d.T)
        facing += bool(np.any(cosang > math.cos(math.radians(75))))
    assert facing >= 9


def write(tmp_path, d, name="w.json"):
    p = tmp_path / name
    p.write_text(json.dumps(d))
    return p


@pytest.fixture
def arena_dict():
    return json.loads((WORLDS_DIR / "report_arena.json").read_text())


def test_loader_rejects_duplicate_id(tmp_path, arena_dict):
    arena_dict["markers"][3]["id"] = arena_dict["markers"][1]["id"]
    p = write(tmp_path, arena_dict)
    with pytest.raises(WorldFormatError) as exc:
        load_world(p)
    msg = str(exc.value)
    assert str(p) in msg and "markers[3].id" in msg and "duplicate" in msg


def test_loader_rejects_non_finite_position(tmp_path, arena_dict):
    arena_dict["markers"][2]["y"] = float("nan")
    p = write(tmp_path, arena_dict)          # json writes NaN, which Python reads back
    with pytest.raises(WorldFormatError) as exc:
        load_world(p)
    assert str(p) in str(exc.value) and "markers[2].y" in str(exc.value)
    assert "finite" in str(exc.value)


@pytest.mark.parametrize("drop", ["x", "y"])
def test_loader_rejects_missing_marker_field(tmp_path, arena_dict, drop):
    del arena_dict["markers"][4][drop]
    p = write(tmp_path, arena_dict)
    with pytest.raises(WorldFormatError) as exc:
        load_world(p)
    assert str(p) in str(exc.value) and f"missing field '{drop}'" in str(exc.value)
    assert "markers[4]" in str(exc.value)


@pytest.mark.parametrize("field", ["marker_length", "bounds", "markers"])
def test_loader_rejects_missing_top_field(tmp_path, arena_dict, field):
    del arena_dict[field]
    p = write(tmp_path, arena_dict)
    with pytest.raises(WorldFormatError, match=field) as exc:
        load_world(p)
    assert str(p) in str(exc.value)


def test_loader_rejects_bad_json_with_line(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text('{\n  "format": "slamlib-world/1",\n  "name": oops\n}\n')
    with pytest.raises(WorldFormatError, match="line 3"):
        load_world(p)


def test_save_load_roundtrip(tmp_path):
    w = random_world(count=12, seed=3)
    save_world(w, tmp_path / "r.json")
    assert load_world(tmp_path / "r.json") == w


def test_random_world_is_deterministic_and_spaced():
    a, b = random_world(count=15, seed=9), random_world(count=15, seed=9)
    assert a == b and a != random_world(count=15, seed=10)
    p = a.positions
    d = np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))
    assert d[~np.eye(len(p), dtype=bool)].min() >= 0.5
    assert np.all((a.yaws >= -math.pi) & (a.yaws < math.pi))


def test_stored_random_world_is_what_the_tool_makes():
    spec = importlib.util.spec_from_file_location(
        "make_runs", Path(__file__).resolve().parent.parent / "tools" / "make_runs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    stored = load_world(mod.RANDOM_WORLD)
    assert stored == mod.make_random_world()
    assert stored.start_pose is not None
