"""Monte Carlo localization benchmark.

1. Time per filter update (motion sample + sensor model + weights + resampling) for a fixed
   particle count (KLD pinned: min = max) with a 360-beam simulated lidar scan of which 60
   beams are used, in the shipped flat; likelihood field (and beam model up to 5,000).
2. Global localization along the simulated house tour (recorded as a CARMEN log with
   ``homebot sim record``'s writer) against the house's ground-truth map: error vs the truth.
3. Localization error when a log is replayed against a map built from it: relation error
   (Kümmerle 2009) of the replayed trajectory and its deviation from the poses the map was
   built with (the map frame), plus the time to the first "localized".

4. The issue #18 table (``--table``): every shipped log in the map ``homebot slam`` builds from it
   (``--slam-maps DIR`` reuses ``DIR/<log>/map.yaml`` and ``trajectory.txt`` of earlier runs) and
   every stress log (``--stress DIR``) in the map built from its ground truth: tracking from the
   reference's first pose and global localization (seeds), scored against the reference
   trajectory with :func:`slam_core.localization.scoring.agreement`. ``--slam-seeds`` gives the
   shipped logs one map per SLAM seed (``DIR/<log>-seed<k>`` with ``--slam-maps``): each seed's map
   has its own errors, and the tracker holds better in some than in others. Of the scans flagged localized
   while more than 0.5 m off, those whose reference pose the map itself contradicts
   (:mod:`slam_core.localization.reference_check`) are counted apart. The last column is the
   ceiling this map and reference allow a scan-to-map localizer: the share of scans within the
   bounds when the tracker's matcher is started at the reference pose itself.

    python benchmarks/localization.py [--map MAP.yaml] [--log mit-csail] [--skip-replay] [--skip-sim]
    python benchmarks/localization.py --table [--slam-maps DIR] [--slam-seeds 0,1,2] [--stress DIR]
                                      [--seeds 0,1]

Without --map, the MIT CSAIL map is built from the log's raw odometry (``homebot map``).
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from slam_core.datasets import resolve_log, resolve_relations
from slam_core.evaluation import load_relations, relation_error
from slam_core.geometry import wrap_angle
from slam_core.io.carmen import laser_records
from slam_core.io.ros_map import load_map, save_map
from slam_core.io.trajectory import Trajectory
from slam_core.localization import MclConfig, MonteCarloLocalizer
from slam_core.localization.reference_check import contradicted, settled_poses
from slam_core.localization.replay import replay_log
from slam_core.localization.scoring import agreement
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.pipelines.log_slam import slam_from_log
from slam_core.pipelines.odometry_mapping import map_from_odometry
from slam_core.sim.ground_truth import ground_truth_map
from slam_core.sim.record import record_tour
from slam_core.sim.simulator import SimConfig, Simulator
from slam_core.sim.world import load_world

COUNTS = (500, 5000, 50000)
BEAMS_USED = 60
UPDATES = 30


def time_updates(grid, frames, n: int, sensor: str) -> tuple[float, float, float]:
    """(first update incl. JIT / cache load, median later update, its CPU time) in ms.

    CPU time (all threads) is reported too: on a shared machine wall time includes waiting.
    """
    cfg = MclConfig(min_particles=n, max_particles=n, max_beams=BEAMS_USED, sensor_model=sensor,
                    update_min_d=0.0, update_min_a=0.0)
    mcl = MonteCarloLocalizer(grid, cfg, rng=np.random.default_rng(0), initial_pose=frames[0][0])
    times, cpu = [], []
    for odom, scan in frames:
        t, c = time.perf_counter(), time.process_time()
        mcl.step(odom, scan)
        mcl.estimate()
        times.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return 1e3 * times[0], 1e3 * float(np.median(times[1:])), 1e3 * float(np.median(cpu[1:]))


def update_costs() -> None:
    world = load_world("flat")
    grid = ground_truth_map(world, 0.05, min_height=0.2)
    sim = Simulator(world, seed=0)
    frames = [(f.odometry_pose, f.scan) for f, _ in zip(sim.tour(), range(UPDATES + 1), strict=False)]
    print(f"scan: {len(frames[0][1])} beams, {BEAMS_USED} used; map {grid.shape[1]} x {grid.shape[0]} "
          f"cells; median of {UPDATES} updates (pose tracking in the flat)")
    print(f"{'particles':>10} {'model':>17} {'first (ms)':>11} {'per update (ms)':>16} {'CPU (ms)':>9}")
    for n in COUNTS:
        for sensor in ("likelihood_field", "beam"):
            if sensor == "beam" and n > 5000:
                continue
            first, per, cpu = time_updates(grid, frames, n, sensor)
            print(f"{n:>10} {sensor:>17} {first:>11.1f} {per:>16.2f} {cpu:>9.2f}")


def simulated_replay(world_name: str, particles: tuple[int, int]) -> None:
    world = load_world(world_name)
    with tempfile.TemporaryDirectory() as tmp:
        rec = record_tour(world, tmp, seed=0, config=SimConfig(sensing_hz=10.0))
        cfg = MclConfig(min_particles=particles[0], max_particles=particles[1], max_beams=BEAMS_USED)
        run = replay_log(rec.log, load_map(rec.map_yaml), cfg)
        truth = Trajectory.load(rec.ground_truth)
    poses = run.trajectory.poses
    d = np.hypot(*(poses[:, :2] - truth.poses[:, :2]).T)
    a = np.degrees(np.abs(wrap_angle(poses[:, 2] - truth.poses[:, 2])))
    k = run.first_localized
    travel = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(truth.poses[:, :2], axis=0).T))])
    print(f"{world_name} tour, global start, {particles[0]}..{particles[1]} particles: {len(d)} scans, "
          f"{travel[-1]:.0f} m, {run.wall_seconds:.1f} s wall, median "
          f"{1e3 * np.median(run.update_seconds):.1f} ms per update")
    if k is None:
        print("never localized")
        return
    after = slice(k, None)
    print(f"first localized after {travel[k]:.1f} m ({run.seconds_to_localized:.1f} s); from then on: "
          f"error median {100 * np.median(d[after]):.1f} cm, p95 {100 * np.percentile(d[after], 95):.1f} cm, "
          f"heading median {np.median(a[after]):.2f} deg, p95 {np.percentile(a[after], 95):.2f} deg; "
          f"localized flag in {100 * run.localized[after].mean():.0f}% of those scans")


def replay(map_path: Path | None, log_name: str, particles: tuple[int, int]) -> None:
    log = resolve_log(log_name)
    with tempfile.TemporaryDirectory() as tmp:
        map_trajectory = None
        if map_path is None:
            t = time.perf_counter()
            built = map_from_odometry(log)
            save_map(built.grid, Path(tmp) / "map")
            map_path = Path(tmp) / "map.yaml"
            map_trajectory = built.trajectory
            print(f"map: built from the log's raw odometry (homebot map, no SLAM) in "
                  f"{time.perf_counter() - t:.1f} s")
        else:
            candidate = map_path.parent / "trajectory.txt"
            map_trajectory = Trajectory.load(candidate) if candidate.exists() else None
            print(f"map: {map_path}")
        grid = load_map(map_path)
        first = next(iter(laser_records(log)))
        start = first.pose if map_trajectory is None else map_trajectory.poses[0]
        cfg = MclConfig(min_particles=particles[0], max_particles=particles[1], max_beams=BEAMS_USED)
        run = replay_log(log, grid, cfg, initial_pose=start,
                         initial_covariance=np.diag([0.25, 0.25, np.radians(15)]) ** 2)
    traj = run.trajectory
    err = relation_error(traj.times, traj.poses, _relations(log_name))
    s = err.summary()
    print(f"replayed {len(traj.stamps)} scans of {log.name} from the map's first pose: "
          f"{run.wall_seconds:.1f} s wall, {run.updates} updates, "
          f"median {1e3 * np.median(run.update_seconds):.1f} ms per update, "
          f"particles median {int(np.median(run.particles))} (max {run.particles.max()})")
    if run.first_localized is not None:
        print(f"first localized at scan {run.first_localized} ({run.seconds_to_localized:.1f} s log time); "
              f"localized in {100 * run.localized.mean():.0f}% of scans")
    print(f"relation error: {s['trans_mean_m']:.3f} m ± {s['trans_std_m']:.3f}, "
          f"{s['rot_mean_deg']:.2f} deg ± {s['rot_std_deg']:.2f} ({s['relations']} relations)")
    if map_trajectory is not None and len(map_trajectory.poses) == len(traj.poses):
        d = np.hypot(*(traj.poses[:, :2] - map_trajectory.poses[:, :2]).T)
        a = np.degrees(np.abs(wrap_angle(traj.poses[:, 2] - map_trajectory.poses[:, 2])))
        print(f"vs the poses the map was built with: {d.mean():.3f} m mean / {np.median(d):.3f} m "
              f"median / {np.percentile(d, 95):.3f} m p95; heading median {np.median(a):.2f} deg, "
              f"p95 {np.percentile(a, 95):.2f} deg")


def _reference_for_shipped(name: str, slam_maps: Path | None, seed: int | None):
    """The SLAM map and trajectory of a shipped log (SLAM ``seed``, 0 when None): from an earlier
    run in ``slam_maps/<name>`` (``<name>-seed<k>`` for a given seed), or a fresh ``homebot slam``."""
    folder = None if slam_maps is None else slam_maps / (name if seed is None else f"{name}-seed{seed}")
    if folder is not None and (folder / "map.yaml").exists():
        return load_map(folder / "map.yaml"), Trajectory.load(folder / "trajectory.txt")
    run = slam_from_log(resolve_log(name), seed=seed or 0)
    return run.grid, run.trajectory


def _reference_for_stress(folder: Path):
    """The map built from a stress log's ground-truth poses, and those poses."""
    log = folder / f"{folder.name}.clf.bz2"
    truth = np.loadtxt(folder / f"{folder.name}.gt", comments="#")
    records = list(laser_records(log))
    if len(records) != len(truth):
        raise ValueError(f"{folder.name}: {len(records)} scans but {len(truth)} ground-truth poses")
    grid = OccupancyGrid(0.05)
    for record, pose in zip(records, truth[:, 1:], strict=True):
        grid.integrate(record.scan, pose)
    return grid, Trajectory([r.stamp.ipc_text for r in records], truth[:, 1:])


