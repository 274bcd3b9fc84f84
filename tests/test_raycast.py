"""Ray traversal and the inverse sensor model: tiny hand-computed worlds, then random scans."""

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from slam_core.occupancy_grid import OccupancyGrid, SensorModel
from slam_core.raycast import beam_endpoint, integrate_scan_dense, ray_buffer_size, trace_ray
from slam_core.scan import Scan
from tests import naive

MODEL = SensorModel()
F32 = np.float32


def trace(x0, y0, x1, y1):
    out = np.empty((int(abs(x1 - x0) + abs(y1 - y0)) + 8, 2), np.int64)
    n = trace_ray(float(x0), float(y0), float(x1), float(y1), out)
    return [tuple(int(v) for v in c) for c in out[:n]]


def integrate(grid_shape, pose, angles, ranges, model=MODEL, range_min=0.1, range_max=80.0,
              resolution=1.0, origin=(0.0, 0.0), data=None):
    data = np.zeros(grid_shape, np.float32) if data is None else data
    integrate_scan_dense(data, origin[0], origin[1], resolution, np.asarray(pose, float),
                         np.asarray(angles, float), np.asarray(ranges, float), range_min, range_max,
                         model.usable_range, model.usable_range, model.no_return_range, model.echo_margin,
                         model.l_free, model.l_occ, model.l_min, model.l_max)
    return data


def expected_grid(shape, free=(), occupied=()):
    g = np.zeros(shape, np.float32)
    for ix, iy in free:
        g[iy, ix] = F32(MODEL.l_free)
    for ix, iy in occupied:
        g[iy, ix] = F32(MODEL.l_occ)
    return g


# --- trace_ray -----------------------------------------------------------------------------

@pytest.mark.parametrize("end, cells", [
    ((8.5, 5.5), [(5, 5), (6, 5), (7, 5), (8, 5)]),      # +x
    ((2.5, 5.5), [(5, 5), (4, 5), (3, 5), (2, 5)]),      # -x
    ((5.5, 8.5), [(5, 5), (5, 6), (5, 7), (5, 8)]),      # +y
    ((5.5, 2.5), [(5, 5), (5, 4), (5, 3), (5, 2)]),      # -y
    ((5.9, 5.1), [(5, 5)]),                              # inside one cell
])
def test_axis_aligned_beams(end, cells):
    assert trace(5.5, 5.5, *end) == cells
    assert naive.ray_cells(5.5, 5.5, *end) == cells


def test_diagonal_beam_off_the_corners():
    # x crosses 1 at t=0.4, y crosses 1 at t=0.4167, x crosses 2 at t=0.9.
    cells = [(0, 0), (1, 0), (1, 1), (2, 1)]
    assert trace(0.2, 0.5, 2.2, 1.7) == cells
    assert naive.ray_cells(0.2, 0.5, 2.2, 1.7) == cells
    assert trace(2.2, 1.7, 0.2, 0.5) == cells[::-1]


def test_diagonal_beam_through_corners_steps_y_first():
    # Through the corners (1, 1) and (2, 2): 4-connected, y before x at each corner.
    assert trace(0.5, 0.5, 2.5, 2.5) == [(0, 0), (0, 1), (1, 1), (1, 2), (2, 2)]
    assert trace(2.5, 2.5, 0.5, 0.5) == [(2, 2), (2, 1), (1, 1), (1, 0), (0, 0)]
    # The reference keeps only cells with positive length inside.
    assert naive.ray_cells(0.5, 0.5, 2.5, 2.5) == [(0, 0), (1, 1), (2, 2)]


@pytest.mark.parametrize("x0, y0, x1, y1", [
    (0.3, 0.7, 6.9, 3.2), (6.1, 0.4, 0.2, 5.5), (-3.3, -1.2, 2.7, -7.9), (1.25, 9.75, 1.26, -4.1),
])
def test_reversed_beam_visits_same_cells_backwards(x0, y0, x1, y1):
    assert trace(x1, y1, x0, y0) == trace(x0, y0, x1, y1)[::-1]


