"""Hit sums rendered in one vectorised pass equal those the filter's own kernels accumulate."""

from __future__ import annotations

import numpy as np
import pytest

from slam_core.occupancy_grid import SensorModel
from slam_core.rbpf.hit_render import SparseHits, add_hit_sums, sparse_hit_sums
from slam_core.rbpf.tiled_map import HIT_N, TiledMaps
from slam_core.scan import Scan
from tests.synthetic_room import cast


def scans_with_every_kind_of_beam(rng, poses) -> list[Scan]:
    """Scans of the room (different beam counts), with beams below range_min, NaN, no return and
    echoes beyond the usable range."""
    scans = []
    for k, pose in enumerate(poses):
        n = 120 + 7 * k
        angles = np.sort(rng.uniform(-np.pi, np.pi, n))
        ranges = cast(pose, angles) + rng.normal(0.0, 0.01, n)
        kinds = rng.random(n)
        ranges[kinds < 0.05] = 0.02  # below range_min
        ranges[(kinds >= 0.05) & (kinds < 0.1)] = np.nan
        ranges[(kinds >= 0.1) & (kinds < 0.15)] = np.inf  # no return
        ranges[(kinds >= 0.15) & (kinds < 0.2)] = 5.5  # beyond the usable range
        scans.append(Scan(angles, ranges, 0.05, 30.0))
    return scans


MODEL = SensorModel(usable_range=5.0)


def filter_mapped(seed: int, n: int):
    """``n`` random poses in the room, their scans, and the filter's own map of them with its hit sums."""
    rng = np.random.default_rng(seed)
    poses = np.column_stack([rng.uniform(-2, 3, n), rng.uniform(-1.5, 2.5, n), rng.uniform(-3, 3, n)])
    scans = scans_with_every_kind_of_beam(rng, poses)
    maps = TiledMaps(1, 0.05, MODEL)
    for pose, scan in zip(poses, scans, strict=True):
        maps.integrate(pose[None], scan)
    return poses, scans, maps.to_grid(0), maps.hit_sums(0)


def test_rendered_hit_sums_equal_the_filter_maps_own():
    poses, scans, grid, expected = filter_mapped(7, 25)
    assert expected[..., HIT_N].sum() > 1500  # many echoes, some cells hit many times
    hits = np.zeros_like(expected)
    outside = add_hit_sums(hits, grid.origin, grid.resolution, poses, scans, MODEL)
    assert outside == 0
    assert np.array_equal(hits[..., HIT_N], expected[..., HIT_N])
    np.testing.assert_allclose(hits, expected, atol=2e-5)
    # Drawn in two parts, on a larger grid: the same sums, shifted by the grid's offset.
    wide = np.zeros((expected.shape[0] + 10, expected.shape[1] + 6, 3), np.float32)
    origin = grid.origin - np.array([4, 7]) * grid.resolution
    for part in (slice(0, 11), slice(11, None)):
        add_hit_sums(wide, origin, grid.resolution, poses[part], scans[part], MODEL)
    np.testing.assert_allclose(wide[7:7 + expected.shape[0], 4:4 + expected.shape[1]], expected, atol=2e-5)
    assert wide[..., HIT_N].sum() == expected[..., HIT_N].sum()


def test_echoes_outside_the_grid_are_counted_not_added():
    scan = Scan(np.array([0.0, np.pi / 2, np.pi]), np.array([1.0, 1.0, 1.0]), 0.05, 30.0)
    hits = np.zeros((10, 30, 3), np.float32)  # x from 0 to 1.5 m, y from 0 to 0.5 m
    outside = add_hit_sums(hits, (0.0, 0.0), 0.05, np.array([[0.23, 0.26, 0.0]]), [scan], MODEL)
    assert outside == 2  # up (y = 1.26) and back (x = -0.77)
    [(iy, ix)] = np.argwhere(hits[..., HIT_N] > 0)
    assert (iy, ix) == (5, 24)
    np.testing.assert_allclose(hits[iy, ix], (1.23 - 24 * 0.05, 0.26 - 5 * 0.05, 1.0), atol=1e-6)


def test_sparse_hit_sums_equal_the_filter_maps_own_and_move_onto_larger_grids():
    poses, scans, grid, expected = filter_mapped(9, 20)
    first, second = (sparse_hit_sums(grid, poses[part], scans[part], MODEL)
                     for part in (slice(0, 9), slice(9, None)))
    both = first.plus(second)
    assert len(both.cells) < len(first.cells) + len(second.cells)  # cells hit in both parts, summed
    assert expected[..., HIT_N].sum() > 1000
    assert np.array_equal(both.dense()[..., HIT_N], expected[..., HIT_N])
    np.testing.assert_allclose(both.dense(), expected, atol=2e-5)
    assert np.array_equal(SparseHits.from_dense(expected, grid.origin).dense(), expected)
    ny, nx = grid.shape
    wide = both.on(grid.origin - np.array([4, 7]) * grid.resolution, (ny + 10, nx + 6), grid.resolution)
    np.testing.assert_array_equal(wide.dense()[7:7 + ny, 4:4 + nx], both.dense())
    assert wide.dense()[..., HIT_N].sum() == expected[..., HIT_N].sum()
    with pytest.raises(ValueError, match="do not fit"):
        both.on(grid.origin + grid.resolution, grid.shape, grid.resolution)
    with pytest.raises(ValueError, match="different grids"):
        both.plus(wide)
    with pytest.raises(ValueError, match="outside the map"):
        SparseHits(grid.origin, grid.shape, np.array([ny * nx]), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="do not pair"):
        SparseHits(grid.origin, grid.shape, np.array([0, 1]), np.zeros((1, 3)))