def _table_row(name: str, start: str, log: Path, grid, reference: Trajectory, relations, seed: int,
               ceiling: float) -> str:
    initial = reference.poses[0] if start == "known" else None
    t = time.perf_counter()
    run = replay_log(log, grid, None, initial, np.diag([0.1, 0.1, 0.05]) ** 2, seed)
    wall = time.perf_counter() - t
    a = agreement(run.trajectory.poses, reference.poses, run.localized)
    ours = relation_error(run.trajectory.times, run.trajectory.poses, relations).summary()["trans_mean_m"]
    ref = relation_error(reference.times, reference.poses, relations).summary()["trans_mean_m"]
    to_correct = "never" if a.travel_to_correct is None else f"{a.travel_to_correct:.1f}"
    wrong = np.flatnonzero(run.localized & (a.xy_error > 0.5))
    unexplained = len(wrong) - int(contradicted(grid, _scans(log, wrong), reference.poses[wrong]).sum())
    return (f"| {name} | {start} | {seed} | {100 * a.within:.1f} | {a.max_jump:.2f} | {ours:.3f} "
            f"| {ref:.3f} | {100 * a.localized:.1f} | {100 * a.false_localized:.2f} "
            f"| {100 * unexplained / len(a.xy_error):.2f} | {to_correct} | {wall:.0f} "
            f"| {100 * ceiling:.1f} |")