def test_endpoint_exactly_on_a_border_belongs_to_the_cell_right_or_above():
    assert trace(0.5, 0.5, 3.0, 0.5) == [(0, 0), (1, 0), (2, 0), (3, 0)]
    assert trace(3.5, 0.5, 1.0, 0.5) == [(3, 0), (2, 0), (1, 0)]
    assert trace(0.5, 0.5, 0.5, 2.0) == [(0, 0), (0, 1), (0, 2)]
    # Starting on a border and moving left: the start cell, then the cells crossed.
    assert trace(3.0, 0.5, 0.5, 0.5) == [(3, 0), (2, 0), (1, 0), (0, 0)]
    for seg in [(0.5, 0.5, 3.0, 0.5), (3.5, 0.5, 1.0, 0.5), (3.0, 0.5, 0.5, 0.5)]:
        assert trace(*seg) == naive.ray_cells(*seg)


def test_ray_along_a_grid_line_stays_in_the_upper_row():
    assert trace(0.5, 2.0, 3.5, 2.0) == [(0, 2), (1, 2), (2, 2), (3, 2)]


def touches_lattice_point(x0, y0, x1, y1):
    """Exact (rational) test whether the segment meets a cell corner."""
    fx0, fy0, fx1, fy1 = (Fraction(v) for v in (x0, y0, x1, y1))
    dx, dy = fx1 - fx0, fy1 - fy0
    if dx == 0:
        return fx0.denominator == 1
    for i in range(math.floor(min(x0, x1)), math.ceil(max(x0, x1)) + 1):
        t = (i - fx0) / dx
        if 0 <= t <= 1 and (fy0 + t * dy).denominator == 1:
            return True
    return False


coords = st.floats(-12.0, 12.0, allow_nan=False, allow_infinity=False)


@settings(deadline=None, max_examples=300)
@given(coords, coords, coords, coords)
@example(0.0, 0.0, 4.0, 11.999999999999998)  # grazes the corner (1, 3): the reference's sliver cell (0, 3)
def test_trace_is_a_4_connected_superset_of_the_reference(x0, y0, x1, y1):
    fast = trace(x0, y0, x1, y1)
    ref = naive.ray_cells(x0, y0, x1, y1)
    start, end = (math.floor(x0), math.floor(y0)), (math.floor(x1), math.floor(y1))
    assert fast[0] == start and fast[-1] == end
    assert len(fast) == abs(end[0] - start[0]) + abs(end[1] - start[1]) + 1
    assert len(fast) <= ray_buffer_size(math.hypot(x1 - x0, y1 - y0), 1.0)   # the kernel's buffer
    for (ax, ay), (bx, by) in itertools.pairwise(fast):
        assert abs(bx - ax) + abs(by - ay) == 1
    # Every reference cell, in order; a cell the segment only grazes within rounding of one of
    # its corners (the reference gives it a sliver of length ~1e-16) may be left out.
    cells = set(fast)
    kept = [c for c in ref if c in cells or _distance_to_cell_corners(x0, y0, x1, y1, c) >= 1e-9]
    it = iter(fast)
    assert all(c in it for c in kept), "reference cells missing or out of order"
    if not touches_lattice_point(x0, y0, x1, y1):
        # Away from exact corners the two agree, up to rounding right next to a corner.
        extra = set(fast) - set(ref)
        for cx, cy in extra:
            near = min(_distance_to_corner(x0, y0, x1, y1, cx + i, cy + j) for i in (0, 1) for j in (0, 1))
            assert near < 1e-9


def _nearest_corner(x0, y0, x1, y1):
    """Distance from the segment to the nearest cell corner."""
    xs = range(math.floor(min(x0, x1)), math.floor(max(x0, x1)) + 2)
    ys = range(math.floor(min(y0, y1)), math.floor(max(y0, y1)) + 2)
    return min(_distance_to_corner(x0, y0, x1, y1, i, j) for i in xs for j in ys)


def _distance_to_cell_corners(x0, y0, x1, y1, cell):
    cx, cy = cell
    return min(_distance_to_corner(x0, y0, x1, y1, cx + i, cy + j) for i in (0, 1) for j in (0, 1))


def _distance_to_corner(x0, y0, x1, y1, px, py):
    dx, dy = x1 - x0, y1 - y0
    d2 = dx * dx + dy * dy
    t = 0.0 if d2 == 0 else min(1.0, max(0.0, ((px - x0) * dx + (py - y0) * dy) / d2))
    return math.hypot(x0 + t * dx - px, y0 + t * dy - py)


