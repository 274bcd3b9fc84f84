"""OdometryIntegrator: wrap-around of ticks and MCU clock, implausible jumps skipped, exact arcs."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.sensors.wheel_odometry import (
    MAX_TIME_GAP,
    TICK_SLACK,
    DiffDriveGeometry,
    OdometryIntegrator,
    wrapped_delta,
)

GEOMETRY = DiffDriveGeometry(wheel_radius=0.035, wheel_base=0.23, ticks_per_rev=1440)
MPT = GEOMETRY.metres_per_tick
DT_US = 20_000


def arc_pose(s_left: float, s_right: float, base: float) -> np.ndarray:
    """Closed-form end pose of a constant-curvature drive from the origin (independent of the code)."""
    s = 0.5 * (s_left + s_right)
    th = (s_right - s_left) / base
    if th == 0.0:
        return np.array([s, 0.0, 0.0])
    r = s / th
    return np.array([r * np.sin(th), r * (1 - np.cos(th)), np.arctan2(np.sin(th), np.cos(th))])


@given(st.integers(-(2**31), 2**31 - 1), st.integers(-(2**20), 2**20))
def test_wrapped_delta_across_the_int32_boundary(start, step):
    new = ((start + step + 2**31) % 2**32) - 2**31
    assert wrapped_delta(new, start) == step


@pytest.mark.parametrize("start", [(2**31 - 37, -(2**31) + 5), (0, 0), (-123456, 98765)])
@pytest.mark.parametrize("t0", [0, 2**32 - 3 * DT_US - 17])
def test_constant_wheel_steps_give_the_exact_arc_across_wraps(start, t0):
    d_left, d_right, n = 11, 17, 60
    integ = OdometryIntegrator(GEOMETRY, max_wheel_speed=1.0)
    for k in range(n + 1):
        t = (t0 + k * DT_US) % 2**32
        left = ((start[0] + k * d_left + 2**31) % 2**32) - 2**31
        right = ((start[1] + k * d_right + 2**31) % 2**32) - 2**31
        assert integ.update(t, left, right)
    np.testing.assert_allclose(integ.pose, arc_pose(n * d_left * MPT, n * d_right * MPT, 0.23), atol=1e-12)
    assert integ.time == pytest.approx(n * DT_US * 1e-6)
    assert integ.jumps_rejected == integ.time_gaps == 0


def test_implausible_jump_is_counted_skipped_and_rebaselined():
    integ = OdometryIntegrator(GEOMETRY, max_wheel_speed=1.0)
    limit = integ.max_ticks(DT_US * 1e-6)
    assert limit == int(1.0 * 0.02 / MPT) + TICK_SLACK
    integ.update(0, 100, 100)
    integ.update(DT_US, 110, 110)
    before = integ.pose.copy()
    assert not integ.update(2 * DT_US, 110 + limit + 1, 110)  # one wheel too fast
    np.testing.assert_array_equal(integ.pose, before)
    assert integ.jumps_rejected == 1
    assert integ.update(3 * DT_US, 120 + limit + 1, 10 + 110)  # continues from the rejected reading
    np.testing.assert_allclose(integ.pose, arc_pose(20 * MPT, 20 * MPT, 0.23), atol=1e-12)


def test_a_duplicate_timestamp_allows_only_slack_ticks():
    integ = OdometryIntegrator(GEOMETRY, max_wheel_speed=1.0)
    integ.update(500, 0, 0)
    assert integ.update(500, TICK_SLACK, -TICK_SLACK)
    assert not integ.update(500, 2 * TICK_SLACK + 1, -TICK_SLACK)


def test_mcu_reset_is_a_time_gap_not_a_jump():
    integ = OdometryIntegrator(GEOMETRY, max_wheel_speed=1.0)
    integ.update(7_000_000, 5000, 5200)
    integ.update(7_000_000 + DT_US, 5010, 5210)
    before = integ.pose.copy()
    assert not integ.update(1000, 0, 0)  # the MCU restarted: clock and counters from zero
    assert integ.time_gaps == 1
    np.testing.assert_array_equal(integ.pose, before)
    assert integ.update(1000 + DT_US, 10, 10)
    assert integ.pose[0] == pytest.approx(before[0] + 10 * MPT * np.cos(before[2]))
    assert not integ.update(1000 + DT_US + int(MAX_TIME_GAP * 1e6) + 1, 10, 10)
    assert integ.time_gaps == 2


def test_a_leap_of_the_mcu_clock_cannot_vouch_for_a_long_move_by_itself():
    """The issue's frame: valid CRC, MCU clock +4.9 s, ticks for metres, 20 ms after the last one."""
    integ = OdometryIntegrator(GEOMETRY, max_wheel_speed=1.5)
    integ.update(0, 0, 0, host_time=100.0)
    integ.update(DT_US, 10, 10, host_time=100.02)
    before = integ.pose.copy()
    leap = int(7.1 / MPT)
    assert not integ.update(DT_US + 4_900_000, 10 + leap, 10 + leap, host_time=100.04)
    np.testing.assert_array_equal(integ.pose, before)
    assert integ.jumps_rejected == 1
    # Without arrival times the MCU clock alone would have allowed it.
    alone = OdometryIntegrator(GEOMETRY, max_wheel_speed=1.5)
    alone.update(0, 0, 0)
    assert alone.update(4_900_000, leap, leap)


def test_a_late_frame_that_the_host_also_waited_for_is_accepted():
    integ = OdometryIntegrator(GEOMETRY, max_wheel_speed=1.0)
    integ.update(0, 0, 0, host_time=5.0)
    ticks = int(0.9 * 1.0 / MPT)  # 0.9 m in 1 s at a 1 m/s limit
    assert integ.update(1_000_000, ticks, ticks, host_time=6.0)
    assert integ.pose[0] == pytest.approx(ticks * MPT)


def test_bad_construction_is_explained():
    with pytest.raises(ValueError, match="max_wheel_speed"):
        OdometryIntegrator(GEOMETRY, max_wheel_speed=0)
    with pytest.raises(ValueError, match="wheel base"):
        OdometryIntegrator(DiffDriveGeometry(0.035, 0.0, 1440), max_wheel_speed=1.0)
    with pytest.raises(ValueError, match="initial pose"):
        OdometryIntegrator(GEOMETRY, max_wheel_speed=1.0, pose=(0, np.nan, 0))


@settings(max_examples=100, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 3 * DT_US), st.integers(-(2**31), 2**31 - 1), st.integers(-400, 400)),
        min_size=2,
        max_size=40,
    )
)
def test_no_pose_step_exceeds_the_speed_limit(readings):
    """Whatever readings arrive (plausible or not), each pose step is bounded by max speed x dt."""
    integ = OdometryIntegrator(GEOMETRY, max_wheel_speed=0.8)
    t = left = right = 0
    prev = integ.pose.copy()
    for dt, jump, step in readings:
        t = (t + dt) % 2**32
        left = ((left + step + 2**31) % 2**32) - 2**31
        right = jump if step % 7 == 0 else right + step // 2
        right = ((right + 2**31) % 2**32) - 2**31
        integ.update(t, left, right)
        bound = integ.max_ticks(dt * 1e-6) * MPT
        assert np.hypot(*(integ.pose[:2] - prev[:2])) <= bound + 1e-12
        assert abs(np.angle(np.exp(1j * (integ.pose[2] - prev[2])))) <= 2 * bound / 0.23 + 1e-12
        prev = integ.pose.copy()
