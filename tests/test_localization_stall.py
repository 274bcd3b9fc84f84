"""An odometry that stalls and then catches up (as MIT CSAIL's does for 3-4 scans at a time) does
not stop the published pose in a corridor, nor make it jump when it catches up."""

import numpy as np
import pytest

from slam_core.geometry import compose, relative
from slam_core.localization import MonteCarloLocalizer
from tests.corridor import STEP, corridor_map, scan_at


def drive(stalls: set[int], scans: int = 100, seed: int = 0):
    """Drive down the corridor; the odometry freezes on the ``stalls`` scans and reports the motion
    it missed with the next scan. Returns the true and published poses and the flags."""
    rng = np.random.default_rng(seed)
    truth = [np.array([STEP * k, 0.05 * np.sin(0.1 * k), 0.0]) for k in range(scans)]
    mcl = MonteCarloLocalizer(corridor_map(), rng=rng, initial_pose=truth[0],
                              initial_covariance=np.diag([0.05, 0.05, 0.02]) ** 2)
    odom, published, flags = truth[0].copy(), [], []
    held = truth[0].copy()  # the odometry the robot reports
    for k, pose in enumerate(truth):
        if k:
            step = np.array([pose[0] - truth[k - 1][0], pose[1] - truth[k - 1][1], 0.0])
            odom = compose(odom, step * (1.01, 1.0, 1.0))
        if k not in stalls:
            held = odom.copy()
        mcl.step(held, scan_at(pose, rng))
        e = mcl.estimate()
        published.append(e.pose.copy())
        flags.append(e.localized)
    return np.array(truth), np.array(published), np.array(flags)


def test_a_stalled_odometry_neither_holds_the_pose_back_nor_makes_it_jump():
    stalls = {30, 31, 32, 60, 61, 62, 63}
    truth, published, flags = drive(stalls)
    error = np.hypot(*(published[:, :2] - truth[:, :2]).T)
    jumps = np.hypot(*np.diff(published[:, :2], axis=0).T) - np.hypot(*np.diff(truth[:, :2], axis=0).T)
    # (the door frames pin the position along the corridor: 1 % odometry scale error leaves it
    # 0.02-0.04 m off; without bridging the stalls it is 0.78 m behind, flagged localized)
    assert error.max() <= 0.1, (int(error.argmax()), error.max())
    assert jumps.max() <= 0.15, (int(jumps.argmax()) + 1, jumps.max())
    assert flags.all()


@pytest.mark.parametrize("slowing", [[0.15, 0.1, 0.05, 0.02], [0.02], []])
def test_a_robot_that_stops_is_not_carried_on(slowing):
    """A robot that really stops, slowing down over scans or within one (as Intel's does), stands
    still where the scans show it."""
    rng = np.random.default_rng(3)
    speeds = [STEP] * 20 + slowing + [0.0] * 15 + [0.05, 0.1, 0.15] + [STEP] * 10
    x = np.concatenate([[0.0], np.cumsum(speeds)])
    truth = [np.array([v, 0.0, 0.0]) for v in x]
    mcl = MonteCarloLocalizer(corridor_map(), rng=rng, initial_pose=truth[0],
                              initial_covariance=np.diag([0.05, 0.05, 0.02]) ** 2)
    for pose in truth:
        mcl.step(pose * (1.01, 1.0, 1.0), scan_at(pose, rng))
        e = mcl.estimate()
        assert np.hypot(*(e.pose[:2] - pose[:2])) <= 0.15


@pytest.mark.parametrize("seed", [5, 6, 7])
def test_an_odometry_that_freezes_while_the_robot_turns_is_caught_up_from_where_it_froze(seed):
    """As MIT CSAIL's at scans 1579-1584: the odometry's last reading before it freezes is mostly
    stale, it then reports nothing for four scans while the robot drives on and turns, and then
    reports all of it in one step. The freeze is bridged with the step before the stale reading,
    and the catch-up is not added on top of what the scans showed."""
    rng = np.random.default_rng(seed)
    scans = 90
    truth = [np.array([STEP * k, 0.0, 0.0]) for k in range(scans)]
    for k in range(1, scans):  # weave: heading up to 0.35 rad, position along it
        theta = 0.35 * np.sin(0.25 * k)
        truth[k] = compose(truth[k - 1], np.array([STEP, 0.0, theta - truth[k - 1][2]]))
        truth[k][1] = np.clip(truth[k][1], -0.4, 0.4)
    mcl = MonteCarloLocalizer(corridor_map(), rng=rng, initial_pose=truth[0],
                              initial_covariance=np.diag([0.05, 0.05, 0.02]) ** 2)
    frozen, partial = range(41, 45), 40
    published = []
    for k, pose in enumerate(truth):
        if k == partial:  # the reading is from 15 % into the last interval
            reported = compose(truth[k - 1], 0.15 * relative(truth[k - 1], pose))
        elif k not in frozen:
            reported = pose
        mcl.step(reported, scan_at(pose, rng))
        published.append(mcl.estimate().pose.copy())
    published, truth = np.array(published), np.array(truth)
    error = np.hypot(*(published[:, :2] - truth[:, :2]).T)
    jumps = np.hypot(*np.diff(published[:, :2], axis=0).T) - np.hypot(*np.diff(truth[:, :2], axis=0).T)
    # the stale reading leaves it 0.15 m behind before the freeze shows; without following the
    # scans through it, 0.84 m behind (flagged localized), then a 0.85 m jump at the catch-up;
    # without passing over the stale reading, 0.22-0.24 m behind at the freeze's first scan
    assert error.max() <= 0.25, (int(error.argmax()), error.max())
    assert error[frozen].max() <= 0.05, (int(error[frozen].argmax()) + frozen[0], error[frozen].max())
    assert error[frozen[-1]:].max() <= 0.05, error[frozen[-1]:].max()
    assert jumps.max() <= 0.2, (int(jumps.argmax()) + 1, jumps.max())
