"""Every part reads the robot file: a robot unlike the simulated one (other wheels, encoder, footprint
and a laser behind the centre, turned) is simulated, its ticks are turned into metres, its scans
are matched, and the odometry and the estimates still agree with the simulator's ground truth;
told the shipped robot's geometry instead, the same consumers are measurably wrong."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
import yaml

from app.cli import main
from app.core.config import Settings
from app.grabbers.odometry_grabber import OdometryGrabber
from app.robot_link.virtual_mcu import VirtualMCU
from app.worker.estimators import Checkpoint, make_estimator
from slam_core.geometry import compose, relative, wrap_angle
from slam_core.io.carmen import laser_mount_of
from slam_core.robot_config import load_robot
from slam_core.sim.ground_truth import ground_truth_map
from slam_core.sim.robot import SimRobot, WheelNoise
from slam_core.sim.simulator import SimConfig, Simulator
from slam_core.sim.world import load_world
from tests.live_server import LiveServer, until

MOUNT = {"x": -0.08, "y": 0.03, "theta": 0.5}
DT = 0.01


@pytest.fixture(scope="module")
def other_robot(tmp_path_factory):
    """A robot file whose every part differs from the shipped simulated robot's."""
    data = load_robot().to_dict()
    data["name"] = "other"
    data["footprint_radius"] = 0.2
    data["wheels"] = {"wheel_radius": 0.05, "wheel_base": 0.31, "ticks_per_rev": 600}
    data["laser"]["mount"] = dict(MOUNT)
    path = tmp_path_factory.mktemp("robot") / "other.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _settings(robot_file) -> Settings:
    return Settings(robot=robot_file, data_dir="unused")


def test_the_grabber_turns_the_robot_files_ticks_into_the_simulators_metres(other_robot):
    robot = load_robot(other_robot)
    sim = SimRobot(load_world("flat"), robot=robot, noise=WheelNoise.none())
    mcu = VirtualMCU(sim, rate_hz=50.0, clock=lambda: sim.time).start()
    grabber = OdometryGrabber(mcu.path, geometry=_settings(other_robot).robot_config().wheels).start()
    try:
        assert grabber.wait_connected(5.0)
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:
            grabber.send_velocity(0.3, 0.4)
            for _ in range(5):
                sim.step(DT)
                time.sleep(DT)
        grabber.send_velocity(0.0, 0.0)
        for _ in range(100):
            sim.step(DT)
            time.sleep(DT)
        _, odo = grabber.odometry.get()
    finally:
        grabber.stop()
        mcu.stop()
    start = sim.world.start
    moved = math.hypot(*(sim.true_pose[:2] - start[:2]))
    assert moved > 0.2 and odo is not None and odo.ticks == sim.ticks()
    pose = compose(start, odo.pose)
    assert np.allclose(pose[:2], sim.true_pose[:2], atol=0.01), (pose, sim.true_pose)
    assert abs(wrap_angle(pose[2] - sim.true_pose[2])) < 0.01
    # the shipped robot's wheels would make metres of the same ticks 3.4 times too short
    shipped = load_robot().wheels.metres_per_tick * np.mean(sim.ticks())
    assert abs(shipped - robot.wheels.metres_per_tick * np.mean(sim.ticks())) > 0.5 * moved


@pytest.fixture(scope="module")
def tour(other_robot):
    """The first 20 s of the other robot's tour of the flat: frames with truth, odometry, scans."""
    sim = Simulator(load_world("flat"), SimConfig(robot=load_robot(other_robot)), seed=3)
    frames = []
    for frame in sim.tour(duration=20.0):
        frames.append(frame)
    return sim, frames


def _final_error(estimate_pose, truth) -> tuple[float, float]:
    return (float(np.hypot(*(estimate_pose[:2] - truth[:2]))),
            abs(float(wrap_angle(estimate_pose[2] - truth[2]))))


@pytest.mark.parametrize("told", ["other", "shipped"])
def test_the_mapping_filter_reads_the_laser_mount_from_the_robot_file(other_robot, tour, told):
    frames = tour[1]
    settings = _settings(other_robot if told == "other" else None)
    slam = make_estimator("mapping", settings, None)
    start_odom, start_true = frames[0].odometry_pose, frames[0].true_pose
    last = frames[0]
    for frame in frames:
        if slam.step(relative(start_odom, frame.odometry_pose), frame.scan):
            last = frame
    truth = relative(start_true, last.true_pose)  # where the robot was at the filter's last update
    assert math.hypot(*truth[:2]) > 2.0  # the tour went somewhere
    dxy, dth = _final_error(slam.estimate().pose, truth)
    if told == "other":
        assert dxy < 0.08 and dth < 0.04, (dxy, dth)
    else:  # odometry and scans disagree about the motion: the map and the pose are bent
        assert dxy > 0.3 or dth > 0.2, (dxy, dth)


