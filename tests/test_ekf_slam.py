"""The EKF cycle on an analytic room: tentative list against clutter, ICP, estimator contract."""

import itertools

import numpy as np
import pytest
from ekf_world import POST_RADIUS, cast, posts

from slam_core.ekf.ekf_slam import EkfConfig, EkfSlam
from slam_core.ekf.landmarks import SPIKE, ExtractorConfig
from slam_core.ekf.scan_odometry import IcpConfig, fuse_increments, match_increment, match_scans
from slam_core.geometry import compose, relative
from slam_core.scan import Scan

EXTRACTOR = ExtractorConfig(spike_min_beams=1, spike_radius=POST_RADIUS)


def test_icp_recovers_the_true_increment_from_a_wrong_guess():
    rng = np.random.default_rng(0)
    centres = posts(rng)
    a, b = np.array([1.0, 2.0, 0.3]), np.array([1.2, 2.1, 0.35])
    sa, sb = cast(a, centres, sigma=0.01, rng=rng), cast(b, centres, sigma=0.01, rng=rng)
    true = relative(a, b)
    for error in ([0.1, -0.05, 0.04], [0.0, 0.0, -0.08]):
        inc, ok = match_increment(sa, sb, true + np.array(error))
        assert ok
        assert np.hypot(*(inc[:2] - true[:2])) < 0.01 and abs(inc[2] - true[2]) < 0.005


def corridor_scan(pose, half_width=1.0, sigma=0.005, rng=None) -> Scan:
    """A 360-degree scan in an endless corridor along x (walls y = ±half_width)."""
    angles = -np.pi + 2 * np.pi * np.arange(720) / 720
    s = np.sin(pose[2] + angles)
    with np.errstate(divide="ignore"):
        ranges = np.where(s > 0, (half_width - pose[1]) / s, (-half_width - pose[1]) / s)
    ranges = np.abs(ranges) + (0.0 if rng is None else sigma * rng.standard_normal(720))
    return Scan(angles, np.where(ranges > 10.0, np.inf, ranges), 0.05, 10.0)


def test_icp_covariance_is_large_only_along_a_corridor():
    a, b = np.array([0.0, 0.1, 0.0]), np.array([0.3, 0.05, 0.03])
    true = relative(a, b)
    corridor = match_scans(corridor_scan(a), corridor_scan(b), true + np.array([0.05, 0.0, 0.0]))
    assert corridor.converged
    sd = np.sqrt(np.diag(corridor.covariance))
    # across the walls and in heading the scans pin the motion down; along them nothing does,
    # and the match stays where the guess put it
    assert sd[0] > 100.0 and sd[1] < 0.01 and sd[2] < np.radians(0.5)
    assert abs(corridor.increment[0] - true[0] - 0.05) < 0.01
    assert abs(corridor.increment[1] - true[1]) < 0.002 and abs(corridor.increment[2] - true[2]) < 0.001
    # with range noise, normals from wider chords keep most of that (noisy normals invent information)
    rng = np.random.default_rng(1)
    noisy = [corridor_scan(p, rng=rng) for p in (a, b)]
    narrow = np.sqrt(np.diag(match_scans(*noisy, true, IcpConfig(normal_span=1)).covariance))
    wide = np.sqrt(np.diag(match_scans(*noisy, true, IcpConfig(normal_span=3)).covariance))
    assert wide[0] > 2 * narrow[0] and wide[0] > 5 * wide[1]
    # a room with posts constrains every direction
    a, b = np.array([1.0, 2.0, 0.3]), np.array([1.2, 2.1, 0.35])
    true = relative(a, b)
    centres = posts(rng)
    room = match_scans(cast(a, centres, sigma=0.005, rng=rng), cast(b, centres, sigma=0.005, rng=rng), true)
    assert room.converged and np.all(np.sqrt(np.diag(room.covariance)) < 0.02)
    assert abs(room.increment[2] - true[2]) < 0.005


def test_fusion_weighs_by_information_and_refuses_a_disagreeing_match():
    q = np.diag([1e-2, 1e-2, 1e-2])
    u, cov, ok = fuse_increments([0.0, 0.0, 0.0], q, [0.1, 0.0, 0.02], q, gate=16.27)
    assert ok
    np.testing.assert_allclose(u, [0.05, 0.0, 0.01], atol=1e-12)
    np.testing.assert_allclose(cov, q / 2, atol=1e-12)
    # a degenerate scan estimate (huge variance along x) leaves x to the odometry
    q_scan = np.diag([1e6, 1e-4, 1e-4])
    u, _, ok = fuse_increments([0.2, 0.0, 0.0], q, [5.0, 0.01, 0.01], q_scan, gate=16.27)
    assert ok and abs(u[0] - 0.2) < 1e-3 and abs(u[1] - 0.01) < 1e-3
    u, cov, ok = fuse_increments([0.0, 0.0, 0.0], q, [1.0, 0.0, 0.0], q, gate=16.27)
    assert not ok and np.array_equal(u, [0.0, 0.0, 0.0]) and np.array_equal(cov, q)


