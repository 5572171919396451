"""Benchmark of the camera pipeline: frames per second of rendering and of detection.

Prints numbers, never pass/fail. Usage: python bench/bench_vision.py [frames]

For a few robot poses in the report's arena (and an empty view) it times
``render_view`` (floor, markers, 4x4 supersampled edges, blur, noise) and
``detect_markers`` (ArUco detection with sub-pixel corners, IPPE_SQUARE pose,
range and bearing), each over ``frames`` repetitions, and reports the
frames per second of each stage and of the whole sensor (render + detect).
"""

from __future__ import annotations

import sys
import time

import cv2
import numpy as np

from slamlib import vision as V
from slamlib.worlds import report_arena


def timed(fn, n: int) -> float:
    fn()                                   # warm caches (textures, detector)
    t = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t) / n


def main(argv: list[str]) -> int:
    n = int(argv[0]) if argv else 50
    world, cam = report_arena(), V.default_camera()
    poses = {"start (3 markers)": world.start_pose, "facing 31/81": (3.0, 1.5, 2.4),
             "close to 0/1": (2.5, 0.3, -2.8), "empty view": (1.0, 0.5, np.pi)}
    print(f"OpenCV {cv2.__version__}, {cam.width}x{cam.height}, {n} frames per row, "
          f"{cv2.getNumThreads()} OpenCV threads")
    print(f"{'pose':<20} {'markers':>7} {'render fps':>11} {'detect fps':>11} {'both fps':>9}")
    for name, pose in poses.items():
        rng = np.random.default_rng(0)
        img = V.render_view(world, pose, cam, rng=rng)
        k = len(V.detect_markers(img, cam, world.marker_length, world.dictionary))
        tr = timed(lambda p=pose, g=rng: V.render_view(world, p, cam, rng=g), n)
        td = timed(lambda im=img: V.detect_markers(im, cam, world.marker_length,
                                                   world.dictionary), n)
        print(f"{name:<20} {k:>7d} {1 / tr:>11.0f} {1 / td:>11.0f} {1 / (tr + td):>9.0f}")
    sensor = V.CameraMarkerSensor()
    rng = np.random.default_rng(0)
    ts = timed(lambda: sensor.read(world, world.start_pose, rng), n)
    print(f"CameraMarkerSensor.read at the start pose: {1 / ts:.0f} frames per second "
          f"({1e3 * ts:.1f} ms per frame)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
