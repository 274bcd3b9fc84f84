"""The scan matcher on a hand-made room: a known shift comes back; its pieces on tiny cases."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.geometry import relative
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.rbpf.config import MatcherParams
from slam_core.rbpf.proposal import match_starts
from slam_core.rbpf.scan_matcher import (
    FREE_STEP,
    P_DMAX2,
    P_FREE,
    P_HUBER,
    P_LSIGMA2,
    P_OCCUPIED,
    P_PRIOR_TH,
    P_PRIOR_XY,
    _solve3,
    beam_rows,
    local_line,
    logodds_at,
    match,
    pose_likelihood,
    surface_point,
)
from slam_core.rbpf.tiled_map import TILE, TiledMaps
from slam_core.scan import Scan
from tests.synthetic_room import room_scan

TRUE_POSE = np.array([0.3, 0.2, 0.1])


@pytest.fixture(scope="module")
def room_map():
    maps = TiledMaps(1, 0.05)
    rng = np.random.default_rng(0)
    for _ in range(8):  # several looks from around the true pose make a confident map
        pose = TRUE_POSE + rng.normal(0, [0.3, 0.3, 0.2])
        maps.integrate(pose[None, :], room_scan(pose, 360))
    return maps


def beams_of(scan):
    v = scan.valid
    a, r = scan.angles[v], scan.ranges[v]
    return np.ascontiguousarray(np.column_stack([r * np.cos(a), r * np.sin(a), np.cos(a), np.sin(a)]))


def args_of(maps):
    return (maps.tables[0], maps.lo, maps.hits, maps.origin[0], maps.origin[1], maps.resolution)


@pytest.mark.parametrize("shift", [(0.04, -0.03, 0.02), (-0.06, 0.05, -0.04), (0.0, 0.0, 0.05),
                                   (0.08, 0.0, 0.0)])
def test_a_known_shift_is_recovered(room_map, shift):
    params = MatcherParams().packed()
    beams = beams_of(room_scan(TRUE_POSE, 180))
    start = TRUE_POSE + np.array(shift)
    x, y, th, info, matched, _, _ = match(*args_of(room_map), *start, beams, params, 15, 5)
    err = relative(TRUE_POSE, [x, y, th])
    assert np.hypot(err[0], err[1]) < 0.003
    assert abs(err[2]) < np.radians(0.1)
    assert matched >= 0.95 * len(beams)
    assert np.all(np.linalg.eigvalsh(info) > 0)  # a closed room pins every direction
    start_ll, _ = pose_likelihood(*args_of(room_map), *start, beams, params)
    end_ll, _ = pose_likelihood(*args_of(room_map), x, y, th, beams, params)
    assert end_ll > start_ll


def test_likelihood_peaks_at_the_true_pose(room_map):
    params = MatcherParams().packed()
    beams = beams_of(room_scan(TRUE_POSE, 180))
    best_ll, matched = pose_likelihood(*args_of(room_map), *TRUE_POSE, beams, params)
    assert matched >= 0.95 * len(beams)
    for d in [(0.03, 0, 0), (0, -0.03, 0), (0, 0, 0.02)]:
        ll, _ = pose_likelihood(*args_of(room_map), *(TRUE_POSE + d), beams, params)
        assert ll < best_ll


def test_beams_into_unknown_space_do_not_match():
    maps = TiledMaps(1, 0.05)
    params = MatcherParams().packed()
    beams = beams_of(room_scan(TRUE_POSE, 90))
    ll, matched = pose_likelihood(*args_of(maps), *TRUE_POSE, beams, params)
    assert matched == 0
    assert ll == pytest.approx(-len(beams) * params[1] / (2 * params[0]))
    _, _, _, info, matched, _, _ = match(*args_of(maps), *TRUE_POSE, beams, params, 5, 2)
    assert matched == 0 and not info.any()


def _map_with_surface_points(points, resolution=0.05):
    """A one-tile map whose occupied cells hold the given surface points (one hit each)."""
    grid = OccupancyGrid(resolution, shape=(TILE, TILE))
    sums = np.zeros((TILE, TILE, 3), np.float32)
    for px, py in points:
        ix, iy = np.floor(np.array([px, py]) / resolution).astype(int)
        grid.data[iy, ix] = 2.0
        sums[iy, ix] = (px - ix * resolution, py - iy * resolution, 1.0)
    maps = TiledMaps(1, resolution)
    maps.seed_from_grid(grid, sums)
    cells = [tuple(np.floor((np.array(p) - maps.origin) / resolution).astype(int)) for p in points]
    return maps, cells


@pytest.mark.parametrize("angle", [0.0, 0.3, np.pi / 2, -1.1])
def test_local_line_finds_the_normal_of_a_straight_wall(angle):
    d = np.array([np.cos(angle), np.sin(angle)])
    centre = np.array([0.52, 0.47])
    points = [centre + s * d for s in np.linspace(-0.06, 0.06, 5)]
    maps, cells = _map_with_surface_points(points)
    occupied = MatcherParams().packed()[2]
    is_line, nx, ny, cx, cy = local_line(*args_of(maps), *cells[2], occupied)
    assert is_line
    assert abs(nx * d[0] + ny * d[1]) < 1e-6  # normal across the wall
    assert abs(np.hypot(nx, ny) - 1) < 1e-9
    assert abs(nx * (cx - centre[0]) + ny * (cy - centre[1])) < 1e-6  # the centroid is on the wall


def test_scattered_points_are_no_line():
    points = [(0.51, 0.51), (0.56, 0.46), (0.47, 0.56), (0.57, 0.58), (0.46, 0.44)]
    maps, cells = _map_with_surface_points(points)
    occupied = MatcherParams().packed()[2]
    assert not local_line(*args_of(maps), *cells[0], occupied)[0]


def test_parallel_matches_from_several_starts_equal_the_serial_ones(room_map):
    params = MatcherParams().packed()
    beams = beams_of(room_scan(TRUE_POSE, 180))
    rng = np.random.default_rng(4)
    starts = TRUE_POSE + rng.normal(0, [0.05, 0.05, 0.05], (7, 3))
    poses, lls, counts = np.empty((7, 3)), np.empty(7), np.empty(7, np.int64)
    match_starts(*args_of(room_map), starts, beams, params, 10, 3, poses, lls, counts)
    for i, start in enumerate(starts):
        x, y, th, _, n, _, _ = match(*args_of(room_map), *start, beams, params, 10, 3)
        assert (poses[i].tolist(), counts[i]) == ([x, y, th], n)
        assert lls[i] == pose_likelihood(*args_of(room_map), x, y, th, beams, params)[0]
    assert len(np.unique(poses[:, 0])) > 1  # the starts did lead to different results


def plain_residual(args, c, s, x, y, beam, params, radius, jac):
    """One beam's residual as the module's docstring defines it, in plain Python, looking every cell
    up again: ``(rows, r0, r1, d2)`` (0 rows without a correspondence, ``d2`` then ``inf``)."""
    table, lo, _, origin_x, origin_y, resolution = args
    rx, ry = c * beam[0] - s * beam[1], s * beam[0] + c * beam[1]
    ex, ey = x + rx, y + ry
    back = FREE_STEP * resolution
    fx, fy = ex - back * (c * beam[2] - s * beam[3]), ey - back * (s * beam[2] + c * beam[3])
    inv = 1.0 / resolution
    ix, iy = math.floor((ex - origin_x) * inv), math.floor((ey - origin_y) * inv)
    fix, fiy = math.floor((fx - origin_x) * inv), math.floor((fy - origin_y) * inv)
    best, cell, point = math.inf, None, None
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            found, sx, sy = surface_point(*args, ix + dx, iy + dy, params[P_OCCUPIED])
            if not found or logodds_at(table, lo, fix + dx, fiy + dy) >= params[P_FREE]:
                continue
            d2 = (ex - sx) * (ex - sx) + (ey - sy) * (ey - sy)
            if d2 < best:
                best, cell, point = d2, (ix + dx, iy + dy), (sx, sy)
    if cell is None:
        return 0, 0.0, 0.0, best
    is_line, nx, ny, cx, cy = local_line(*args, *cell, params[P_OCCUPIED])
    if is_line:
        r = nx * (ex - cx) + ny * (ey - cy)
        jac[0] = nx, ny, -nx * ry + ny * rx
        return 1, r, 0.0, r * r
    jac[0], jac[1] = (1.0, 0.0, -ry), (0.0, 1.0, rx)
    return 2, ex - point[0], ey - point[1], best


def reference_likelihood(args, x, y, th, beams, params):
    """``(log-likelihood, beams matched)`` of a pose from :func:`plain_residual` at radius 1."""
    c, s, jac = math.cos(th), math.sin(th), np.empty((2, 3))
    loglik, matched = 0.0, 0
    for beam in beams:
        rows, _, _, d2 = plain_residual(args, c, s, x, y, beam, params, 1, jac)
        matched += rows > 0
        loglik -= min(d2, params[P_DMAX2])
    return loglik / (2.0 * params[P_LSIGMA2]), matched


def reference_match(args, x, y, th, beams, params, iterations, wide_iterations):
    """:func:`match`'s Gauss-Newton written out in Python on :func:`plain_residual` (no per-beam
    memory)."""
    x0, y0, th0 = x, y, th
    inv_l2 = 1.0 / params[P_LSIGMA2]
    prior_xy, prior_th = 1.0 / params[P_PRIOR_XY], 1.0 / params[P_PRIOR_TH]
    jac = np.empty((2, 3))
    for it in range(iterations):
        radius = 2 if it < wide_iterations else 1
        c, s = math.cos(th), math.sin(th)
        info, grad, matched = np.zeros((3, 3)), np.zeros(3), 0
        for beam in beams:
            rows, r0, r1, d2 = plain_residual(args, c, s, x, y, beam, params, radius, jac)
            if rows == 0:
                continue
            matched += 1
            length = math.sqrt(d2)
            w = inv_l2 if length <= params[P_HUBER] else inv_l2 * params[P_HUBER] / length
            for k in range(rows):
                r = r0 if k == 0 else r1
                for i in range(3):
                    grad[i] += w * jac[k, i] * r
                    for j in range(3):
                        info[i, j] += w * jac[k, i] * jac[k, j]
        system = info.copy()
        system[0, 0] += prior_xy
        system[1, 1] += prior_xy
        system[2, 2] += prior_th
        grad += [prior_xy * (x - x0), prior_xy * (y - y0), prior_th * (th - th0)]
        step = _solve3(system, grad)
        x, y, th = x - step[0], y - step[1], th - step[2]
        if it >= wide_iterations and abs(step[0]) + abs(step[1]) < 1e-4 and abs(step[2]) < 1e-4:
            break
    return x, y, th, info, matched


@pytest.mark.parametrize("seed", range(4))
def test_the_matcher_remembering_cells_gives_exactly_the_plain_result(room_map, seed):
    params = MatcherParams().packed()
    rng = np.random.default_rng(seed)
    beams = beams_of(room_scan(TRUE_POSE, 180))
    start = TRUE_POSE + rng.normal(0, [0.06, 0.06, 0.05])
    x, y, th, info, matched, ll, fitting = match(*args_of(room_map), *start, beams, params, 10, 3)
    rx, ry, rth, rinfo, rmatched = reference_match(args_of(room_map), *start, beams, params, 10, 3)
    assert (x, y, th, matched) == (rx, ry, rth, rmatched)
    np.testing.assert_array_equal(info, rinfo)
    reference = reference_likelihood(args_of(room_map), x, y, th, beams, params)
    assert (ll, fitting) == reference == pose_likelihood(*args_of(room_map), x, y, th, beams, params)
    assert (x, y, th) != tuple(start)


def test_surface_points_read_from_the_tile_parts_are_the_dense_mean_endpoints(room_map):
    """``surface_point`` (the matcher's one reader of the hit blocks, kept by tile part) against the
    mean endpoints of the map's dense hit sums and log-odds, cell for cell, map edges included."""
    grid, sums = room_map.to_grid(0), room_map.hit_sums(0)
    occupied_lo = float(MatcherParams().packed()[P_OCCUPIED])
    shift = np.round((grid.origin - room_map.origin) / room_map.resolution).astype(int)
    ny, nx = grid.shape
    found_any = 0
    for iy in range(-2, ny + 2):
        for ix in range(-2, nx + 2):
            gx, gy = ix + shift[0], iy + shift[1]
            found, x, y = surface_point(room_map.tables[0], room_map.lo, room_map.hits, room_map.origin[0],
                                        room_map.origin[1], room_map.resolution, gx, gy, occupied_lo)
            inside = 0 <= iy < ny and 0 <= ix < nx
            n = sums[iy, ix, 2] if inside else 0.0
            assert found == (inside and n > 0 and grid.data[iy, ix] > occupied_lo)
            if found:
                found_any += 1
                ox, oy, res = room_map.origin[0], room_map.origin[1], room_map.resolution
                assert (x, y) == (ox + gx * res + sums[iy, ix, 0] / n, oy + gy * res + sums[iy, ix, 1] / n)
    assert found_any > 100


def _rows_by_numpy(scan, max_range, max_beams):
    """The rows as numpy's own functions give them: echoes picked at ``np.linspace`` rounded."""
    r = scan.ranges
    idx = np.flatnonzero(scan.valid & (r <= max_range))
    if len(idx) > max_beams:
        idx = idx[np.linspace(0, len(idx) - 1, max_beams).round().astype(int)]
    a = scan.angles[idx]
    return np.column_stack([r[idx] * np.cos(a), r[idx] * np.sin(a), np.cos(a), np.sin(a)])


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.integers(1, 400), st.sampled_from([0, 1, 2, 3, 90, 180, 720]),
       st.floats(0.5, 90.0))
def test_beam_rows_are_numpys_rows_to_the_bit(seed, n, max_beams, max_range):
    """Echoes, misses (max range, inf), non-measurements (nan, below the minimum) mixed."""
    rng = np.random.default_rng(seed)
    ranges = rng.uniform(0.0, 85.0, n)
    ranges[rng.random(n) < 0.1] = np.inf
    ranges[rng.random(n) < 0.1] = np.nan
    ranges[rng.random(n) < 0.1] = 81.9
    scan = Scan(np.sort(rng.uniform(-np.pi, np.pi, n)), ranges, 0.05, 81.0)
    rows = beam_rows(scan, max_range, max_beams)
    assert rows.flags.c_contiguous
    assert np.array_equal(rows, _rows_by_numpy(scan, max_range, max_beams))
