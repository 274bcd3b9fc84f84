"""Spike and corner extraction on hand-made scans and on real scans of the MIT CSAIL log."""

import itertools

import numpy as np
import pytest

from slam_core.datasets import resolve_log
from slam_core.ekf.landmarks import (
    CORNER,
    SPIKE,
    ExtractorConfig,
    clusters,
    extract,
    fit_line,
    split_segments,
)
from slam_core.geometry import relative, transform_points
from slam_core.io.carmen import laser_records
from slam_core.scan import Scan

ANGLES = np.radians(np.arange(-180.0, 180.0, 0.5))


def scan_of(ranges_fn) -> Scan:
    return Scan(ANGLES, ranges_fn(ANGLES), 0.05, 20.0)


def room_ranges(a, half=4.0, centre=(0.0, 0.0)):
    """Inside an axis-aligned square room of half-width ``half`` around ``centre``."""
    c, s = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (half - centre[0]) / c, (-half - centre[0]) / c)
        ty = np.where(s > 0, (half - centre[1]) / s, (-half - centre[1]) / s)
    return np.minimum(np.abs(tx), np.abs(ty))


def with_post(ranges, a, post, radius):
    d = np.column_stack([np.cos(a), np.sin(a)])
    b = d @ -np.asarray(post)
    disc = b * b - (post @ post - radius ** 2)
    t = -b - np.sqrt(np.maximum(disc, 0))
    return np.where((disc >= 0) & (t > 0), np.minimum(ranges, t), ranges)


def test_room_corners_are_found_where_the_walls_meet():
    centre = (0.7, -0.4)
    feats = extract(scan_of(lambda a: room_ranges(a, 3.0, centre)))
    corners = feats.points[feats.kinds == CORNER]
    truth = np.array([[sx * 3.0 - centre[0], sy * 3.0 - centre[1]] for sx in (-1, 1) for sy in (-1, 1)])
    assert len(corners) == 4
    d = np.hypot(*(corners[:, None] - truth[None]).T)
    assert d.min(axis=0).max() < 0.02
    # bisectors point from the corner into the room: towards the robot for a concave corner
    dirs = feats.directions[feats.kinds == CORNER]
    back = np.arctan2(-corners[:, 1], -corners[:, 0])
    assert np.all(np.abs(np.angle(np.exp(1j * (dirs - back)))) < np.radians(15))


def test_a_post_in_front_of_a_wall_is_a_spike_at_its_centre():
    post, radius = np.array([2.0, 0.5]), 0.05
    feats = extract(scan_of(lambda a: with_post(room_ranges(a, 4.0), a, post, radius)),
                    ExtractorConfig(spike_radius=radius))
    spikes = feats.points[feats.kinds == SPIKE]
    assert len(spikes) == 1
    assert np.hypot(*(spikes[0] - post)) < 0.02
    assert np.sum(feats.kinds == CORNER) == 4


def test_posts_too_close_to_a_wall_or_too_wide_are_not_spikes():
    near_wall = extract(scan_of(lambda a: with_post(room_ranges(a, 4.0), a, np.array([3.85, 0.0]), 0.05)))
    assert np.sum(near_wall.kinds == SPIKE) == 0
    wide = extract(scan_of(lambda a: with_post(room_ranges(a, 4.0), a, np.array([2.0, 0.0]), 0.4)))
    assert np.sum(wide.kinds == SPIKE) == 0


def test_dotted_grazing_wall_gives_no_spikes():
    # a long wall at y = 0.6 seen at grazing angles: far points are sparse
    def ranges(a):
        r = np.full_like(a, np.inf)
        s = np.sin(a)
        hit = s > 0.02
        r[hit] = 0.6 / s[hit]
        return np.where(r < 15.0, r, np.inf)
    feats = extract(Scan(ANGLES, ranges(ANGLES), 0.05, 15.0))
    assert np.sum(feats.kinds == SPIKE) == 0


def test_split_segments_cuts_an_l_shape_at_its_knee():
    t = np.linspace(0, 1, 21)
    pts = np.vstack([np.column_stack([t, 0 * t]), np.column_stack([np.ones(20), t[1:]])])
    assert split_segments(pts, 0.01) == [(0, 20), (20, 40)]


@pytest.fixture(scope="module")
def mit_records():
    return list(itertools.islice(laser_records(resolve_log("mit-csail")), 0, 400))


def test_real_scans_yield_features_and_corners_repeat_from_scan_to_scan(mit_records):
    """Corners of one MIT scan reappear in the next (odometry-moved) scan within 15 cm."""
    counts, repeated, total = [], 0, 0
    for a, b in itertools.pairwise(mit_records):
        fa, fb = extract(a.scan), extract(b.scan)
        counts.append(len(fa))
        ca, cb = fa.points[fa.kinds == CORNER], fb.points[fb.kinds == CORNER]
        if len(ca) == 0 or len(cb) == 0:
            continue
        moved = transform_points(relative(b.odom, a.odom), ca)  # a's corners in b's frame
        d = np.hypot(*(moved[:, None] - cb[None]).T)
        repeated += int(np.sum(d.min(axis=1) < 0.15))
        total += len(ca)
    assert np.mean(counts) >= 1.0
    assert total >= 100
    assert repeated / total > 0.5


def test_compiled_clusters_match_the_naive_reference(mit_records):
    from naive_ekf import naive_clusters

    config = ExtractorConfig()
    for rec in mit_records[::40]:
        fast = clusters(rec.scan, config)
        slow = naive_clusters(rec.scan, config.breakpoint_lambda, config.range_sigma)
        assert len(fast) == len(slow)
        for a, b in zip(fast, slow, strict=True):
            np.testing.assert_array_equal(a, b)


def test_fit_line_direction_matches_the_principal_eigenvector():
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(50, 2)) * [2.0, 0.1] @ np.array([[0.6, 0.8], [-0.8, 0.6]])
    _, d = fit_line(pts)
    _, vecs = np.linalg.eigh(np.cov(pts.T))
    assert abs(abs(d @ vecs[:, 1]) - 1.0) < 1e-9
