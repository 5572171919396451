"""Regenerate the recorded runs in data/runs (and the random world they use), bit for bit.

Usage:
    python tools/make_runs.py           # rewrite data/worlds/random_16_seed4.json, data/runs/*
    python tools/make_runs.py --check   # regenerate in memory; exit 1 if a file would change

Every run is a scenario of ``slamlib.sim.SCENARIOS`` simulated with its seed;
the same code and seed give the same bytes. The random world is
``random_world(extent=(0, 5, -2.5, 2.5), count=16, seed=4)`` (seed 4 of the
first ten lets the loop see the most markers), with a start pose on the loop.
"""

from __future__ import annotations

import json
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from slamlib.runs import RUNS_DIR, save_run
from slamlib.sim import SCENARIOS, loop_waypoints, scenario
from slamlib.worlds import WORLDS_DIR, World, random_world, save_world

RANDOM_WORLD = "random_16_seed4"


def make_random_world() -> World:
    """The random world of the ``random_loop`` run."""
    w = random_world(extent=(0.0, 5.0, -2.5, 2.5), count=16, min_spacing=0.5, seed=4,
                     name=RANDOM_WORLD)
    start = loop_waypoints(w.bounds, margin=1.0)[0]
    return replace(w, start_pose=(round(float(start[0]), 6), round(float(start[1]), 6),
                                  round(-np.pi / 2, 10)),
                   description=w.description + "; start pose on the elliptic loop of "
                   "slamlib.sim.loop_waypoints(bounds, margin=1.0), heading -y")


def write_all(worlds_dir: Path, runs_dir: Path) -> list[Path]:
    """Write the random world and every run; return the files written."""
    worlds_dir.mkdir(parents=True, exist_ok=True)
    save_world(make_random_world(), worlds_dir / f"{RANDOM_WORLD}.json")
    files = [worlds_dir / f"{RANDOM_WORLD}.json"]
    for name in SCENARIOS:
        run = scenario(name)
        save_run(run, runs_dir / name)
        files += sorted((runs_dir / name).iterdir())
        print(run.summary())
    return files


def main(argv: list[str]) -> int:
    check = "--check" in argv
    if not check:
        write_all(WORLDS_DIR, RUNS_DIR)
        return 0
    # the world must exist before the runs can be simulated: compare it first
    world_text = json.dumps(make_random_world().to_dict(), indent=2) + "\n"
    stored = WORLDS_DIR / f"{RANDOM_WORLD}.json"
    changed = []
    if not stored.is_file() or stored.read_text(encoding="utf-8") != world_text:
        changed.append(stored)
    with tempfile.TemporaryDirectory() as tmp:
        for name in SCENARIOS:
            save_run(scenario(name), Path(tmp) / name)
            for f in sorted((Path(tmp) / name).iterdir()):
                old = RUNS_DIR / name / f.name
                if not old.is_file() or old.read_bytes() != f.read_bytes():
                    changed.append(old)
    for f in changed:
        print(f"would change: {f}")
    print("all recorded runs are up to date" if not changed else f"{len(changed)} file(s) differ")
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
