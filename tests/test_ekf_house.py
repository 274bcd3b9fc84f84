"""Landmark EKF against simulator ground truth: the scripted tour of the shipped house.

The tour drives into rooms and once around the 40 m corridor loop. Bounds checked:
- robot pose NEES below the 95 % chi-square bound (3 dof) for >= 90 % of updates, i.e. the filter
  is not overconfident. (The two-sided 95 % interval also holds for seed 3, 90.6 %, but not for
  seed 4, where NEES falls under the LOWER bound: the wheels' fixed scale error drawn by the
  simulator makes the pose error smaller than the motion model assumes.)
- every table leg is mapped at most once (no duplicates within 0.5 m of one leg);
- every mapped leg lies within LEG_ERROR_BOUND of the true leg, and most legs are mapped.
"""

import numpy as np
import pytest
from scipy.stats import chi2

from slam_core.ekf.ekf_slam import EkfConfig, EkfSlam
from slam_core.ekf.landmarks import SPIKE, ExtractorConfig
from slam_core.geometry import wrap_angle
from slam_core.sim.simulator import SimConfig, Simulator
from slam_core.sim.world import DEFAULT_LEG_RADIUS, load_world

SENSING_HZ = 5.0  # the tour at 5 Hz keeps the test fast; the EKF updates every 5 cm / 0.05 rad anyway
LEG_ERROR_BOUND = 0.2  # m
LEG_MATCH_RADIUS = 0.5  # m: a spike landmark this close to a true leg is that leg's
#: the simulated lidar has 1-degree beams: a 5 cm leg shows one or two of them
SIM_EXTRACTOR = ExtractorConfig(spike_min_beams=1, spike_radius=DEFAULT_LEG_RADIUS)


@pytest.fixture(scope="module", params=[3, 4])
def house_run(request):
    world = load_world("house")
    sim = Simulator(world, SimConfig(sensing_hz=SENSING_HZ), seed=request.param)
    ekf = None
    nees = []
    truth = []
    for frame in sim.tour():
        if ekf is None:
            ekf = EkfSlam(EkfConfig(extractor=SIM_EXTRACTOR), initial_pose=frame.odometry_pose)
        if ekf.step(frame.odometry_pose, frame.scan) and ekf.updates > 1:
            err = ekf.pose - frame.true_pose
            err[2] = wrap_angle(err[2])
            nees.append(err @ np.linalg.solve(ekf.state.pose_covariance, err))
        truth.append(frame.true_pose)
    return world, ekf, np.array(nees), np.array(truth)


def test_tour_is_a_real_loop(house_run):
    _, _, nees, truth = house_run
    assert np.hypot(*(truth[-1, :2] - truth[0, :2])) < 1.0
    assert np.sum(np.hypot(*np.diff(truth[:, :2], axis=0).T)) > 40.0
    assert len(nees) > 300


def test_pose_nees_is_inside_the_95_percent_bound(house_run):
    _, _, nees, _ = house_run
    bound = chi2.ppf(0.95, 3)
    inside = np.mean(nees < bound)
    assert inside >= 0.9, f"NEES below {bound:.3f} for only {inside:.1%} of updates"


def test_legs_are_mapped_once_and_accurately(house_run):
    world, ekf, _, _ = house_run
    legs = world.landmarks
    spikes = ekf.state.landmarks[ekf.landmark_kinds == SPIKE]
    d = np.hypot(spikes[:, None, 0] - legs[None, :, 0], spikes[:, None, 1] - legs[None, :, 1])
    nearest = d.argmin(axis=1)
    close = d.min(axis=1) < LEG_MATCH_RADIUS
    per_leg = np.bincount(nearest[close], minlength=len(legs))
    assert per_leg.max() <= 1, f"duplicate landmarks for legs {np.flatnonzero(per_leg > 1)}"
    errors = d.min(axis=1)[close]
    assert errors.max() < LEG_ERROR_BOUND
    assert close.sum() >= 0.6 * len(legs)


def test_final_pose_beats_odometry(house_run):
    _, ekf, _, truth = house_run
    assert np.hypot(*(ekf.pose[:2] - truth[-1, :2])) < 0.3
