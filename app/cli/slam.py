"""``homebot slam LOG --out DIR``: particle filter SLAM over a log."""

from __future__ import annotations

import json
import resource
import sys
from pathlib import Path

from app.cli.progress import fraction_bar
from app.db.names import check_name
from slam_core.datasets import CREDIT, is_bundled, resolve_log
from slam_core.io.render import save_png
from slam_core.io.ros_map import save_map
from slam_core.pipelines.log_slam import slam_from_log
from slam_core.rbpf import RBPFConfig
from slam_core.session import SUFFIX, load_session, save_session


def register(sub) -> None:
    p = sub.add_parser("slam", help="particle filter SLAM over a log",
                       description="Rao-Blackwellized particle filter SLAM (improved proposal) over a "
                                   "CARMEN log, then a pose graph back end that closes the best "
                                   "particle's loops. Writes the map (PGM + YAML, PNG), the trajectory "
                                   "for every scan (trajectory.txt; the best particle's own in "
                                   "particle_trajectory.txt), the effective config and run stats.")
    p.add_argument("log", help="CARMEN log (.clf, .bz2, .gz) or a bundled name: intel, mit-csail")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument("--particles", type=int, help="number of particles (default 30)")
    p.add_argument("--seed", type=int, default=0, help="random seed (%(default)s)")
    p.add_argument("--config", type=Path, help="a config.json written by an earlier run")
    p.add_argument("--linear-update", type=float, help="metres travelled between filter updates")
    p.add_argument("--angular-update", type=float, help="radians turned between filter updates")
    p.add_argument("--laser-mount", type=float, nargs=3, metavar=("X", "Y", "THETA"),
                   help="the laser's pose on the robot (m, m, rad; default: the offset between the "
                        "log's laser and odometry poses)")
    p.add_argument("--no-loop-closure", action="store_true",
                   help="skip the back end: write the best particle's own map and trajectory")
    p.add_argument("--save-session", metavar="NAME",
                   help=f"also save the mapping session as OUT/NAME{SUFFIX}, to be continued later")
    p.add_argument("--resume", type=Path, metavar="SESSION",
                   help=f"continue a saved session (a {SUFFIX} file) with this log, which must start "
                        "where the session ended; its config is used unless --config is given")
    p.set_defaults(run=run)


def effective_config(args, base: RBPFConfig | None = None) -> RBPFConfig:
    """``base`` (a resumed session's) or the defaults, then --config, then the options given."""
    config = base or RBPFConfig()
    if args.config is not None:
        config = RBPFConfig.from_file(args.config)
    data = config.to_dict()
    options = {"particles": args.particles, "linear_update": args.linear_update,
               "angular_update": args.angular_update}
    data.update({k: v for k, v in options.items() if v is not None})
    if args.no_loop_closure:
        data["loop_closure"]["enabled"] = False
    return RBPFConfig.from_dict(data)  # the options are checked like a config file's values


def run(args) -> int:
    log = resolve_log(args.log)
    resume = load_session(args.resume) if args.resume is not None else None
    config = effective_config(args, resume.config if resume is not None else None)
    name = None if args.save_session is None else check_name(args.save_session, "session name")
    with fraction_bar(f"slam {log.name}") as progress:
        result = slam_from_log(log, config, seed=args.seed, progress=progress, laser_mount=args.laser_mount,
                               resume=resume)
    args.out.mkdir(parents=True, exist_ok=True)
    pgm, yml = save_map(result.map, args.out / "map")
    png = save_png(result.map, args.out / "map.png", result.trajectory.poses,
                   caption="homebot RBPF SLAM" + (" - " + CREDIT if is_bundled(log) else ""))
    traj = result.trajectory.save(args.out / "trajectory.txt")
    particle = result.particle_trajectory.save(args.out / "particle_trajectory.txt")
    (args.out / "config.json").write_text(json.dumps(config.to_dict(), indent=2) + "\n")
    if name is not None:
        session = save_session(result.session, args.out / f"{name}{SUFFIX}")
        print(f"saved the session ({len(result.session.scans)} updates) as {session}")
    stats = {
        "log": str(log),
        "seed": args.seed,
        "laser_mount": list(result.laser_mount.as_tuple()),
        "wall_time_s": round(result.wall_time, 3),
        "filter_time_s": round(result.filter_time, 3),
        "log_duration_s": round(result.log_duration, 3),
        "real_time_factor": round(result.log_duration / max(result.wall_time, 1e-9), 2),
        "peak_rss_mb": round(_peak_rss_mb(), 1),
        "map_storage_mb": round(result.map_bytes / 1e6, 1),
        "tiles_in_use": result.tiles_in_use,
        **result.stats.as_dict(),
        **(result.loop_closure.stats() if result.loop_closure else {}),
        "warnings": result.warnings,
    }
    if resume is not None:
        old = len(resume.scans)
        pairs = result.loop_closure.loop_pairs if result.loop_closure else []
        stats["resumed"] = {"session": str(args.resume), "updates": old,
                            "loop_edges_to_it": sum(anchor < old <= update for anchor, update in pairs)}
    (args.out / "stats.json").write_text(json.dumps(stats, indent=2) + "\n")
    for warning in result.warnings:
        print(f"warning: {warning}")
    s = result.stats
    print(f"{s.scans} scans, {s.updates} filter updates, {s.resamplings} resamplings, "
          f"{s.fallbacks} motion-model fallbacks (of {s.matched + s.fallbacks} particle updates)")
    if result.loop_closure:
        lc = result.loop_closure
        print(f"loop closing: {lc.loop_edges} loop edges ({lc.rejected_edges} rejected as outliers), "
              f"{result.wall_time - result.filter_time:.1f} s")
    print(f"{result.wall_time:.1f} s wall for {result.log_duration:.0f} s of log "
          f"({stats['real_time_factor']}x real time), peak RSS {stats['peak_rss_mb']} MB")
    print(f"wrote {yml}, {pgm}, {png}, {traj}, {particle}, {args.out / 'config.json'}, "
          f"{args.out / 'stats.json'}")
    if is_bundled(log):
        print(CREDIT)
    return 0


def _peak_rss_mb() -> float:
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 1e6 if sys.platform == "darwin" else rss / 1e3
