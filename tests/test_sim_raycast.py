import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.sim.raycast import cast_hits, cast_rays, clearance
from slam_core.sim.world import load_world
from tests import naive_sim

BOX = np.array([[0, 0, 4, 0], [4, 0, 4, 3], [4, 3, 0, 3], [0, 3, 0, 0]], dtype=float)
NO_CIRCLES = np.zeros((0, 3))


def test_hand_computed_distances_in_a_box():
    # robot at (1, 1) facing +x: east wall 3 m, north wall 2 m, west 1 m, south 1 m
    angles = np.array([0.0, np.pi / 2, np.pi, -np.pi / 2])
    r = cast_rays([1.0, 1.0, 0.0], angles, BOX, NO_CIRCLES)
    assert np.allclose(r, [3.0, 2.0, 1.0, 1.0])
    # 45 degrees: the ray meets the north wall (y = 3) at x = 3, distance 2 sqrt(2)
    assert cast_rays([1.0, 1.0, 0.0], [np.pi / 4], BOX, NO_CIRCLES)[0] == pytest.approx(2 * math.sqrt(2))
    # heading is added to the bearings: facing north, bearing 0 hits the north wall
    assert cast_rays([1.0, 1.0, np.pi / 2], [0.0], BOX, NO_CIRCLES)[0] == pytest.approx(2.0)
    # the corner (4, 3) from (1, 0): 3-4-5 triangle
    a = math.atan2(3, 3)
    assert cast_rays([1.0, 0.5, 0.0], [a], BOX, NO_CIRCLES)[0] == pytest.approx(2.5 * math.sqrt(2))


def test_hand_computed_circle():
    circle = np.array([[3.0, 0.0, 0.5]])
    assert cast_rays([0, 0, 0], [0.0], np.zeros((0, 4)), circle)[0] == pytest.approx(2.5)
    # tangent-ish ray above misses; a ray at the angle of the tangent point grazes at sqrt(9 - 0.25)
    tangent = math.asin(0.5 / 3.0)
    assert cast_rays([0, 0, 0], [tangent - 1e-9], np.zeros((0, 4)), circle)[0] == pytest.approx(
        math.sqrt(9 - 0.25), abs=1e-3)
    assert math.isinf(cast_rays([0, 0, 0], [tangent + 1e-6], np.zeros((0, 4)), circle)[0])
    # behind the robot: no hit
    assert math.isinf(cast_rays([0, 0, np.pi], [0.0], np.zeros((0, 4)), circle)[0])
    # inside the circle: distance 0
    assert cast_rays([3.1, 0, 0], [0.0], np.zeros((0, 4)), circle)[0] == 0.0


def test_max_range_and_misses():
    assert math.isinf(cast_rays([1, 1, 0], [0.0], BOX, NO_CIRCLES, max_range=2.5)[0])
    assert cast_rays([1, 1, 0], [0.0], BOX, NO_CIRCLES, max_range=3.5)[0] == pytest.approx(3.0)
    outside = cast_rays([10, 10, 0], [0.0], BOX, NO_CIRCLES)
    assert math.isinf(outside[0])


def test_bad_input_is_explained():
    with pytest.raises(ValueError, match="pose"):
        cast_rays([1, 1], [0.0], BOX, NO_CIRCLES)
    with pytest.raises(ValueError, match="non-finite"):
        cast_rays([1, 1, 0], [0.0], BOX * np.nan, NO_CIRCLES)
    with pytest.raises(ValueError, match="height"):
        cast_hits([1, 1, 0], [0.0], BOX, [1.0], NO_CIRCLES, [], 10.0)


def test_numba_matches_slow_reference_in_the_flat():
    w = load_world("flat")
    rng = np.random.default_rng(3)
    angles = np.linspace(-np.pi, np.pi, 36, endpoint=False)
    for _ in range(3):
        pose = [rng.uniform(0.3, 9.7), rng.uniform(0.3, 7.7), rng.uniform(-np.pi, np.pi)]
        fast = cast_rays(pose, angles, w.segments, w.circles, 20.0)
        slow = naive_sim.cast_rays(pose, angles, w.segments, w.circles, 20.0)
        assert np.allclose(fast, slow, atol=1e-9, equal_nan=False)


coord = st.floats(-5, 5, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(coord, coord, coord, coord), min_size=1, max_size=6),
       st.lists(st.tuples(coord, coord, st.floats(0.01, 1.0)), max_size=3),
       st.tuples(coord, coord, st.floats(-4, 4)))
def test_numba_matches_slow_reference_on_random_geometry(segs, circles, pose):
    segs = np.array(segs, dtype=float).reshape(-1, 4)
    segs = segs[np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]) > 1e-3]
    circles = np.array(circles, dtype=float).reshape(-1, 3)
    angles = np.linspace(-np.pi, np.pi, 24, endpoint=False) + 0.0123
    fast = cast_rays(pose, angles, segs, circles)
    slow = naive_sim.cast_rays(pose, angles, segs, circles)
    finite = np.isfinite(slow)
    assert np.array_equal(finite, np.isfinite(fast))
    assert np.allclose(fast[finite], slow[finite], rtol=1e-7, atol=1e-7)
    assert clearance(pose[0], pose[1], segs, circles) == pytest.approx(
        naive_sim.clearance(pose[0], pose[1], segs, circles), abs=1e-9)


def test_cast_hits_are_sorted_and_the_first_is_the_nearest():
    w = load_world("flat")
    angles = np.linspace(-0.5, 0.5, 40)
    pose = [1.0, 3.75, 0.0]
    t, h, n = cast_hits(pose, angles, w.segments, w.segment_heights, w.circles, w.circle_heights, 30.0, k=5)
    nearest = cast_rays(pose, angles, w.segments, w.circles, 30.0)
    assert np.all(n >= 1) and np.all(n <= 5)
    assert np.allclose(t[:, 0], nearest)
    for i in range(len(angles)):
        assert np.all(np.diff(t[i, :n[i]]) >= 0)
        assert np.all(h[i, :n[i]] > 0)
