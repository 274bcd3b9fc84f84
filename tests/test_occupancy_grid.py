"""The log-odds grid: world <-> cell transforms, growth, probability and trinary views."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.io.render import map_image
from slam_core.occupancy_grid import (
    FREE_THRESH,
    OCCUPIED_THRESH,
    ROW_BLOCK,
    OccupancyGrid,
    SensorModel,
    logit,
)
from slam_core.scan import Scan


def test_world_to_cell_with_resolution_and_origin():
    g = OccupancyGrid(0.25, origin=(-2.0, 3.0), shape=(10, 10))
    assert g.world_to_cell([-2.0, 3.0]).tolist() == [0, 0]
    assert g.world_to_cell([-1.76, 3.24]).tolist() == [0, 0]
    assert g.world_to_cell([-1.75, 3.25]).tolist() == [1, 1]          # on a border: the next cell
    assert g.world_to_cell([-2.01, 2.99]).tolist() == [-1, -1]
    assert g.world_to_cell([[0.0, 4.0], [0.3, 3.0]]).tolist() == [[8, 4], [9, 0]]
    assert g.cell_to_world([0, 0]).tolist() == [-1.875, 3.125]
    assert g.cell_to_world([[8, 4]]).tolist() == [[0.125, 4.125]]
    assert g.extent() == (-2.0, 3.0, 0.5, 5.5)
    assert g.contains_cell(9, 9) and not g.contains_cell(10, 0) and not g.contains_cell(0, -1)


@settings(deadline=None)  # timing is for benchmarks/, not tests
@given(st.floats(0.01, 2.0), st.floats(-100, 100), st.floats(-100, 100),
       st.integers(-500, 500), st.integers(-500, 500))
def test_cell_centres_round_trip(res, ox, oy, ix, iy):
    g = OccupancyGrid(res, origin=(ox, oy))
    assert g.world_to_cell(g.cell_to_world([ix, iy])).tolist() == [ix, iy]


def test_data_is_row_major_with_row_zero_at_the_bottom():
    g = OccupancyGrid(1.0, origin=(0.0, 0.0), shape=(8, 8))
    g.integrate(Scan([math.pi / 2], [5.0], 0.1, 80.0), (0.5, 0.5, 0.0))   # beam straight up (+y)
    assert g.data[5, 0] > 0            # data[iy, ix]: the echo is high in y
    assert (g.data[:5, 0] < 0).all()
    assert not g.data[:, 1:].any()


def test_invalid_resolution_is_refused():
    with pytest.raises(ValueError, match="resolution"):
        OccupancyGrid(0.0)


@pytest.mark.parametrize("pose", [(math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), (0.0, 0.0)])
def test_bad_pose_is_refused_before_touching_the_grid(pose):
    g = OccupancyGrid(0.1)
    g.integrate(ring_scan(), (0.0, 0.0, 0.0))
    before = g.data.copy()
    with pytest.raises(ValueError, match="three finite numbers"):
        g.integrate(ring_scan(), pose)
    assert np.array_equal(g.data, before)


def snapshot(grid):
    iy, ix = np.nonzero(grid.data)
    return grid.cell_to_world(np.column_stack([ix, iy])), grid.data[iy, ix].copy()


def values_at(grid, world):
    cells = grid.world_to_cell(world)
    return grid.data[cells[:, 1], cells[:, 0]]


def ring_scan(max_range=2.0, n=72):
    angles = np.linspace(-math.pi, math.pi, n, endpoint=False)
    return Scan(angles, np.full(n, max_range - 0.3), 0.1, 30.0)


@pytest.mark.parametrize("far", [(60.0, 0.0), (-60.0, 0.0), (0.0, 60.0), (0.0, -60.0), (-45.0, 45.0)])
def test_growth_keeps_cells_at_their_world_positions(far):
    g = OccupancyGrid(0.1)
    g.integrate(ring_scan(), (0.3, -0.2, 0.4))
    world, values = snapshot(g)
    assert len(values) > 50
    old_origin = g.origin.copy()
    g.integrate(ring_scan(), (far[0], far[1], 0.0))
    assert np.array_equal(values_at(g, world), values)
    xmin, ymin, xmax, ymax = g.extent()
    assert xmin <= far[0] - 1.7 and xmax >= far[0] + 1.7 and ymin <= far[1] - 1.7 and ymax >= far[1] + 1.7
    # The origin moves by whole cells only, so the lattice stays put.
    shift = (old_origin - g.origin) / g.resolution
    assert np.allclose(shift, np.round(shift), atol=1e-6)
    assert (g.data > 0).sum() > 1.5 * (values > 0).sum()     # the far ring landed too


def test_no_fixed_box_a_scan_far_away_still_lands():
    g = OccupancyGrid(0.2)
    g.integrate(ring_scan(), (0.0, 0.0, 0.0))
    g.integrate(ring_scan(), (400.0, -250.0, 0.0))
    _, ymin, xmax, _ = g.extent()
    assert xmax >= 401.7 and ymin <= -251.7
    assert values_at(g, np.array([[400.0 + 1.7 - 0.01, -250.0]]))[0] > 0


def test_first_growth_covers_the_box_on_the_lattice():
    g = OccupancyGrid(0.05)
    g.ensure_contains(-3.21, 1.0, 7.5, 2.0)
    xmin, ymin, xmax, ymax = g.extent()
    assert xmin <= -3.21 and ymin <= 1.0 and xmax > 7.5 and ymax > 2.0
    assert g.data.dtype == np.float32 and not g.data.any()
    ix, iy = g.world_to_cell([7.5, 2.0])
    assert g.contains_cell(ix, iy)


def test_ensure_contains_inside_changes_nothing():
    g = OccupancyGrid(0.1)
    g.ensure_contains(-1, -1, 1, 1)
    shape, origin = g.shape, g.origin.copy()
    g.ensure_contains(-0.5, -0.5, 0.5, 0.5)
    assert g.shape == shape and np.array_equal(g.origin, origin)


def test_growth_for_beams_clipped_to_their_caps():
    model = SensorModel(usable_range=3.0, no_return_range=1.0)
    g = OccupancyGrid(0.1, model=model)
    g.integrate(Scan([0.0, math.pi / 2, math.pi], [50.0, 80.0, float("nan")], 0.1, 80.0), (0.0, 0.0, 0.0))
    xmin, ymin, xmax, ymax = g.extent()
    # A grid of whole chunks around the 3 m cap, not a 50 m one.
    assert xmax - xmin < 20 and ymax - ymin < 20
    assert values_at(g, np.array([[2.95, 0.0]]))[0] < 0
    assert values_at(g, np.array([[0.0, 0.95]]))[0] < 0
    assert values_at(g, np.array([[0.0, 1.15]]))[0] == 0
    assert (g.data <= 0).all()


def test_probability_view():
    g = OccupancyGrid(1.0, shape=(1, 3))
    g.data[0] = [0.0, logit(0.9), logit(0.2)]
    assert np.allclose(g.probability(), [[0.5, 0.9, 0.2]])


def test_trinary_view_uses_map_server_thresholds():
    g = OccupancyGrid(1.0, shape=(1, 7))
    p = np.array([0.5, 0.97, 0.12, 0.66, 0.64, 0.19, 0.2])
    g.data[0] = logit(p)
    assert g.trinary().tolist() == [[-1, 100, 0, 100, -1, 0, -1]]
    assert g.trinary().dtype == np.int8
    assert g.trinary(occupied_thresh=0.9, free_thresh=0.5).tolist() == [[-1, 100, 0, -1, -1, 0, 0]]
    assert (OCCUPIED_THRESH, FREE_THRESH) == (0.65, 0.196)


def test_one_hit_on_an_unknown_cell_is_occupied_and_one_miss_is_not_free():
    # With the default model a single echo is enough to call a cell occupied,
    # while a single pass-through leaves it unknown (p = 0.4).
    g = OccupancyGrid(1.0, shape=(1, 4))
    g.integrate(Scan([0.0], [2.0], 0.1, 80.0), (0.5, 0.5, 0.0))
    assert g.trinary().tolist() == [[-1, -1, 100, -1]]


def test_a_large_grid_converts_a_block_of_rows_at_a_time_to_the_same_result():
    rng = np.random.default_rng(4)
    g = OccupancyGrid(0.05, shape=(2 * ROW_BLOCK + 7, 40))
    g.data[:] = rng.normal(0.0, 3.0, g.shape)
    p = 1.0 - 1.0 / (1.0 + np.exp(g.data.astype(np.float64)))
    np.testing.assert_array_equal(g.probability(), p)
    expected = np.where(p > OCCUPIED_THRESH, 100, np.where(p < FREE_THRESH, 0, -1))
    np.testing.assert_array_equal(g.trinary(), expected)
    np.testing.assert_array_equal(map_image(g), np.flipud((255.0 * (1.0 - p)).round().astype(np.uint8)))
