"""``homebot map LOG --out DIR``: an occupancy grid from the poses a log carries."""

from __future__ import annotations

import time
from pathlib import Path

from app.cli.progress import fraction_bar
from slam_core.datasets import CREDIT, is_bundled, resolve_log
from slam_core.io.render import save_png
from slam_core.io.ros_map import save_map
from slam_core.occupancy_grid import SensorModel
from slam_core.pipelines.odometry_mapping import map_from_odometry


def register(sub) -> None:
    p = sub.add_parser("map", help="build a map from a log's raw odometry poses",
                       description="Build an occupancy grid from a CARMEN log using the poses it "
                                   "carries (no SLAM) and write PGM + YAML + PNG.")
    p.add_argument("log", help="CARMEN log (.clf, .bz2, .gz) or a bundled name: intel, mit-csail")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument("--resolution", type=float, default=0.05, help="metres per cell (0.05)")
    p.add_argument("--usable-range", type=float, default=SensorModel.usable_range,
                   help="trust beams up to this range in metres (%(default)s)")
    p.set_defaults(run=run)


def run(args) -> int:
    log = resolve_log(args.log)
    started = time.perf_counter()
    with fraction_bar(f"mapping {log.name}") as progress:
        result = map_from_odometry(log, args.resolution, SensorModel(usable_range=args.usable_range),
                                   progress=progress)
    elapsed = time.perf_counter() - started
    if result.scans == 0:
        raise ValueError(f"{log}: no laser records (FLASER, RLASER, ROBOTLASER1) to build a map from"
                         + "".join(f"; {w}" for w in result.warnings))
    stem = args.out / "map"
    pgm, yml = save_map(result.grid, stem)
    png = save_png(result.grid, stem.with_suffix(".png"), result.trajectory.poses,
                   caption="raw odometry" + (" - " + CREDIT if is_bundled(log) else ""))
    traj = result.trajectory.save(args.out / "trajectory.txt")
    for warning in result.warnings:
        print(f"warning: {warning}")
    ny, nx = result.grid.shape
    print(f"integrated {result.scans} scans from {log} in {elapsed:.1f} s "
          f"using the log's odometry poses (no SLAM)")
    print(f"map: {nx} x {ny} cells at {args.resolution} m, origin "
          f"({result.grid.origin[0]:.2f}, {result.grid.origin[1]:.2f})")
    print(f"wrote {yml}, {pgm}, {png}, {traj}")
    if is_bundled(log):
        print(CREDIT)
    return 0
