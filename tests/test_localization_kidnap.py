"""Kidnapping in the simulated flat: noticed within 2 s, re-localized within 10 m, and the
``localized`` flag never set while the estimate is more than 0.5 m from the truth."""

import numpy as np
import pytest
from mcl_sim import Drive, room_of

from slam_core.localization import MclConfig, MonteCarloLocalizer
from slam_core.sim.ground_truth import ground_truth_map
from slam_core.sim.world import load_world

SEEDS = range(5)
CONFIG = MclConfig(min_particles=300, max_particles=12000)
NOTICE_SECONDS = 2.0
RELOCALIZE_TRAVEL = 10.0
WRONG_XY = 0.5


@pytest.fixture(scope="module")
def runs():
    world = load_world("flat")
    grid = ground_truth_map(world, 0.05, min_height=0.2)
    n = len(world.tour)
    out = []
    for seed in SEEDS:
        mcl = MonteCarloLocalizer(grid, CONFIG, rng=np.random.default_rng(seed))
        drive = Drive(world, mcl, seed)
        k = (3 * seed + 1) % n
        before = drive.leg(k, 10.0, every_scan=True)
        here = room_of(world.waypoints[k].name)
        j = next(i % n for i in range(k + n // 2, k + n + n // 2)
                 if room_of(world.waypoints[i % n].name) not in (here, "hall"))
        after = drive.leg(j, RELOCALIZE_TRAVEL, every_scan=True)
        out.append((before, after))
    return out


def test_the_flag_is_never_set_while_wrong(runs):
    wrong = [u for before, after in runs for u in before + after if u.localized and u.error_xy > WRONG_XY]
    assert wrong == []


def test_kidnapping_is_noticed_within_two_seconds(runs):
    for before, after in runs:
        assert before[-1].localized, "localized before the kidnapping"
        noticed = next(u.seconds for u in after if not u.localized)
        assert noticed <= NOTICE_SECONDS


def test_relocalized_within_ten_metres_after_kidnapping(runs):
    for _, after in runs:
        right = [u for u in after if u.localized and u.error_xy < 0.1]
        assert right, "re-localized within 10 m of travel"
        assert right[0].travelled <= RELOCALIZE_TRAVEL

