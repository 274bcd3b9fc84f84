"""Room segmentation time on SLAM maps and the simulator's worlds, and a picture of the rooms.

    python benchmarks/rooms.py --map out/intel/map.yaml [--map out/mit-csail/map.yaml] [--repeats 5]

Maps come from ``homebot slam LOG --out DIR``. For each map: the first call (numba's kernels
compiled or loaded from the cache), then the median of ``--repeats`` warm calls, the rooms
found, and ``benchmarks/figures/rooms_<name>.png`` (rooms in colours, walls black, unknown grey).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from slam_core.io.ros_map import load_map  # noqa: E402
from slam_core.occupancy_grid import FREE_THRESH, OCCUPIED_THRESH  # noqa: E402
from slam_core.rooms import segment_rooms  # noqa: E402
from slam_core.sim.ground_truth import ground_truth_map  # noqa: E402
from slam_core.sim.world import load_world  # noqa: E402

FIGURES = ROOT / "benchmarks" / "figures"


def picture(grid, labels: np.ndarray) -> Image.Image:
    """Rooms in distinct colours (golden-angle hues), walls black, unknown grey, top row = max y."""
    p = grid.probability()
    rgb = np.full((*p.shape, 3), 205, np.uint8)
    rgb[p < FREE_THRESH] = 255
    rgb[p > OCCUPIED_THRESH] = 0
    for room in range(1, int(labels.max()) + 1):
        hue = (room * 0.381966) % 1.0
        swatch = Image.new("HSV", (1, 1), (int(hue * 255), 110, 245)).convert("RGB")
        rgb[labels == room] = swatch.getpixel((0, 0))
    return Image.fromarray(np.flipud(rgb))


def run(name: str, grid, repeats: int) -> dict:
    t0 = time.perf_counter()
    labels = segment_rooms(grid)
    first = time.perf_counter() - t0
    warm = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        segment_rooms(grid)
        warm.append(time.perf_counter() - t0)
    FIGURES.mkdir(parents=True, exist_ok=True)
    path = FIGURES / f"rooms_{name}.png"
    picture(grid, labels).save(path, optimize=True)
    return {"map": name, "cells": f"{grid.shape[1]} x {grid.shape[0]}", "rooms": int(labels.max()),
            "first_s": round(first, 3), "warm_median_s": round(statistics.median(warm), 3),
            "warm_max_s": round(max(warm), 3), "picture": str(path.relative_to(ROOT))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--map", action="append", default=[], help="a ROS map YAML (repeatable)")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    maps = [(Path(m).parent.name or Path(m).stem, load_map(m)) for m in args.map]
    maps += [(w, ground_truth_map(load_world(w), 0.05)) for w in ("flat", "house")]
    print("| map | cells | rooms | first call s | warm median s | warm max s | picture |")
    print("|---|---|---|---|---|---|---|")
    for name, grid in maps:
        r = run(name, grid, args.repeats)
        print(f"| {r['map']} | {r['cells']} | {r['rooms']} | {r['first_s']} | {r['warm_median_s']} | "
              f"{r['warm_max_s']} | `{r['picture']}` |")


if __name__ == "__main__":
    main()