def test_icp_reports_failure_on_an_empty_scan():
    empty = Scan(np.linspace(-1, 1, 50), np.full(50, np.inf), 0.1, 10.0)
    guess = np.array([0.1, 0.0, 0.0])
    inc, ok = match_increment(empty, empty, guess)
    assert not ok and np.array_equal(inc, guess)


def drive(ekf, centres, clutter_rng=None, steps=60):
    """Drive straight along x through the room; optionally one random clutter post per scan."""
    rng = np.random.default_rng(5)
    for k in range(steps):
        pose = np.array([-4.0 + 0.1 * k, 0.0, 0.0])
        extra = centres
        if clutter_rng is not None:
            extra = np.vstack([centres, clutter_rng.uniform(-8, 8, (1, 2))])
        ekf.step(pose, cast(pose, extra, sigma=0.005, rng=rng))
    return ekf


def test_clutter_seen_once_never_becomes_a_landmark():
    centres = np.array([[0.0, 3.0], [2.0, -3.0], [-3.0, 4.0]])
    clean = drive(EkfSlam(EkfConfig(extractor=EXTRACTOR), (-4.0, 0.0, 0.0)), centres)
    noisy = drive(EkfSlam(EkfConfig(extractor=EXTRACTOR), (-4.0, 0.0, 0.0)), centres,
                  clutter_rng=np.random.default_rng(9))
    for ekf in (clean, noisy):
        spikes = ekf.state.landmarks[ekf.landmark_kinds == SPIKE]
        assert len(spikes) == len(centres)
        d = np.hypot(spikes[:, None, 0] - centres[None, :, 0], spikes[:, None, 1] - centres[None, :, 1])
        assert d.min(axis=0).max() < 0.05
    # without the tentative list every clutter post would have become a landmark at once
    eager = drive(EkfSlam(EkfConfig(extractor=EXTRACTOR, confirm_hits=1), (-4.0, 0.0, 0.0)), centres,
                  clutter_rng=np.random.default_rng(9))
    assert np.sum(eager.landmark_kinds == SPIKE) > len(centres) + 10


def test_estimate_and_innovations_follow_the_estimator_contract():
    centres = np.array([[0.0, 3.0], [2.0, -3.0], [-3.0, 4.0]])
    ekf = drive(EkfSlam(EkfConfig(extractor=EXTRACTOR), (-4.0, 0.0, 0.0)), centres, steps=30)
    est = ekf.estimate()
    k = int(np.sum(~ekf.state.lines))  # the estimate carries the point landmarks; lines apart
    assert est.pose.shape == (3,) and est.covariance.shape == (3, 3)
    assert est.landmarks.shape == (k, 2) and est.landmark_covariances.shape == (k, 2, 2)
    assert ekf.occupancy_map() is None
    inn = ekf.last_innovations
    assert len(inn.landmarks) > 0
    assert inn.innovations.shape == (len(inn.landmarks), 2)
    assert np.all(np.linalg.eigvalsh(inn.covariances) > 0)
    # a small move is not an update: the pose follows the odometry, the filter waits
    before = ekf.updates
    odom = np.array([-4.0 + 0.1 * 29 + 0.01, 0.0, 0.0])
    assert not ekf.step(odom, cast(odom, centres))
    assert ekf.updates == before
    np.testing.assert_allclose(ekf.pose, compose(ekf.state.pose, [0.01, 0.0, 0.0]), atol=1e-9)


def test_bad_odometry_is_rejected():
    ekf = EkfSlam()
    with pytest.raises(ValueError, match="odometry"):
        ekf.step([0.0, np.inf, 0.0], cast(np.zeros(3), []))


def test_scan_matching_with_a_laser_offset_corrects_biased_odometry():
    """Odometry that over-turns by 20 % in every step; the laser sits 0.3 m ahead of the robot
    centre. ICP's increments, carried from the laser to the robot frame, keep the pose right
    (landmarks off, so that nothing else corrects it)."""
    rng = np.random.default_rng(2)
    centres = posts(rng)
    offset = (0.3, 0.0, 0.0)
    truth = [np.array([-3.0, -2.0, 0.0])]
    for _ in range(40):
        truth.append(compose(truth[-1], [0.12, 0.0, 0.06]))
    odom = [truth[0]]
    for a, b in itertools.pairwise(truth):
        inc = relative(a, b)
        odom.append(compose(odom[-1], [inc[0], inc[1], 1.2 * inc[2]]))
    results = {}
    for matching in (False, True):
        none = ExtractorConfig(spikes=False, corners=False, lines=False)
        ekf = EkfSlam(EkfConfig(extractor=none, laser_offset=offset, scan_matching=matching), truth[0])
        for t, o in zip(truth, odom, strict=True):
            ekf.step(o, cast(compose(t, offset), centres, sigma=0.005, rng=rng))
        results[matching] = ekf.pose - truth[-1]
    assert abs(results[False][2]) > 0.3  # the odometry alone ends far off
    assert np.hypot(*results[True][:2]) < 0.05 and abs(results[True][2]) < 0.01