@settings(deadline=None, max_examples=200)
@given(coords, coords, coords, coords)
def test_reversed_trace_is_the_forward_trace_backwards(x0, y0, x1, y1):
    assume(_nearest_corner(x0, y0, x1, y1) > 1e-9)
    assume(x0 != math.floor(x0) and y0 != math.floor(y0) and x1 != math.floor(x1) and y1 != math.floor(y1))
    assert trace(x1, y1, x0, y0) == trace(x0, y0, x1, y1)[::-1]


# --- beam_endpoint -------------------------------------------------------------------------

@pytest.mark.parametrize("rng, use, hit, reach", [
    (3.0, True, True, 3.0),
    (0.05, False, False, 0.0),     # below range_min
    (0.0, False, False, 0.0),
    (float("nan"), False, False, 0.0),
    (25.0, True, False, 20.0),     # beyond usable_range: clears to it
    (80.0, True, False, 4.0),      # no return: clears to no_return_range
    (float("inf"), True, False, 4.0),
])
def test_beam_endpoint_classification(rng, use, hit, reach):
    u, h, ex, ey = beam_endpoint(1.0, 2.0, 0.0, math.pi / 2, rng, 0.1, 80.0, 20.0, 4.0)
    assert (u, h) == (use, hit)
    if use:
        assert ex == pytest.approx(1.0, abs=1e-12)
        assert ey == pytest.approx(2.0 + reach)


# --- integrate_scan_dense: hand-computed log-odds -----------------------------------------

def test_single_beam_frees_the_path_and_marks_the_echo():
    g = integrate((3, 6), (0.5, 0.5, 0.0), [0.0], [3.0])
    assert np.array_equal(g, expected_grid((3, 6), free=[(0, 0), (1, 0), (2, 0)], occupied=[(3, 0)]))


@pytest.mark.parametrize("heading, free, occ", [
    (0.0, [(3, 3), (4, 3)], (5, 3)),
    (math.pi / 2, [(3, 3), (3, 4)], (3, 5)),
    (math.pi, [(3, 3), (2, 3)], (1, 3)),
    (-math.pi / 2, [(3, 3), (3, 2)], (3, 1)),
])
def test_beams_in_all_four_directions(heading, free, occ):
    # The heading is the robot's; the beam points straight ahead.
    g = integrate((7, 7), (3.5, 3.5, heading), [0.0], [2.0])
    assert np.array_equal(g, expected_grid((7, 7), free=free, occupied=[occ]))


def test_scan_angles_add_to_the_heading():
    g = integrate((7, 7), (3.5, 3.5, math.pi / 2), [-math.pi / 2, math.pi / 2], [2.0, 2.0])
    assert g[3, 5] == F32(MODEL.l_occ) and g[3, 1] == F32(MODEL.l_occ)
    # The robot's own cell is crossed by both beams.
    assert g[3, 3] == F32(F32(MODEL.l_free) + MODEL.l_free)


def test_echo_on_a_cell_border_marks_the_cell_beyond_it():
    g = integrate((1, 5), (0.5, 0.5, 0.0), [0.0], [2.5])
    assert np.array_equal(g, expected_grid((1, 5), free=[(0, 0), (1, 0), (2, 0)], occupied=[(3, 0)]))


def test_no_return_beam_clears_up_to_the_cap_and_marks_nothing():
    model = SensorModel(no_return_range=3.0)
    for rng in (80.0, 81.83, float("inf")):
        g = integrate((1, 8), (0.5, 0.5, 0.0), [0.0], [rng], model=model)
        assert np.array_equal(g, expected_grid((1, 8), free=[(i, 0) for i in range(4)]))
        assert (g <= 0).all()


def test_echo_beyond_usable_range_only_clears():
    model = SensorModel(usable_range=3.0, no_return_range=2.0)
    g = integrate((1, 8), (0.5, 0.5, 0.0), [0.0], [5.0], model=model)
    assert np.array_equal(g, expected_grid((1, 8), free=[(i, 0) for i in range(4)]))


