"""The odometry's systematic error and noise, learned from matched updates."""

import dataclasses
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.geometry import compose, relative, wrap_angle
from slam_core.motion_model import OdometryMotionModel, noise_stds
from slam_core.odometry_calibration import OdometryCalibration
from slam_core.rbpf import RBPFConfig, RBPFSlam
from slam_core.scan import Scan
from tests.synthetic_room import room_scan

ALPHAS = OdometryMotionModel().alphas


def observed(drift, turn_scale, trans_scale, noise_rot, noise_trans, n=200, seed=0, outliers=0):
    """A calibration fed ``n`` errors of an odometry with the given systematic errors and noise."""
    rng = np.random.default_rng(seed)
    cal = OdometryCalibration(ALPHAS, window=n, min_samples=20, min_scale=0.01)
    for k in range(n):
        rot1, trans, rot2 = rng.uniform(-0.3, 0.3), rng.uniform(0.1, 1.0), rng.uniform(-0.3, 0.3)
        heading = drift * trans + turn_scale * (rot1 + rot2) + rng.normal(0, noise_rot)
        along = trans_scale * trans + rng.normal(0, noise_trans)
        if k < outliers:  # a stall or a slip: far off
            heading, along = heading + rng.choice([-1, 1]) * 0.5, along - 0.3
        cal.observe(np.array([rot1, trans, rot2]), np.array([along, 0.0, heading]))
    return cal


@settings(max_examples=25, deadline=None)
@given(drift=st.floats(-0.05, 0.05), turn_scale=st.floats(-0.05, 0.05), trans_scale=st.floats(-0.05, 0.05),
       seed=st.integers(0, 1000))
def test_recovers_the_systematic_errors(drift, turn_scale, trans_scale, seed):
    cal = observed(drift, turn_scale, trans_scale, noise_rot=0.002, noise_trans=0.002, seed=seed)
    np.testing.assert_allclose(cal.bias(), [drift, turn_scale, trans_scale], atol=0.003)


@settings(max_examples=25, deadline=None)
@given(noise_rot=st.floats(0.001, 0.02), seed=st.integers(0, 1000))
def test_noise_scale_is_the_measured_spread_in_model_units(noise_rot, seed):
    cal = observed(0.02, 0.0, 0.01, noise_rot=noise_rot, noise_trans=0.005, seed=seed)
    # the model's heading std over this mix of motions, for reference
    rng = np.random.default_rng(seed)
    model = np.median([np.hypot(*np.array(noise_stds(r1, t, r2, *ALPHAS))[[0, 2]])
                       for r1, t, r2 in zip(rng.uniform(-0.3, 0.3, 200), rng.uniform(0.1, 1.0, 200),
                                            rng.uniform(-0.3, 0.3, 200), strict=True)])
    rotation, _translation = cal.scales()
    assert 0.4 * noise_rot / model < rotation < 2.5 * noise_rot / model
    assert cal.scales().max() <= 1.0


def test_stalls_and_slips_do_not_move_the_calibration():
    clean = observed(0.03, 0.02, 0.02, 0.003, 0.003, seed=4)
    faulty = observed(0.03, 0.02, 0.02, 0.003, 0.003, seed=4, outliers=20)
    np.testing.assert_allclose(faulty.bias(), clean.bias(), atol=0.003)
    assert faulty.scales()[0] < 1.5 * clean.scales()[0]


def test_an_odometry_noisier_than_the_model_keeps_the_model():
    cal = observed(0.0, 0.0, 0.0, noise_rot=1.0, noise_trans=1.0)
    np.testing.assert_array_equal(cal.scales(), [1.0, 1.0])
    np.testing.assert_allclose(cal.fallback_alphas(), ALPHAS)


def test_nothing_changes_before_enough_errors_are_measured():
    cal = observed(0.05, 0.05, 0.05, 0.001, 0.001, n=19)
    motion = np.array([0.1, 0.5, -0.2])
    np.testing.assert_array_equal(cal.corrected(motion), motion)
    np.testing.assert_array_equal(cal.fallback_alphas(), ALPHAS)


def test_the_corrected_motion_takes_the_drift_out():
    cal = observed(0.04, 0.0, 0.02, 0.0005, 0.0005)
    rot1, trans, rot2 = cal.corrected(np.array([0.0, 1.0, 0.0]))
    assert abs(trans - 1.02) < 0.002 and abs(rot2 - 0.04) < 0.002 and rot1 == 0.0


def circle(laps: float, step: float = 0.05, radius: float = 1.5, centre=(0.5, 0.4)) -> np.ndarray:
    """True poses driving anticlockwise round a circle in the synthetic room."""
    t = np.arange(int(laps * 2 * np.pi * radius / step) + 1) * step / radius
    return np.column_stack([centre[0] + radius * np.sin(t), centre[1] - radius * np.cos(t), wrap_angle(t)])


