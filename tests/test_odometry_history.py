"""OdometryHistory: each scan's odometry at the scan's own stamp."""

from dataclasses import dataclass

import numpy as np
import pytest

from app.grabbers.odometry_history import OdometryHistory


@dataclass(frozen=True)
class Reading:
    pose: np.ndarray
    stamp: float


def reading(stamp, x, y, theta):
    return Reading(np.array([x, y, theta]), stamp)


def test_an_empty_history_has_no_odometry():
    assert OdometryHistory().at(1.0) is None


def test_a_reading_at_the_exact_stamp_is_returned_as_it_is():
    history = OdometryHistory()
    first, second = reading(1.0, 0, 0, 0), reading(2.0, 1, 0, 0)
    history.put(first)
    history.put(second)
    assert history.at(1.0) is first and history.at(2.0) is second


def test_between_two_readings_the_pose_is_interpolated_across_the_heading_wrap():
    history = OdometryHistory()
    history.put(reading(10.0, 0.0, 0.0, 3.1))
    history.put(reading(11.0, 1.0, -2.0, -3.1))  # turned 2*pi - 6.2 = 0.083 rad counter-clockwise
    mid = history.at(10.25)
    assert mid.stamp == 10.25
    np.testing.assert_allclose(mid.pose[:2], [0.25, -0.5])
    turn = 2 * np.pi - 6.2
    assert mid.pose[2] == pytest.approx(np.angle(np.exp(1j * (3.1 + 0.25 * turn))))


def test_stamps_before_or_after_the_history_take_its_oldest_or_newest_reading():
    history = OdometryHistory()
    for t in (1.0, 2.0, 3.0):
        history.put(reading(t, t, 0, 0))
    assert history.at(0.5).stamp == 1.0
    assert history.at(9.0).stamp == 3.0


def test_a_stamp_that_steps_back_is_kept_in_order():
    history = OdometryHistory()
    for t in (1.0, 3.0, 2.0):  # a log's ipc stamps do this
        history.put(reading(t, t, 0, 0))
    assert history.at(2.0).pose[0] == 2.0
    assert history.at(2.5).pose[0] == pytest.approx(2.5)


def test_the_oldest_readings_go_when_the_history_is_full():
    history = OdometryHistory(length=3)
    for t in range(6):
        history.put(reading(float(t), t, 0, 0))
    assert history.at(0.0).stamp == 3.0
