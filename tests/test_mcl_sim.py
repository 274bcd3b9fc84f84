"""Monte Carlo localization in the shipped flat, against the simulator's ground truth."""

import numpy as np
import pytest
from mcl_sim import Drive, room_of, tour_from

from slam_core.localization import MclConfig, MonteCarloLocalizer
from slam_core.sim.ground_truth import ground_truth_map
from slam_core.sim.world import load_world

SEEDS = range(10)
TRAVEL = 10.0
#: Moderate particle counts keep these tests fast.
CONFIG = MclConfig(min_particles=300, max_particles=12000)
#: Recovery counts once the estimate stayed right for this many consecutive updates.
STABLE_UPDATES = 5


@pytest.fixture(scope="module")
def flat():
    world = load_world("flat")
    return world, ground_truth_map(world, 0.05, min_height=0.2)


def stable(updates):
    return len(updates) >= STABLE_UPDATES and all(u.good for u in updates[-STABLE_UPDATES:])


def test_global_localization_then_kidnapping(flat):
    world, grid = flat
    n = len(world.tour)
    found, recovered = [], []
    for seed in SEEDS:
        mcl = MonteCarloLocalizer(grid, CONFIG, rng=np.random.default_rng(seed))
        drive = Drive(world, mcl, seed)
        k = (5 * seed) % n
        ups = drive.leg(k, TRAVEL)
        assert ups[-1].travelled >= TRAVEL - 0.5, "the tour must give 10 m of travel"
        found.append(ups[-1].good and ups[-1].localized)
        here = room_of(world.waypoints[k].name)
        j = next(i % n for i in range(k + n // 2, k + n + n // 2)
                 if room_of(world.waypoints[i % n].name) not in (here, "hall"))
        ups = drive.leg(j, TRAVEL, stop=stable)
        recovered.append(stable(ups))
    assert sum(found) >= 9, f"global localization right at 10 m in {sum(found)}/10 runs: {found}"
    assert sum(recovered) >= 8, f"recovered from kidnapping in {sum(recovered)}/10 runs: {recovered}"


def test_tracking_from_a_known_pose(flat):
    world, grid = flat
    errors_xy, errors_th = [], []
    for seed in (0, 1):
        k = 7 * seed
        _, pose = tour_from(world, k)
        mcl = MonteCarloLocalizer(grid, CONFIG, rng=np.random.default_rng(seed), initial_pose=pose,
                                  initial_covariance=np.diag([0.05, 0.05, 0.05]) ** 2)
        ups = Drive(world, mcl, seed).leg(k, 25.0)
        errors_xy += [u.error_xy for u in ups]
        errors_th += [u.error_theta for u in ups]
        assert np.mean([u.localized for u in ups[5:]]) > 0.95
    assert np.median(errors_xy) < 0.05
    assert np.median(errors_th) < np.radians(2.0)
    assert np.max(errors_xy) < 0.2


def test_tracking_with_the_beam_model(flat):
    world, grid = flat
    _, pose = tour_from(world, 0)
    cfg = MclConfig(min_particles=200, max_particles=1000, sensor_model="beam", max_beams=30)
    mcl = MonteCarloLocalizer(grid, cfg, rng=np.random.default_rng(7), initial_pose=pose,
                              initial_covariance=np.diag([0.05, 0.05, 0.05]) ** 2)
    ups = Drive(world, mcl, 7).leg(0, 10.0)
    assert np.median([u.error_xy for u in ups]) < 0.05
    assert np.median([u.error_theta for u in ups]) < np.radians(2.0)
