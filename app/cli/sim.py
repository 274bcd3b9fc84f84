"""``homebot sim``: the home simulator (``sim record WORLD --out DIR``, ``sim worlds``)."""

from __future__ import annotations

import time
from pathlib import Path

from app.cli.inputs import text_file
from app.cli.progress import fraction_bar
from slam_core.robot_config import load_robot
from slam_core.sim.record import record_tour
from slam_core.sim.simulator import SENSORS, SimConfig
from slam_core.sim.world import load_world, resolve_world, world_names


def register(sub) -> None:
    p = sub.add_parser("sim", help="simulate a robot in a home",
                       description="Simulate a differential-drive robot touring a home.")
    actions = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    rec = actions.add_parser("record", help="drive the scripted tour and write a CARMEN log + ground truth",
                             description="Drive the world's scripted tour and write sim.clf (CARMEN, "
                                         "odometry poses), groundtruth.txt, groundtruth.relations (for "
                                         "homebot eval) and groundtruth_map.pgm/.yaml/.png.")
    rec.add_argument("world", help=f"world file, or a shipped world: {', '.join(world_names())}")
    rec.add_argument("--out", required=True, type=Path, help="output folder")
    rec.add_argument("--seed", type=int, default=0, help="random seed (%(default)s)")
    rec.add_argument("--sensor", choices=SENSORS, default="lidar", help="scan source (%(default)s)")
    rec.add_argument("--duration", type=float, default=None,
                     help="stop after this many simulated seconds (default: end of the tour)")
    rec.add_argument("--robot", type=Path, default=None, metavar="FILE",
                     help="the robot's description (YAML, see README); default: the simulated robot")
    rec.add_argument("--resolution", type=float, default=0.05, help="ground-truth map m/cell (0.05)")
    rec.set_defaults(run=run_record)
    worlds = actions.add_parser("worlds", help="list the shipped worlds")
    worlds.set_defaults(run=run_worlds)


def run_record(args) -> int:
    if args.duration is not None and not args.duration > 0:
        raise ValueError("--duration must be positive")
    world = load_world(text_file(resolve_world(args.world)))
    config = SimConfig(sensor=args.sensor, robot=load_robot(args.robot))
    started = time.perf_counter()
    with fraction_bar(f"touring {world.name}") as progress:
        rec = record_tour(world, args.out, seed=args.seed, duration=args.duration,
                          resolution=args.resolution, config=config, progress=progress)
    wall = time.perf_counter() - started
    err = rec.final_odometry_error
    print(f"recorded {rec.scans} {args.sensor} scans over {rec.sim_time:.1f} simulated s in {wall:.1f} s "
          f"(tour {'completed' if rec.tour_completed else 'NOT completed'})")
    print(f"final odometry error: dx {err[0]:+.3f} m, dy {err[1]:+.3f} m, dtheta {err[2]:+.3f} rad")
    print(f"wrote {rec.log}, {rec.ground_truth}, {rec.relations}, {rec.map_yaml}, {rec.map_pgm}, "
          f"{rec.map_png}, {rec.robot}")
    return 0


def run_worlds(args) -> int:
    for name in world_names():
        w = load_world(name)
        x0, y0, x1, y1 = w.bounds()
        print(f"{name:10s} {x1 - x0:.1f} x {y1 - y0:.1f} m, {w.wall_count} wall pieces, "
              f"{len(w.furniture)} furniture, {len(w.circles)} legs, {len(w.waypoints)} waypoints")
    return 0
