"""Plan time on house-like maps, homebot's numba A* side by side with pyastar2d (C++).

    python benchmarks/planning.py [--sizes 1000 2000] [--repeats 7]

Each map size runs in a fresh subprocess with an empty ``NUMBA_CACHE_DIR`` so
the first call includes numba's compilation; warm figures are the median (and
best) of interleaved repeats. Both planners search the SAME costmap under the
SAME rules: pyastar2d charges the destination cell's weight for every move,
diagonal or not, and cuts corners, so homebot runs with ``diagonal_step=1,
corner_cutting=True`` for the comparison, and both paths are priced by one
shared function (:func:`path_cost`). homebot's own rules (octile, sqrt(2)
diagonals, no corner cutting) and the full ``Planner.plan`` are timed too.
pyastar2d is for this benchmark only (``pip install pyastar2d``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

RES = 0.05
WALL = 3  # cells (15 cm)
DOOR = 18  # cells (90 cm)
MIN_ROOM = 60  # cells (3 m)
SEED = 20261122


def house_map(n: int, seed: int = SEED) -> np.ndarray:
    """``int8`` ROS map (100 wall, 0 free), ``n x n``: rooms split recursively, doors, furniture."""
    rng = np.random.default_rng(seed)
    t = np.zeros((n, n), np.int8)
    t[:WALL, :] = t[-WALL:, :] = t[:, :WALL] = t[:, -WALL:] = 100

    def furnish(x0, y0, x1, y1):
        margin = 20  # keep 1 m free along the walls so doors stay usable
        for _ in range(rng.integers(0, 4)):
            w, h = rng.integers(8, 25, 2)
            if x1 - x0 - 2 * margin <= w or y1 - y0 - 2 * margin <= h:
                continue
            x = rng.integers(x0 + margin, x1 - margin - w)
            y = rng.integers(y0 + margin, y1 - margin - h)
            t[y:y + h, x:x + w] = 100

    def split(x0, y0, x1, y1):
        w, h = x1 - x0, y1 - y0
        if max(w, h) <= 2 * MIN_ROOM + WALL + 1 or (max(w, h) < 4 * MIN_ROOM and rng.random() < 0.3):
            furnish(x0, y0, x1, y1)
            return
        vertical = w >= h
        lo, hi = (x0, x1) if vertical else (y0, y1)
        cut = int(rng.integers(lo + MIN_ROOM, hi - MIN_ROOM - WALL))
        along = (y0, y1) if vertical else (x0, x1)
        doors = [int(rng.integers(along[0] + 5, along[1] - DOOR - 5))
                 for _ in range(1 + int(along[1] - along[0] > 6 * MIN_ROOM))]
        if vertical:
            t[y0:y1, cut:cut + WALL] = 100
            for d in doors:
                t[d:d + DOOR, cut:cut + WALL] = 0
            split(x0, y0, cut, y1)
            split(cut + WALL, y0, x1, y1)
        else:
            t[cut:cut + WALL, x0:x1] = 100
            for d in doors:
                t[cut:cut + WALL, d:d + DOOR] = 0
            split(x0, y0, x1, cut)
            split(x0, cut + WALL, x1, y1)

    split(WALL, WALL, n - WALL, n - WALL)
    return t


def path_cost(weights: np.ndarray, cells: np.ndarray, diagonal_step: float, corner_cutting: bool) -> float:
    """THE shared price of a cell path ``(n, 2)`` of ``(ix, iy)``: sum of step length x destination weight.

    ``inf`` if a step is not to an 8-neighbour, enters an impassable cell, or
    (without ``corner_cutting``) squeezes diagonally past an impassable cell.
    """
    cells = np.asarray(cells, np.int64)
    d = np.diff(cells, axis=0)
    if len(d) and (np.abs(d).max(axis=1).min() != 1 or np.abs(d).max() > 1):
        return math.inf
    w = weights.astype(np.float64)
    dest = w[cells[1:, 1], cells[1:, 0]]
    diagonal = (d[:, 0] != 0) & (d[:, 1] != 0)
    if not corner_cutting:
        a = cells[:-1][diagonal]
        dd = d[diagonal]
        if np.any(np.isinf(w[a[:, 1], a[:, 0] + dd[:, 0]]) | np.isinf(w[a[:, 1] + dd[:, 1], a[:, 0]])):
            return math.inf
    return float(np.sum(np.where(diagonal, diagonal_step, 1.0) * dest))


def nearest_free(costmap, ix, iy) -> tuple[int, int]:
    free = np.argwhere(np.isfinite(costmap.weights))
    k = np.argmin((free[:, 0] - iy) ** 2 + (free[:, 1] - ix) ** 2)
    return int(free[k, 1]), int(free[k, 0])


def _timed(fn):
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def _cpu_timed(fn):
    t = time.process_time()
    out = fn()
    return time.process_time() - t, out


def child(n: int, repeats: int) -> dict:
    """Run in a fresh process: every first call here is a cold one."""
    t_import, _ = _timed(lambda: __import__("slam_core.planning"))
    from slam_core.planning import Planner, costmap_from_trinary
    from slam_core.planning.astar import SQRT2, astar

    try:
        import pyastar2d
    except ImportError:
        pyastar2d = None
    trinary = house_map(n)
    t_costmap, cm = _timed(lambda: costmap_from_trinary(trinary, RES))
    cm.padded_weights()
    start = nearest_free(cm, 25, 25)
    goal = nearest_free(cm, n - 26, n - 26)
    w32 = cm.weights  # float32, inf = impassable, min 1: pyastar2d's input as is
    out = {"n": n, "import_s": t_import, "costmap_s": t_costmap, "start": start, "goal": goal,
           "free_fraction": float(np.isfinite(w32).mean())}

    def hb_same():
        return astar(cm, start, goal, diagonal_step=1.0, corner_cutting=True)

    def pya():
        p = pyastar2d.astar_path(w32, start[::-1], goal[::-1], allow_diagonal=True)
        return p[:, ::-1]

    def hb_native():
        return astar(cm, start, goal)

    planner = Planner()
    start_xy = cm.cell_to_world(start)
    goal_xy = cm.cell_to_world(goal)

    def hb_plan():
        return planner.plan(cm, start_xy, goal_xy)

    out["hb_first_s"], r = _timed(hb_same)
    if pyastar2d is not None:
        out["pya_first_s"], p = _timed(pya)
    out["hb_native_first_s"], rn = _timed(hb_native)
    out["plan_first_s"], path = _timed(hb_plan)
    times = {"hb": [], "pya": [], "hb_native": [], "plan": [], "hb_cpu": [], "pya_cpu": []}
    for _ in range(repeats):
        times["hb"].append(_timed(hb_same)[0])
        times["hb_cpu"].append(_cpu_timed(hb_same)[0])
        if pyastar2d is not None:
            times["pya"].append(_timed(pya)[0])
            times["pya_cpu"].append(_cpu_timed(pya)[0])
        times["hb_native"].append(_timed(hb_native)[0])
        times["plan"].append(_timed(hb_plan)[0])
    out["costmap_warm_s"] = _timed(lambda: costmap_from_trinary(trinary, RES))[0]
    for k, v in times.items():
        if v:
            out[k + "_warm_s"] = float(np.median(v))
            out[k + "_best_s"] = float(np.min(v))
    out["hb_cost"] = path_cost(w32, r.cells, 1.0, True)
    out["hb_reported_cost"] = r.cost
    out["hb_expansions"] = r.expansions
    out["hb_native_cost"] = path_cost(w32, rn.cells, SQRT2, False)
    out["hb_native_reported_cost"] = rn.cost
    out["plan_waypoints"] = len(path.waypoints)
    out["plan_length_m"] = path.length
    if pyastar2d is not None:
        out["pya_cost"] = path_cost(w32, p, 1.0, True)
        out["pya_native_cost"] = path_cost(w32, p, SQRT2, False)
        out["pya_cells"] = len(p)
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def run_child(n: int, repeats: int, cache_dir: str) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": cache_dir, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, __file__, "--child", str(n), "--repeats", str(repeats)],
                          env=env, capture_output=True, text=True, check=False)
    if proc.returncode:
        raise SystemExit(f"child for {n}x{n} failed:\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def ms(x) -> str:
    return "n/a" if x is None else f"{1000 * x:.1f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 2000])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--child", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.child, args.repeats)))
        return
    try:
        import pyastar2d  # noqa: F401
        have_pya = True
    except ImportError:
        have_pya = False
        print("pyastar2d is NOT installed: only homebot is timed. `pip install pyastar2d` for the comparison "
              "(benchmark only, not a project dependency).")
    cpu_lines = Path("/proc/cpuinfo").read_text().splitlines()
    cpu = next((line.split(":", 1)[1].strip() for line in cpu_lines if "model name" in line), "?")
    print(f"machine: {cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"load average {os.getloadavg()[0]:.1f}")
    rows = []
    for n in args.sizes:
        with tempfile.TemporaryDirectory(prefix="numba-cold-") as cache:
            cold = run_child(n, args.repeats, cache)
            cached = run_child(n, 1, cache)
        rows.append((cold, cached))
        print(f"{n}x{n}: done", file=sys.stderr)
    print()
    print("Same cost model (pyastar2d's: 8-connected, every move costs the destination weight, corners cut):")
    print("| map | free | homebot first (compile) | homebot first (cache on disk) | pyastar2d first "
          "| homebot warm | pyastar2d warm | speed-up | homebot warm CPU | pyastar2d warm CPU | speed-up CPU "
          "| homebot cost | pyastar2d cost | expansions |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for cold, cached in rows:
        pya_warm = cold.get("pya_warm_s")
        speed = f"{pya_warm / cold['hb_warm_s']:.2f}x" if pya_warm else "n/a"
        pya_cpu = cold.get("pya_cpu_warm_s")
        speed_cpu = f"{pya_cpu / cold['hb_cpu_warm_s']:.2f}x" if pya_cpu else "n/a"
        pya_cost = cold.get("pya_cost", float("nan"))
        print(f"| {cold['n']}x{cold['n']} | {100 * cold['free_fraction']:.0f}% | {ms(cold['hb_first_s'])} ms "
              f"| {ms(cached['hb_first_s'])} ms | {ms(cold.get('pya_first_s'))} ms "
              f"| {ms(cold['hb_warm_s'])} ms | {ms(pya_warm)} ms | {speed} | {ms(cold['hb_cpu_warm_s'])} ms "
              f"| {ms(pya_cpu)} ms | {speed_cpu} | {cold['hb_cost']:.3f} "
              f"| {pya_cost:.3f} | {cold['hb_expansions']} |")
    print()
    print("homebot's own rules (octile, sqrt(2) diagonals, no corner cutting) and the full Planner.plan "
          "(A* + snapping + shortcuts + 0.25 m waypoints, costmap prebuilt):")
    print("| map | costmap build first (compile) / warm | A* first call (kernel already compiled) "
          "| A* warm | Planner.plan warm "
          "| cost (cells) | pyastar2d path under these rules | waypoints | length | peak RSS |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for cold, _ in rows:
        pn = cold.get("pya_native_cost")
        pn_s = "n/a" if pn is None else ("cuts a corner (illegal)" if math.isinf(pn) else f"{pn:.3f}")
        print(f"| {cold['n']}x{cold['n']} | {ms(cold['costmap_s'])} / {ms(cold['costmap_warm_s'])} ms "
              f"| {ms(cold['hb_native_first_s'])} ms "
              f"| {ms(cold['hb_native_warm_s'])} ms | {ms(cold['plan_warm_s'])} ms "
              f"| {cold['hb_native_cost']:.3f} | {pn_s} | {cold['plan_waypoints']} "
              f"| {cold['plan_length_m']:.1f} m | {cold['peak_rss_mb']:.0f} MB |")
    if have_pya:
        same = all(abs(c["hb_cost"] - c["pya_cost"]) <= 1e-6 * c["pya_cost"] for c, _ in rows)
        fast = all(c["hb_warm_s"] <= c["pya_warm_s"] for c, _ in rows)
        fast_cpu = all(c["hb_cpu_warm_s"] <= c["pya_cpu_warm_s"] for c, _ in rows)
        print(f"\nequal path cost: {'yes' if same else 'NO'}; homebot warm <= pyastar2d warm: wall "
              f"{'yes' if fast else 'NO'}, CPU {'yes' if fast_cpu else 'NO'}")


if __name__ == "__main__":
    main()
