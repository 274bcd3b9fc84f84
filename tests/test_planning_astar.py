import math
import threading
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.planning.astar import CANCEL_POLL, astar, new_cancel_flag
from slam_core.planning.costmap import Costmap
from tests.naive_planning import dijkstra_cost, path_cost


@st.composite
def weight_grids(draw):
    ny = draw(st.integers(2, 14))
    nx = draw(st.integers(2, 14))
    seed = draw(st.integers(0, 2**32 - 1))
    p_wall = draw(st.sampled_from([0.0, 0.15, 0.3, 0.45]))
    rng = np.random.default_rng(seed)
    weights = 1.0 + np.round(rng.exponential(2.0, (ny, nx)), 2)
    weights[rng.random((ny, nx)) < p_wall] = np.inf
    start = (draw(st.integers(0, nx - 1)), draw(st.integers(0, ny - 1)))
    goal = (draw(st.integers(0, nx - 1)), draw(st.integers(0, ny - 1)))
    return weights, start, goal


@settings(max_examples=200, deadline=None)
@given(weight_grids(), st.sampled_from([(math.sqrt(2), False), (1.0, True), (math.sqrt(2), True)]))
def test_cost_equals_dijkstra_oracle(case, rules):
    weights, start, goal = case
    diagonal_step, corner_cutting = rules
    costmap = Costmap(weights, 0.05)
    weights = costmap.weights.astype(np.float64)  # the float32 weights the search really uses
    result = astar(costmap, start, goal, diagonal_step=diagonal_step, corner_cutting=corner_cutting)
    expected = dijkstra_cost(weights, start, goal, diagonal_step, corner_cutting)
    if math.isinf(expected):
        assert not result.found and math.isinf(result.cost) and len(result.cells) == 0
        return
    assert result.found
    assert result.cost == pytest.approx(expected, rel=1e-7)
    cells = result.cells
    assert tuple(cells[0]) == start and tuple(cells[-1]) == goal
    # The path is legal (no impassable cell, no corner cut) and really costs what is reported.
    assert path_cost(weights, cells, diagonal_step, corner_cutting) == pytest.approx(result.cost, rel=1e-12)
    assert np.all(np.isfinite(weights[cells[1:, 1], cells[1:, 0]]))


def test_no_corner_cutting_between_diagonal_walls():
    weights = np.ones((2, 2))
    weights[0, 1] = weights[1, 0] = np.inf
    assert not astar(Costmap(weights, 1.0), (0, 0), (1, 1)).found
    cut = astar(Costmap(weights, 1.0), (0, 0), (1, 1), corner_cutting=True)
    assert cut.cost == pytest.approx(math.sqrt(2))


def test_reachable_region_after_exhausted_search():
    weights = np.ones((5, 7))
    weights[:, 3] = np.inf
    result = astar(Costmap(weights, 1.0), (0, 0), (6, 4))
    assert not result.found
    reach = result.reachable()
    assert reach[:, :3].all() and not reach[:, 3:].any()


def test_rejects_cells_outside():
    with pytest.raises(ValueError, match=r"goal cell .* outside the 4x3"):
        astar(Costmap(np.ones((3, 4)), 1.0), (0, 0), (4, 0))


def test_cancel_before_start_stops_at_first_poll():
    flag = new_cancel_flag()
    flag[0] = 1
    weights = np.ones((200, 200))
    weights[:, 150] = np.inf
    result = astar(Costmap(weights, 1.0), (0, 0), (199, 199), cancel=flag)
    assert result.cancelled and not result.found and len(result.cells) == 0
    assert result.expansions == CANCEL_POLL  # stopped at the first poll


def test_cancel_from_another_thread():
    weights = np.ones((1500, 1500))
    weights[:, 1400] = np.inf  # the goal is walled off: the search would scan ~2M cells
    costmap = Costmap(weights, 0.05)
    astar(Costmap(np.ones((3, 3)), 1.0), (0, 0), (2, 2))  # load the compiled kernel first
    flag = new_cancel_flag()
    out = {}
    worker = threading.Thread(target=lambda: out.update(r=astar(costmap, (0, 0), (1499, 1499), cancel=flag)))
    worker.start()
    time.sleep(0.05)
    flag[0] = 1
    worker.join(timeout=30)
    assert not worker.is_alive()
    assert out["r"].cancelled
    assert out["r"].expansions < 1400 * 1500