@pytest.mark.parametrize("told", ["other", "shipped"])
def test_localization_reads_the_laser_mount_from_the_robot_file(other_robot, tour, told):
    sim, frames = tour
    laser = load_robot(other_robot).laser
    grid = ground_truth_map(sim.world, 0.05, laser.height)
    checkpoint = Checkpoint("localization", frames[0].true_pose.copy(), grid=grid)
    mcl = make_estimator("localization", _settings(other_robot if told == "other" else None), checkpoint)
    errors = []
    for frame in frames:
        mcl.step(frame.odometry_pose, frame.scan)
        errors.append(_final_error(mcl.estimate().pose, frame.true_pose))
    dxy, dth = np.array(errors[-40:]).mean(axis=0)  # the last 2 s
    if told == "other":
        assert dxy < 0.08 and dth < 0.04, (dxy, dth)
    else:
        assert dth > 0.2 or dxy > 0.2, (dxy, dth)


@pytest.mark.parametrize("told", ["other", "shipped"])
def test_the_ekf_reads_the_laser_mount_from_the_robot_file(other_robot, tour, told):
    frames = tour[1]
    ekf = make_estimator("ekf", _settings(other_robot if told == "other" else None), None)
    start_odom, start_true = frames[0].odometry_pose, frames[0].true_pose
    for frame in frames:
        ekf.step(relative(start_odom, frame.odometry_pose), frame.scan)
    truth = relative(start_true, frames[-1].true_pose)
    dxy, dth = _final_error(ekf.estimate().pose, truth)
    odometry_dxy, _ = _final_error(relative(start_odom, frames[-1].odometry_pose), truth)
    if told == "other":  # its scan odometry beats the wheels'
        assert dxy < 0.5 * odometry_dxy and dth < 0.02, (dxy, dth, odometry_dxy)
    else:
        assert dxy > 0.3, (dxy, dth)


def test_sim_record_drives_the_robot_file_and_logs_its_mount(other_robot, tmp_path, capsys):
    out = tmp_path / "rec"
    args = ["sim", "record", "flat", "--robot", str(other_robot), "--duration", "2", "--out", str(out)]
    assert main(args) == 0
    assert load_robot(out / "robot.yaml") == load_robot(other_robot)
    np.testing.assert_allclose(laser_mount_of(out / "sim.clf"), list(MOUNT.values()), atol=1e-5)


@pytest.mark.parametrize("command", [["sim", "record", "flat", "--duration", "1"], ["serve"]])
def test_a_bad_robot_file_is_refused_by_the_commands_with_exit_2(tmp_path, capsys, command):
    data = load_robot().to_dict()
    data["laser"]["mount"]["theta"] = float("nan")
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(data))
    args = [*command, "--robot", str(bad), "--out" if command[0] == "sim" else "--data", str(tmp_path / "o")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert f"{bad}: laser.mount.theta must be finite" in err and "Traceback" not in err


def test_a_live_server_drives_the_robot_file_and_publishes_its_true_pose(other_robot, tmp_path):
    """``homebot serve`` with ``HOMEBOT_ROBOT``: the simulated robot, its serial odometry, the
    planner's footprint, the controller and the mapping filter all take the other robot's file;
    the robot reaches a goal through a door and the published pose is the true one."""
    server = LiveServer(tmp_path / "data", env={"HOMEBOT_ROBOT": str(other_robot)}).start()
    try:
        with server.client() as c:
            assert c.get("/api/robot").json() == load_robot(other_robot).to_dict()  # what the dashboard draws
            r = c.post("/api/goal", json={"x": 3.2, "y": 1.8, "explore": True})  # hall -> kitchen
            assert r.status_code == 202, r.text

            def settled():
                status = c.get("/api/status").json()
                return status if status["nav"]["state"] in ("arrived", "failed") else None

            status = until(settled, 120, "the robot to reach the kitchen")
    finally:
        server.stop()
    assert load_robot(tmp_path / "data" / "robot.yaml") == load_robot(other_robot)  # the effective robot
    assert status["nav"]["state"] == "arrived", status["nav"]
    pose, true = status["pose"], status["true_pose"]
    assert math.hypot(true[0] - 3.2, true[1] - 1.8) < 0.3, true
    assert math.hypot(pose["x"] - true[0], pose["y"] - true[1]) < 0.1, (pose, true)
    assert abs(wrap_angle(pose["yaw"] - true[2])) < 0.05, (pose, true)
