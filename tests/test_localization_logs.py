"""Localization on slices of the bundled logs, against the SLAM trajectory of the same slice.

The map is built from the reference poses (``tests/data/localization``, written by
``homebot slam`` on the slice) and the slice's scans; the localizer then replays the
slice in it and is scored with :func:`slam_core.localization.scoring.agreement`.
"""

from pathlib import Path

import numpy as np
import pytest
from bundled import read_bundled

from slam_core.datasets import resolve_relations
from slam_core.evaluation import load_relations, relation_error
from slam_core.io.trajectory import Trajectory
from slam_core.localization import MonteCarloLocalizer
from slam_core.localization.scoring import agreement
from slam_core.occupancy_grid import OccupancyGrid

REFERENCES = Path(__file__).parent / "data" / "localization"
SLICES = {"intel": 1200, "mit-csail": 500}


class Slice:
    def __init__(self, name: str):
        self.name = name
        self.records = read_bundled(name).lasers[:SLICES[name]]
        self.reference = Trajectory.load(REFERENCES / f"{name}_{SLICES[name]}.txt")
        assert self.reference.stamps == [r.stamp.ipc_text for r in self.records]
        self.grid = OccupancyGrid(0.05)
        for record, pose in zip(self.records, self.reference.poses, strict=True):
            self.grid.integrate(record.scan, pose)

    def localize(self, seed: int, start=None):
        mcl = MonteCarloLocalizer(self.grid, rng=np.random.default_rng(seed), initial_pose=start,
                                  initial_covariance=np.diag([0.1, 0.1, 0.05]) ** 2)
        poses, flags = [], []
        for record in self.records:
            mcl.step(record.pose, record.scan)
            e = mcl.estimate()
            poses.append(e.pose)
            flags.append(e.localized)
        return np.array(poses), np.array(flags)


@pytest.fixture(scope="module", params=sorted(SLICES))
def log_slice(request):
    return Slice(request.param)


#: Scans within 0.10 m and 2 deg of the SLAM pose after the first 10 m (issue #18 asks 99.5 %; on the
#: MIT slice the map itself moves ~4 % of the SLAM poses farther than that, see benchmarks/RESULTS.md).
MIN_WITHIN = {"intel": 0.995, "mit-csail": 0.95}


def test_tracking_from_the_slam_start_holds(log_slice):
    poses, flags = log_slice.localize(0, start=log_slice.reference.poses[0])
    a = agreement(poses, log_slice.reference.poses, flags)
    assert a.within >= MIN_WITHIN[log_slice.name], a.within
    assert a.max_jump <= 0.3
    assert a.localized == 1.0 and a.false_localized == 0.0
    relations = load_relations(resolve_relations(log_slice.name))
    times = log_slice.reference.times
    inside = relations[(relations[:, 0] >= times[0]) & (relations[:, 1] <= times[-1])]
    ours = relation_error(times, poses, inside).summary()["trans_mean_m"]
    slams = relation_error(times, log_slice.reference.poses, inside).summary()["trans_mean_m"]
    assert ours <= 1.5 * slams, (ours, slams)


def test_global_localization_converges_and_says_so_only_when_right(log_slice):
    poses, flags = log_slice.localize(1)
    a = agreement(poses, log_slice.reference.poses, flags)
    assert a.travel_to_correct is not None and a.travel_to_correct <= 10.0
    assert a.false_localized == 0.0
    assert a.localized >= 0.6
    # once right and flagged, it stays right
    first = int(np.flatnonzero(flags)[0])
    assert a.xy_error[first:].max() <= 0.5
