"""Segmentation of a large real map: the whole bundled intel log mapped at its own (odometry)
poses, about twice the extent of the SLAM map. Its time is measured in ``benchmarks/rooms.py``
(``benchmarks/RESULTS.md``), not here: a timed test fails on a busy machine."""

from __future__ import annotations

import numpy as np

from slam_core.datasets import BUNDLED
from slam_core.pipelines.odometry_mapping import map_from_odometry
from slam_core.rooms import segment_rooms
from slam_core.rooms.segmentation import NO_ROOM, free_space


def test_intel_is_segmented_into_rooms_of_free_space_the_same_each_time():
    grid = map_from_odometry(BUNDLED["intel"][0]).grid
    assert grid.shape[0] * grid.shape[1] > 896 * 832  # at least the SLAM map's cells
    labels = segment_rooms(grid)
    assert labels.max() >= 5  # 31
    roomed = labels != NO_ROOM
    assert np.all(free_space(grid)[roomed]) and roomed.sum() > 0.9 * free_space(grid).sum()  # 98 %
    np.testing.assert_array_equal(segment_rooms(grid), labels)
