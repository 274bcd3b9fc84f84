"""``homebot localize LOG --map MAP.yaml [--global | --initial x,y,theta] --out DIR``.

Writes the per-scan trajectory and ``localization.png`` (the map, the trajectory
coloured by the localized flag, rings where the robot was lost and found again)
and prints how often it was localized and how often it was lost.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from app.cli.progress import fraction_bar
from slam_core.datasets import resolve_log
from slam_core.io.ros_map import load_map
from slam_core.localization.mcl import SENSOR_MODELS, MclConfig
from slam_core.localization.picture import save_run_png
from slam_core.localization.replay import replay_log


def register(sub) -> None:
    p = sub.add_parser("localize", help="replay a log against a saved map (Monte Carlo localization)",
                       description="Monte Carlo localization (AMCL-class) of a CARMEN log in a saved "
                                   "ROS map; writes the per-scan trajectory that 'homebot eval' scores.")
    p.add_argument("log", help="CARMEN log (.clf, .bz2, .gz) or a bundled name: intel, mit-csail")
    p.add_argument("--map", required=True, type=Path, help="map_server YAML of the known map")
    start = p.add_mutually_exclusive_group()
    start.add_argument("--global", dest="global_", action="store_true",
                       help="start with no idea where the robot is (the default)")
    start.add_argument("--initial", type=_pose, metavar="X,Y,THETA",
                       help="start near this map pose (metres, radians)")
    p.add_argument("--initial-std", type=_triple, default=(0.25, 0.25, 0.26), metavar="SX,SY,STH",
                   help="standard deviations around --initial (%(default)s)")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument("--particles", type=_range, default=(MclConfig.min_particles, MclConfig.max_particles),
                   metavar="MIN,MAX", help="KLD-sampling particle bounds (%(default)s)")
    p.add_argument("--beams", type=int, default=MclConfig.max_beams, help="beams used per scan (%(default)s)")
    p.add_argument("--sensor-model", choices=SENSOR_MODELS, default=MclConfig.sensor_model)
    p.add_argument("--seed", type=int, default=0, help="random seed (%(default)s)")
    p.set_defaults(run=run)


def _numbers(text: str, count: int, what: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != count or not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"{what} must be {count} comma-separated numbers, got {text!r}")
    return values


def _pose(text: str):
    return _numbers(text, 3, "--initial")


def _triple(text: str):
    return _numbers(text, 3, "--initial-std")


def _range(text: str):
    lo, hi = _numbers(text, 2, "--particles")
    return int(lo), int(hi)


def run(args) -> int:
    log = resolve_log(args.log)
    grid = load_map(args.map)
    lo, hi = args.particles
    config = MclConfig(min_particles=lo, max_particles=hi, max_beams=args.beams,
                       sensor_model=args.sensor_model)
    cov = None if args.initial is None else np.diag(np.square(args.initial_std))
    with fraction_bar(f"localizing {log.name}") as progress:
        result = replay_log(log, grid, config, args.initial, cov, args.seed, progress)
    n = len(result.trajectory.stamps)
    if n == 0:
        raise ValueError(f"{log}: no laser records to localize" + "".join(f"; {w}" for w in result.warnings))
    traj = result.trajectory.save(args.out / "trajectory.txt")
    flags = result.localized
    lost = int(np.sum(flags[:-1] & ~flags[1:]))
    rate = 100 * float(flags.mean()) if len(flags) else 0.0
    png = save_run_png(grid, result.trajectory.poses, flags, args.out / "localization.png",
                       caption=f"{log.name}: localized {rate:.1f}% of scans, lost {lost}x")
    for warning in result.warnings:
        print(f"warning: {warning}")
    per_update = 1e3 * float(np.mean(result.update_seconds)) if result.update_seconds else 0.0
    start = "global" if args.initial is None else f"from {args.initial}"
    print(f"localized {n} scans of {log} in {args.map} ({start}) in {result.wall_seconds:.1f} s: "
          f"{result.updates} filter updates, {per_update:.1f} ms per update")
    if result.first_localized is None:
        print("never localized")
    else:
        print(f"first localized at scan {result.first_localized} "
              f"({result.seconds_to_localized:.1f} s of log time)")
    print(f"localized rate: {rate:.1f}% of scans; lost {lost} times")
    odo = result.odometry
    measured = odo.get("errors_measured", 0)
    if measured >= config.tracking.calibration_min:
        fitted = min(measured, config.tracking.calibration_window)
        print(f"odometry as the last {fitted} of {measured} matches measured it: travel scale error "
              f"{100 * odo['translation_scale_error']:+.1f} %, heading drift "
              f"{odo['heading_drift_deg_per_m']:+.2f} deg/m")
    else:
        print(f"odometry: {measured} matches measured it, too few to calibrate")
    print(f"wrote {traj}, {png}")
    return 0
