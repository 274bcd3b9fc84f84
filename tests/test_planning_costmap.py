import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from slam_core.occupancy_grid import OccupancyGrid
from slam_core.planning.costmap import CostmapConfig, build_costmap, costmap_from_trinary

RES = 0.05


def room():
    t = np.zeros((40, 50), np.int8)
    t[0, :] = t[-1, :] = t[:, 0] = t[:, -1] = 100
    t[20, 10:30] = 100
    t[30:, 40:] = -1
    return t


def test_weights_follow_the_inflation_formula():
    cfg = CostmapConfig(robot_radius=0.12, inflation_radius=0.4, cost_scaling=5.0, max_cost=8.0)
    t = room()
    cm = costmap_from_trinary(t, RES, (1.0, 2.0), cfg)
    d = distance_transform_edt(t != 100) * RES
    known = t != -1
    expect = np.where(d <= 0.12, np.inf, np.where(d > 0.4, 1.0, 1.0 + 8.0 * np.exp(-5.0 * (d - 0.12))))
    expect = np.where(known, expect, expect + cfg.unknown_cost)
    np.testing.assert_allclose(cm.weights, expect, rtol=1e-7)
    assert np.array_equal(cm.lethal, d <= 0.12)
    # Weights fall monotonically with clearance, from 1 + max_cost down to 1.
    free = known & np.isfinite(cm.weights)
    order = np.argsort(d[free])
    assert np.all(np.diff(cm.weights[free][order]) <= 0)
    assert cm.weights[free].max() <= 1 + 8.0 and cm.weights[free].min() == 1.0


def test_unknown_forbidden_or_priced():
    t = room()
    forbid = costmap_from_trinary(t, RES, config=CostmapConfig(unknown_cost=None))
    priced = costmap_from_trinary(t, RES, config=CostmapConfig(unknown_cost=3.0))
    inner = (slice(32, 38), slice(42, 48))
    assert np.all(np.isinf(forbid.weights[inner])) and np.all(forbid.unknown[inner])
    assert not forbid.lethal[inner].any()
    assert np.all(priced.weights[inner] >= 4.0) and np.all(np.isfinite(priced.weights[inner]))


def test_build_from_occupancy_grid_uses_trinary():
    grid = OccupancyGrid(resolution=RES, origin=(-1.0, 0.5), shape=(40, 50))
    t = room()
    grid.data[t == 100] = 3.0
    grid.data[t == 0] = -3.0
    cm = build_costmap(grid)
    ref = costmap_from_trinary(t, RES, (-1.0, 0.5))
    np.testing.assert_array_equal(cm.weights, ref.weights)
    np.testing.assert_array_equal(cm.origin, grid.origin)


@pytest.mark.parametrize("kwargs, msg", [
    ({"robot_radius": -0.1}, "robot_radius"),
    ({"robot_radius": 0.5, "inflation_radius": 0.3}, "inflation_radius"),
    ({"unknown_cost": -1.0}, "unknown_cost"),
])
def test_bad_config_is_explained(kwargs, msg):
    with pytest.raises(ValueError, match=msg):
        CostmapConfig(**kwargs)
