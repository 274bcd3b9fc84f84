import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.planning.astar import astar
from slam_core.planning.costmap import Costmap
from slam_core.planning.line import supercover_cells
from slam_core.planning.smoothing import polyline_cost, resample, shortcut_path
from tests.naive_planning import supercover_reference

coords = st.integers(-12, 12)


@settings(max_examples=300, deadline=None)
@given(coords, coords, coords, coords)
def test_supercover_equals_exact_clipping(x0, y0, x1, y1):
    cells = supercover_cells(x0, y0, x1, y1)
    assert {tuple(c) for c in cells} == supercover_reference(x0, y0, x1, y1)
    assert len({tuple(c) for c in cells}) == len(cells)
    assert tuple(cells[0]) == (x0, y0) and tuple(cells[-1]) == (x1, y1)


@st.composite
def maps_with_paths(draw):
    ny = draw(st.integers(3, 30))
    nx = draw(st.integers(3, 30))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    weights = 1.0 + rng.exponential(1.0, (ny, nx)) * (rng.random((ny, nx)) < 0.3)
    weights[rng.random((ny, nx)) < draw(st.sampled_from([0.0, 0.1, 0.25]))] = np.inf
    free = np.argwhere(np.isfinite(weights))
    if len(free) < 2:
        weights[0, 0] = weights[-1, -1] = 1.0
        free = np.array([[0, 0], [ny - 1, nx - 1]])
    a, b = free[rng.choice(len(free), 2, replace=False)]
    return weights, (a[1], a[0]), (b[1], b[0])


@settings(max_examples=150, deadline=None)
@given(maps_with_paths(), st.sampled_from([0.0, 0.01, 0.2]))
def test_shortcuts_never_cross_obstacles_nor_cost_more(case, tolerance):
    weights, start, goal = case
    result = astar(Costmap(weights, 1.0), start, goal)
    if not result.found:
        return
    smooth = shortcut_path(weights, result.cells, tolerance)
    assert tuple(smooth[0]) == start and tuple(smooth[-1]) == goal
    # The kept vertices are a subsequence of the A* path.
    index = {tuple(c): i for i, c in enumerate(result.cells)}
    assert np.all(np.diff([index[tuple(c)] for c in smooth]) > 0)
    for a, b in itertools.pairwise(smooth):
        for ix, iy in supercover_reference(*a, *b):
            assert np.isfinite(weights[iy, ix]), f"segment {a}->{b} crosses impassable cell {(ix, iy)}"
    assert polyline_cost(weights, smooth) <= (1 + tolerance) * polyline_cost(weights, result.cells) + 1e-9


def test_open_space_path_becomes_one_segment():
    weights = np.ones((20, 30))
    cells = astar(Costmap(weights, 1.0), (0, 0), (29, 7)).cells
    assert len(cells) > 2
    np.testing.assert_array_equal(shortcut_path(weights, cells), [[0, 0], [29, 7]])


def test_expensive_shortcut_is_refused():
    # A straight line through a costly band is longer in cost than the detour A* took.
    weights = np.ones((9, 9))
    weights[4, 1:8] = 50.0
    weights[4, 0] = weights[4, 8] = 1.0
    cells = astar(Costmap(weights, 1.0), (4, 0), (4, 8)).cells
    smooth = shortcut_path(weights, cells, 0.0)
    assert polyline_cost(weights, smooth) <= polyline_cost(weights, cells) + 1e-9
    assert len(smooth) > 2


def test_resample_keeps_vertices_and_spacing():
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.1], [1.0, 2.0]])
    out = resample(pts, 0.25)
    gaps = np.linalg.norm(np.diff(out, axis=0), axis=1)
    assert gaps.max() <= 0.25 + 1e-12 and gaps.min() > 0
    for p in pts:
        assert np.min(np.linalg.norm(out - p, axis=1)) < 1e-12
    with pytest.raises(ValueError, match="spacing"):
        resample(pts, 0.0)
