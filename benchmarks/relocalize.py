"""Re-localization in a restored map: how fast, how exact, and how far ahead of its runner-up.

The flat and the house are mapped from their tours' true poses (one map, no filter); then for
``--poses`` random poses along each tour, with a random heading, a simulated scan is located
(:class:`app.worker.relocalize.Relocalizer`) twice: from a guess 0.5 m / 0.4 rad off (the local
search) and from the tour's farthest pose (the global search, which also finds its runner-up).
Printed per world: CPU and wall time per search, the error of every fix against the true pose,
how many global fixes were accepted, and the margin by which the true pose's fit beat the
runner-up's (the acceptance needs ``RUNNER_UP_MARGIN``).

    python benchmarks/relocalize.py [--poses 40] [--seed 0]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from app.worker import relocalize
from app.worker.relocalize import Relocalizer
from slam_core.geometry import wrap_angle
from slam_core.rbpf.hit_render import SparseHits
from slam_core.rbpf.tiled_map import TiledMaps
from slam_core.sim.lidar import Lidar
from slam_core.sim.world import load_world


def mapped(world, lidar: Lidar, rng) -> tuple[Relocalizer, np.ndarray]:
    """A relocalizer in the world mapped from its tour's true poses, and those poses."""
    maps, poses = TiledMaps(1, 0.05), world.tour_poses()
    for pose in poses:
        maps.integrate(pose[None, :], lidar.scan(pose, rng))
    grid = maps.to_grid(0)
    return Relocalizer(grid, SparseHits.from_dense(maps.hit_sums(0), grid.origin)), poses


def runner_up_margin(relocalizer: Relocalizer, scan) -> float:
    """The global search's best fit minus its runner-up's, as ``locate`` weighs them (the best fit itself
    when the runner-up refined back onto the best pose)."""
    best, runner_up = relocalizer.global_search(scan)
    return best.fit - (0.0 if runner_up is None else runner_up.fit)


def timed(call, *args):
    """``(call(*args), wall s, CPU s)``."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = call(*args)
    return result, time.perf_counter() - wall, time.process_time() - cpu


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    for name in ("flat", "house"):
        world = load_world(name)
        lidar, rng = Lidar(world), np.random.default_rng(args.seed)
        relocalizer, poses = mapped(world, lidar, rng)
        rows = {"local": [], "global": []}
        margins = []
        for _ in range(args.poses):
            truth = poses[rng.integers(len(poses))] + [0.0, 0.0, rng.uniform(-np.pi, np.pi)]
            scan = lidar.scan(truth, rng)
            far = poses[np.argmax(np.hypot(*(poses[:, :2] - truth[:2]).T))]
            near = truth + rng.uniform([-0.5, -0.5, -0.4], [0.5, 0.5, 0.4])
            for search, guess in (("local", near), ("global", far)):
                fix, wall, cpu = timed(relocalizer.locate, scan, guess)
                error = (np.nan, np.nan) if fix is None else (float(np.hypot(*(fix.pose[:2] - truth[:2]))),
                                                              abs(float(wrap_angle(fix.pose[2] - truth[2]))))
                rows[search].append((fix is not None and fix.search == search, wall, cpu, *error))
            margins.append(runner_up_margin(relocalizer, scan))
        for search, found in rows.items():
            ok, wall, cpu, d, dth = (np.array(column, float) for column in zip(*found, strict=True))
            print(f"{name:5s} {search:6s}: {int(ok.sum())}/{len(ok)} found by it; wall median "
                  f"{np.median(wall):.3f} s, max {wall.max():.3f} s; CPU median {np.median(cpu):.3f} s; "
                  f"error max {np.nanmax(d) * 100:.1f} cm / {np.degrees(np.nanmax(dth)):.2f} deg")
        margins = np.array(margins)
        print(f"{name:5s} runner-up: the true pose fits {margins.min():.2f}-{margins.max():.2f} better "
              f"(median {np.median(margins):.2f}); below the {relocalize.RUNNER_UP_MARGIN} margin: "
              f"{int((margins < relocalize.RUNNER_UP_MARGIN).sum())}/{len(margins)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
