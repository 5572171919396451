"""Marker worlds: the report's arena and random ones, stored as JSON.

A world is a flat floor with ArUco markers on posts. Each marker is a square of
side ``marker_length`` whose centre stands ``marker_height`` above the floor at
``(x, y)`` in the z-down frame N, and whose printed face looks along ``yaw``
(the direction of its outward normal, an angle in N: 0 looks along +x, pi/2
along +y, i.e. clockwise from above). A camera sees the marker only from the
side it faces.

File format (``data/worlds/*.json``, one object)::

    {
      "format": "slamlib-world/1",
      "name": "report_arena",
      "description": "free text",
      "frame": "N (z-down: x forward, y right; angles clockwise seen from above)",
      "dictionary": "DICT_ARUCO_ORIGINAL",
      "marker_length": 0.15,            # m, side of the black square
      "marker_height": 0.15,            # m, centre above the floor
      "bounds": [xmin, xmax, ymin, ymax],
      "start_pose": [x, y, theta],      # optional
      "markers": [{"id": 0, "x": 0.30, "y": 0.00, "yaw": 0.0}, ...]
    }

Every field is checked on load; an error names the file and the field.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .validate import ID_MAX, read_json_file

__all__ = ["Marker", "World", "WorldFormatError", "load_world", "save_world", "random_world",
           "report_arena", "DATA_DIR", "WORLDS_DIR"]

FORMAT = "slamlib-world/1"
#: The project's data folder (worlds, runs, calibration).
def _data_dir() -> Path:
    """The course's data: ``slamlib/data`` where a non-editable install ships it (the
    package data of ``pyproject.toml``), else ``data/`` beside the package (a checkout, or
    an editable install of one)."""
    package = Path(__file__).resolve().parent
    shipped = package / "data"
    return shipped if shipped.is_dir() else package.parent / "data"


#: Where the worlds, runs, calibration and stored studies are (see :func:`_data_dir`).
DATA_DIR = _data_dir()
WORLDS_DIR = DATA_DIR / "worlds"


class WorldFormatError(ValueError):
    """A world file is malformed; the message names the file and the field."""


@dataclass(frozen=True)
class Marker:
    """One ArUco marker: its id, centre ``(x, y)`` in N and facing direction ``yaw``."""

    id: int
    x: float
    y: float
    yaw: float = 0.0

    @property
    def position(self) -> np.ndarray:
        """Centre ``[x, y]`` in N."""
        return np.array([self.x, self.y])


@dataclass(frozen=True)
class World:
    """A set of markers with their common geometry (see the module docstring)."""

    name: str
    markers: tuple[Marker, ...]
    marker_length: float = 0.15
    marker_height: float = 0.15
    dictionary: str = "DICT_ARUCO_ORIGINAL"
    bounds: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 1.0)
    start_pose: tuple[float, float, float] | None = None
    description: str = ""
    _index: dict = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        ids = [m.id for m in self.markers]
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ValueError(f"markers: duplicate id(s) {dup}")
        object.__setattr__(self, "_index", {m.id: k for k, m in enumerate(self.markers)})

    @property
    def ids(self) -> np.ndarray:
        """Marker ids in file order, shape (n,)."""
        return np.array([m.id for m in self.markers], dtype=int)

    @property
    def positions(self) -> np.ndarray:
        """Marker centres in N, shape (n, 2), in the order of :attr:`ids`."""
        return np.array([[m.x, m.y] for m in self.markers], dtype=float).reshape(-1, 2)

    @property
    def yaws(self) -> np.ndarray:
        """Marker facing directions in N, shape (n,)."""
        return np.array([m.yaw for m in self.markers], dtype=float)

    def landmarks(self) -> dict[int, np.ndarray]:
        """The map as ``{id: [x, y]}``, the form the filters take."""
        return {m.id: m.position for m in self.markers}

    def marker(self, marker_id: int) -> Marker:
        """The marker with this id (KeyError if absent)."""
        return self.markers[self._index[int(marker_id)]]

    def to_dict(self) -> dict:
        """The JSON object of this world."""
        d = {"format": FORMAT, "name": self.name, "description": self.description,
             "frame": "N (z-down: x forward, y right; angles clockwise seen from above)",
             "dictionary": self.dictionary, "marker_length": self.marker_length,
             "marker_height": self.marker_height, "bounds": list(self.bounds)}
        if self.start_pose is not None:
            d["start_pose"] = list(self.start_pose)
        d["markers"] = [{"id": m.id, "x": m.x, "y": m.y, "yaw": m.yaw} for m in self.markers]
        return d


# --------------------------------------------------------------------------- loading
def _number(where: str, obj: dict, key: str, positive: bool = False) -> float:
    if key not in obj:
        raise WorldFormatError(f"{where}: missing field '{key}'")
    v = obj[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise WorldFormatError(f"{where}.{key}: expected a number, got {v!r}")
    if not math.isfinite(v) if isinstance(v, float) else abs(v) > 2**1000:
        raise WorldFormatError(f"{where}.{key}: expected a finite number, got "
                               f"{v if isinstance(v, float) else 'an integer that large'}")
    if positive and v <= 0:
        raise WorldFormatError(f"{where}.{key}: expected a positive number, got {v!r}")
    return float(v)


def _numbers(where: str, obj: dict, key: str, n: int, required: bool = True):
    if key not in obj:
        if required:
            raise WorldFormatError(f"{where}: missing field '{key}'")
        return None
    v = obj[key]
    if not isinstance(v, list) or len(v) != n:
        raise WorldFormatError(f"{where}.{key}: expected a list of {n} numbers, got {v!r}")
    return tuple(_number(f"{where}.{key}", {str(i): x for i, x in enumerate(v)}, str(i))
                 for i in range(n))


def world_from_dict(d: dict, where: str = "world") -> World:
    """Build a :class:`World` from its JSON object, checking every field."""
    if not isinstance(d, dict):
        raise WorldFormatError(f"{where}: expected a JSON object at the top level")
    if d.get("format") != FORMAT:
        raise WorldFormatError(f"{where}.format: expected '{FORMAT}', got {d.get('format')!r}")
    for key in ("name", "dictionary"):
        if not isinstance(d.get(key), str) or not d[key]:
            raise WorldFormatError(f"{where}.{key}: expected a non-empty string")
    length = _number(where, d, "marker_length", positive=True)
    height = _number(where, d, "marker_height", positive=True)
    bounds = _numbers(where, d, "bounds", 4)
    if not (bounds[0] < bounds[1] and bounds[2] < bounds[3]):
        raise WorldFormatError(f"{where}.bounds: expected [xmin, xmax, ymin, ymax] "
                               f"with xmin < xmax and ymin < ymax, got {list(bounds)}")
    start = _numbers(where, d, "start_pose", 3, required=False)
    raw = d.get("markers")
    if not isinstance(raw, list):
        raise WorldFormatError(f"{where}: missing field 'markers' (a list)")
    markers, seen = [], {}
    for k, m in enumerate(raw):
        w = f"{where}.markers[{k}]"
        if not isinstance(m, dict):
            raise WorldFormatError(f"{w}: expected an object with id, x, y, yaw")
        mid = m.get("id")
        if isinstance(mid, bool) or not isinstance(mid, int) or not 0 <= mid <= ID_MAX:
            raise WorldFormatError(f"{w}.id: expected an integer in 0..2**63-1, got "
                                   f"{mid!r}"[:200])
        if mid in seen:
            raise WorldFormatError(f"{w}.id: duplicate id {mid} (also markers[{seen[mid]}])")
        seen[mid] = k
        yaw = _number(w, m, "yaw") if "yaw" in m else 0.0
        markers.append(Marker(mid, _number(w, m, "x"), _number(w, m, "y"), yaw))
    return World(name=d["name"], markers=tuple(markers), marker_length=length,
                 marker_height=height, dictionary=d["dictionary"], bounds=bounds,
                 start_pose=start, description=str(d.get("description", "")))


def load_world(path) -> World:
    """Load a world from a JSON file (a name without folder is looked up in ``data/worlds``).

    Raises
    ------
    WorldFormatError
        With the file and the offending field in the message.
    """
    d, p = read_json_file(path, WorldFormatError, WORLDS_DIR)
    return world_from_dict(d, where=str(p))


def save_world(world: World, path) -> None:
    """Write a world as indented JSON (stable key order, so files diff well)."""
    Path(path).write_text(json.dumps(world.to_dict(), indent=2) + "\n", encoding="utf-8")


def report_arena() -> World:
    """The report's arena (``data/worlds/report_arena.json``)."""
    return load_world(WORLDS_DIR / "report_arena.json")