@pytest.mark.parametrize("rng", [0.05, 0.0, -1.0, float("nan")])
def test_beams_that_are_not_measurements_change_nothing(rng):
    g = integrate((1, 8), (0.5, 0.5, 0.0), [0.0], [rng], range_min=0.1)
    assert not g.any()


def test_repeated_updates_sum_and_clamp():
    g = np.zeros((1, 4), np.float32)
    free_expect, occ_expect = F32(0.0), F32(0.0)
    for _ in range(8):
        integrate((1, 4), (0.5, 0.5, 0.0), [0.0], [2.0], data=g)
        free_expect = F32(min(max(float(free_expect) + MODEL.l_free, MODEL.l_min), MODEL.l_max))
        occ_expect = F32(min(max(float(occ_expect) + MODEL.l_occ, MODEL.l_min), MODEL.l_max))
        assert g[0, 0] == free_expect and g[0, 1] == free_expect and g[0, 2] == occ_expect
    assert g[0, 0] == F32(MODEL.l_min)   # 8 * -0.405 < -1.99
    assert g[0, 2] == F32(MODEL.l_max)   # 8 * 0.847 > 3.48
    assert g[0, 3] == 0.0
    # A cleared cell is not stuck: one hit moves it up by exactly l_occ.
    integrate((1, 4), (0.5, 0.5, 0.0), [0.0], [0.3], data=g)
    assert g[0, 0] == F32(float(F32(MODEL.l_min)) + MODEL.l_occ)


def test_log_odds_constants_are_the_named_probabilities():
    m = SensorModel(p_hit=0.7, p_miss=0.4, p_min=0.12, p_max=0.97)
    assert m.l_occ == pytest.approx(math.log(0.7 / 0.3))
    assert m.l_free == pytest.approx(math.log(0.4 / 0.6))
    assert m.l_min == pytest.approx(math.log(0.12 / 0.88))
    assert m.l_max == pytest.approx(math.log(0.97 / 0.03))


def test_cells_outside_the_grid_are_skipped_not_wrapped():
    g = integrate((2, 2), (0.5, 0.5, 0.0), [0.0, math.pi], [5.0, 5.0])
    assert g[0, 0] == F32(F32(MODEL.l_free) + MODEL.l_free)
    assert g[0, 1] == F32(MODEL.l_free)
    assert not g[1].any()


# --- random scans against the reference ----------------------------------------------------

def random_scan(rng, n, range_max=8.0):
    angles = np.sort(rng.uniform(-math.pi, math.pi, n))
    ranges = rng.uniform(0.0, 7.5, n)
    kind = rng.integers(0, 10, n)
    ranges[kind == 0] = range_max              # no return
    ranges[kind == 1] = np.inf
    ranges[kind == 2] = np.nan
    ranges[kind == 3] = rng.uniform(0.0, 0.2, (kind == 3).sum())   # some below range_min
    return Scan(angles, ranges, 0.15, range_max)


def test_random_scans_match_the_reference_exactly():
    rng = np.random.default_rng(20260522)
    model = SensorModel(usable_range=5.5, no_return_range=3.0, p_hit=0.8, p_miss=0.35)
    grid = OccupancyGrid(0.25, model=model)
    for _ in range(12):
        scan = random_scan(rng, 90)
        pose = np.array([rng.uniform(-6, 6), rng.uniform(-6, 6), rng.uniform(-math.pi, math.pi)])
        naive.check_integrate(grid, scan, pose)
    assert (grid.data > 0).sum() > 100 and (grid.data < 0).sum() > 100


# --- the scan type ---------------------------------------------------------------------------

def test_scan_validates_and_classifies():
    scan = Scan([0.0, 0.1, 0.2, 0.3, 0.4, 0.5], [1.0, 0.05, 80.0, np.inf, np.nan, 0.0], 0.1, 80.0)
    assert scan.angles.dtype == np.float64 and len(scan) == 6
    assert scan.valid.tolist() == [True, False, False, False, False, False]
    assert np.allclose(scan.points(), [[1.0, 0.0]])
    with pytest.raises(ValueError, match="must be equal 1-D"):
        Scan([0.0, 1.0], [1.0], 0.1, 10.0)
    with pytest.raises(ValueError, match="range_min < range_max"):
        Scan([0.0], [1.0], 5.0, 5.0)