def blind_lap(seed: int, min_samples: int):
    """Two laps with scans, then one with no echo at all, on an odometry that drifts 0.03 rad a
    metre and reads travel 2 % long; the filter's pose error at its last update (m, deg) and the
    odometry's heading error over the blind lap (deg)."""
    rng = np.random.default_rng(seed)
    truth = circle(3)
    odom = [truth[0].copy()]
    for a, b in itertools.pairwise(truth):
        step = relative(a, b) * [1.02, 1.02, 1.0] + [0.0, 0.0, 0.03 * 0.05] + rng.normal(0, 0.001, 3)
        odom.append(compose(odom[-1], step))
    config = dataclasses.replace(RBPFConfig(particles=10), calibration_min_samples=min_samples)
    slam = RBPFSlam(config, seed=seed, initial_pose=truth[0])
    blind_from = 2 * len(truth) // 3
    blind = Scan(np.linspace(-np.pi, np.pi, 180, endpoint=False), np.full(180, 80.0), 0.1, 80.0)
    last = 0
    for k, (pose, od) in enumerate(zip(truth, odom, strict=True)):
        if slam.step(od, blind if k >= blind_from else room_scan(pose, 180, noise=0.01, rng=rng)):
            last = k
    assert last > len(truth) - 10
    end = slam.estimate().pose  # the pose at the last update
    odometry_turn = relative(odom[blind_from], odom[-1])[2] - relative(truth[blind_from], truth[-1])[2]
    return (np.hypot(*(end[:2] - truth[last, :2])), np.degrees(abs(wrap_angle(end[2] - truth[last, 2]))),
            np.degrees(abs(wrap_angle(odometry_turn))))


@pytest.mark.parametrize("seed", [0, 2])
def test_a_blind_lap_follows_the_calibrated_odometry(seed):
    metres, degrees, odometry_degrees = blind_lap(seed, min_samples=20)
    _, uncalibrated_degrees, _ = blind_lap(seed, min_samples=10**6)
    assert odometry_degrees > 10  # the raw odometry turns the blind lap that far wrong
    assert degrees < 5 and metres < 0.2
    assert degrees < uncalibrated_degrees


def _errors(n: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` (motion, error) pairs of an odometry that drifts 0.02 rad a metre and over-reports 3 %."""
    rng = np.random.default_rng(seed)
    pairs = []
    for _ in range(n):
        motion = np.array([rng.uniform(-0.3, 0.3), rng.uniform(0.1, 1.0), rng.uniform(-0.3, 0.3)])
        heading = 0.02 * motion[1] + rng.normal(0, 0.003)
        pairs.append((motion, np.array([-0.03 * motion[1] + rng.normal(0, 0.003), 0.0, heading])))
    return pairs


def _fed(pairs, window: int = 150) -> OdometryCalibration:
    cal = OdometryCalibration(ALPHAS, window=window, min_samples=20, min_scale=0.01)
    for motion, error in pairs:
        cal.observe(motion, error)
    return cal


@settings(max_examples=20, deadline=None)
@given(n=st.integers(0, 400), seed=st.integers(0, 1000))
def test_a_calibration_resumed_from_the_errors_kept_corrects_as_the_original(n, seed):
    """What a restarted worker does with its checkpoint's errors: the same corrections at once, and
    the same after both go on measuring (the ring of kept errors wraps past 150)."""
    pairs = _errors(n + 30, seed)
    original = _fed(pairs[:n])
    resumed = OdometryCalibration(ALPHAS, window=150, min_samples=20, min_scale=0.01)
    assert resumed.resume(original.measured())
    assert len(original.measured().rows) == min(n, 150) and original.calibrated() == (n >= 20)
    for _ in range(2):
        assert resumed.calibrated() == original.calibrated()
        np.testing.assert_allclose(resumed.bias(), original.bias(), rtol=0, atol=1e-12)
        np.testing.assert_allclose(resumed.scales(), original.scales(), rtol=0, atol=1e-12)
        np.testing.assert_array_equal(resumed.measured().rows, original.measured().rows)
        for motion, error in pairs[n:]:
            original.observe(motion, error)
            resumed.observe(motion, error)
    assert abs(resumed.bias()[0] - 0.02) < 0.005 and abs(resumed.bias()[2] + 0.03) < 0.005


def test_errors_measured_with_another_motion_model_or_malformed_are_refused():
    errors = _fed(_errors(60, 3)).measured()
    other = OdometryCalibration(ALPHAS * 2, window=150, min_samples=20, min_scale=0.01)
    assert not other.resume(errors) and not other.calibrated()  # its noise columns mean other stds
    smaller = OdometryCalibration(ALPHAS, window=40, min_samples=20, min_scale=0.01)
    assert smaller.resume(errors)
    np.testing.assert_array_equal(smaller.measured().rows, errors.rows[-40:])  # the newest that fit
    with pytest.raises(ValueError, match="rows of 6"):
        type(errors)(errors.alphas, errors.rows[:, :5])
    with pytest.raises(ValueError, match="non-finite"):
        type(errors)(errors.alphas, np.where(np.eye(60, 6, dtype=bool), np.nan, errors.rows))