def random_world(extent: tuple[float, float, float, float] = (0.0, 6.0, -3.0, 3.0),
                 count: int = 20, min_spacing: float = 0.5, seed: int = 0,
                 marker_length: float = 0.15, marker_height: float = 0.15,
                 dictionary: str = "DICT_ARUCO_ORIGINAL", max_id: int = 1023,
                 name: str | None = None) -> World:
    """A random world: ``count`` markers in ``extent`` at least ``min_spacing`` apart.

    Positions are drawn uniformly by rejection, facing directions uniformly in
    [-pi, pi), ids without repetition from ``0..max_id``. Same seed, same world.

    Raises
    ------
    ValueError
        If the markers cannot be placed (too many for the extent and spacing).
    """
    xmin, xmax, ymin, ymax = (float(v) for v in extent)
    if not (xmin < xmax and ymin < ymax):
        raise ValueError(f"extent: expected (xmin, xmax, ymin, ymax) increasing, got {extent}")
    if count < 0 or count > max_id + 1:
        raise ValueError(f"count: expected 0..{max_id + 1}, got {count}")
    if min_spacing < 0:
        raise ValueError(f"min_spacing: expected >= 0, got {min_spacing}")
    rng = np.random.default_rng(seed)
    pts: list[np.ndarray] = []
    tries = 0
    while len(pts) < count:
        tries += 1
        if tries > 1000 * max(count, 1):
            raise ValueError(f"count: could not place {count} markers {min_spacing} m apart "
                             f"in {extent}; placed {len(pts)}")
        p = rng.uniform([xmin, ymin], [xmax, ymax])
        if all(np.hypot(*(p - q)) >= min_spacing for q in pts):
            pts.append(p)
    ids = np.sort(rng.choice(max_id + 1, size=count, replace=False))
    yaws = rng.uniform(-np.pi, np.pi, size=count)
    markers = tuple(Marker(int(i), round(float(p[0]), 4), round(float(p[1]), 4),
                           round(float(a), 4)) for i, p, a in zip(ids, pts, yaws))
    return World(name=name or f"random_{count}_seed{seed}", markers=markers,
                 marker_length=marker_length, marker_height=marker_height,
                 dictionary=dictionary, bounds=(xmin, xmax, ymin, ymax),
                 description=f"random_world(extent={extent}, count={count}, "
                             f"min_spacing={min_spacing}, seed={seed})")