def _scans(log: Path, indices: np.ndarray) -> list:
    """The scans of the log's laser records at ``indices``."""
    wanted = set(int(i) for i in indices)
    return [r.scan for i, r in enumerate(laser_records(log)) if i in wanted]


def issue_table(slam_maps: Path | None, slam_seeds: list[int] | None, stress: Path | None, seeds: list[int],
                logs: set[str] | None, starts: set[str]) -> None:
    print("| log | start | seed | within 0.10 m / 2 deg after 10 m (%) | max jump (m) | relation error (m) "
          "| reference's (m) | localized (%) | localized > 0.5 m off (%) | ... where the map does not "
          "contradict the reference (%) | travel to right pose (m) | wall (s) | matched from the reference "
          "itself: within (%) |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    def wanted(name: str) -> bool:
        return logs is None or name in logs

    cases = [(name if slam_seed is None else f"{name} (SLAM seed {slam_seed})", resolve_log(name),
              *_reference_for_shipped(name, slam_maps, slam_seed), _relations(name))
             for name in ("intel", "mit-csail") if wanted(name) for slam_seed in slam_seeds or [None]]
    if stress is not None:
        for folder in sorted(p for p in stress.iterdir() if p.is_dir() and wanted(p.name)):
            cases.append((folder.name, folder / f"{folder.name}.clf.bz2", *_reference_for_stress(folder),
                          load_relations(folder / f"{folder.name}.relations")))
    for name, log, grid, reference, relations in cases:
        settled = settled_poses(grid, [r.scan for r in laser_records(log)], reference.poses)
        ceiling = agreement(settled, reference.poses).within
        if "known" in starts:
            print(_table_row(name, "known", log, grid, reference, relations, seeds[0], ceiling), flush=True)
        for seed in seeds if "global" in starts else []:
            print(_table_row(name, "global", log, grid, reference, relations, seed, ceiling), flush=True)


def _relations(log_name: str):
    return load_relations(resolve_relations(log_name))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--map", type=Path, help="map YAML to localize in (default: build from the log)")
    parser.add_argument("--log", default="mit-csail", help="log to replay (default mit-csail)")
    parser.add_argument("--particles", default="300,5000", help="MIN,MAX particles for the replay")
    parser.add_argument("--skip-replay", action="store_true")
    parser.add_argument("--skip-updates", action="store_true")
    parser.add_argument("--skip-sim", action="store_true")
    parser.add_argument("--table", action="store_true", help="only the issue #18 table (section 4)")
    parser.add_argument("--slam-maps", type=Path, help="folder with <log>/map.yaml of earlier SLAM runs")
    parser.add_argument("--slam-seeds", help="one map per SLAM seed for the shipped logs (comma-separated)")
    parser.add_argument("--stress", type=Path, help="folder of the stress logs (one folder per log)")
    parser.add_argument("--seeds", default="0,1", help="seeds of the global runs in the table")
    parser.add_argument("--logs", help="only these logs in the table (comma-separated names)")
    parser.add_argument("--starts", default="known,global", help="which starts in the table (%(default)s)")
    args = parser.parse_args()
    t = time.perf_counter()
    if args.table:
        slam_seeds = None if args.slam_seeds is None else [int(v) for v in args.slam_seeds.split(",")]
        issue_table(args.slam_maps, slam_seeds, args.stress, [int(v) for v in args.seeds.split(",")],
                    None if args.logs is None else set(args.logs.split(",")), set(args.starts.split(",")))
        print(f"total {time.perf_counter() - t:.1f} s")
        return
    if not args.skip_updates:
        update_costs()
    lo, hi = (int(v) for v in args.particles.split(","))
    if not args.skip_sim:
        simulated_replay("house", (lo, hi))
    if not args.skip_replay:
        replay(args.map, args.log, (lo, hi))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"total {time.perf_counter() - t:.1f} s, peak memory {peak:.0f} MB")


if __name__ == "__main__":
    main()
