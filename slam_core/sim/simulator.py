"""World + robot + sensors + clock: the simulation loop and the scripted tour.

Physics runs at ``physics_hz`` and the sensor at ``sensing_hz`` (20 Hz by
default). Each :meth:`Simulator.advance` applies one velocity command for one
sensing period and returns a :class:`Frame` with the ground truth, the
odometry, the encoder ticks and the new scan (for the depth camera, the image
too; its scan comes from :func:`slam_core.sensors.depth_to_scan.depth_to_scan`,
the depth grabber's own function).

:meth:`Simulator.tour` drives the world's waypoints with
:class:`~slam_core.control.pure_pursuit.PurePursuit`. The script steers on the
*true* pose (it is the director, not the robot's estimator) and uses the latest
scan for the obstacle stop; it ends at the last waypoint, at ``duration``, or
when the robot has been blocked for ``BLOCKED_TIMEOUT`` seconds.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from slam_core.control.pure_pursuit import PurePursuit, PursuitConfig
from slam_core.robot_config import RobotConfig, robot_from
from slam_core.scan import Scan
from slam_core.sensors.depth_to_scan import DEFAULT_BAND_ROWS, depth_to_scan
from slam_core.sim.depth_camera import DepthCamera, DepthCameraConfig
from slam_core.sim.lidar import Lidar, LidarConfig
from slam_core.sim.robot import SimRobot, WheelNoise
from slam_core.sim.world import World

SENSORS = ("lidar", "depth")
#: A tour gives up after the robot has been blocked this long (s).
BLOCKED_TIMEOUT = 5.0


@dataclass(frozen=True)
class SimConfig:
    """The simulated ``robot`` (default: the shipped simulated robot), its sensor and noise.

    The depth camera, when it is the sensor, sits at the robot's laser mount."""

    sensor: str = "lidar"
    sensing_hz: float = 20.0
    physics_hz: float = 100.0
    robot: RobotConfig = field(default_factory=lambda: robot_from(None))
    noise: WheelNoise = field(default_factory=WheelNoise)
    depth: DepthCameraConfig = field(default_factory=DepthCameraConfig)
    depth_band_rows: int = DEFAULT_BAND_ROWS

    def __post_init__(self):
        if self.sensor not in SENSORS:
            raise ValueError(f"unknown sensor {self.sensor!r} (choose from {', '.join(SENSORS)})")
        if not (self.sensing_hz > 0 and self.physics_hz >= self.sensing_hz):
            raise ValueError("need physics_hz >= sensing_hz > 0")

    @property
    def lidar(self) -> LidarConfig:
        return LidarConfig(self.robot.laser)


@dataclass(frozen=True)
class Frame:
    """One sensing instant: ``time`` (s), poses ``(x, y, theta)``, cumulative ticks, scan, image."""

    time: float
    true_pose: np.ndarray
    odometry_pose: np.ndarray
    ticks: tuple[int, int]
    velocity: tuple[float, float]
    scan: Scan
    depth: np.ndarray | None = None


class Simulator:
    """``Simulator(world, config, seed)``: step it with :meth:`advance` or drive :meth:`tour`."""

    def __init__(self, world: World, config: SimConfig | None = None, seed: int = 0):
        self.world = world
        self.config = config or SimConfig()
        c = self.config
        robot_rng, self.sensor_rng = np.random.default_rng(seed).spawn(2)
        self.robot = SimRobot(world, robot=c.robot, noise=c.noise, rng=robot_rng)
        self.lidar = Lidar(world, c.lidar) if c.sensor == "lidar" else None
        self.camera = DepthCamera(world, c.depth) if c.sensor == "depth" else None
        self.period = 1.0 / c.sensing_hz
        self.substeps = max(1, round(c.physics_hz / c.sensing_hz))
        self.time = 0.0
        self.last: Frame = self.sense()

    def sense(self) -> Frame:
        """Read the sensor at the current instant."""
        pose = self.robot.true_pose
        depth = None
        if self.lidar is not None:
            scan = self.lidar.scan(pose, self.sensor_rng, self.time)
        else:
            depth = self.camera.render(self.config.robot.laser.mount.laser_poses(pose), self.sensor_rng)
            scan = depth_to_scan(depth, self.camera.intrinsics, self.config.depth_band_rows,
                                 self.camera.config.range_min, self.camera.config.range_max, self.time)
        self.last = Frame(self.time, pose, self.robot.odometry_pose, self.robot.ticks(),
                          self.robot.velocity, scan, depth)
        return self.last

    def advance(self, v: float, w: float) -> Frame:
        """Command ``(v, w)`` for one sensing period, then sense."""
        self.robot.set_velocity(v, w)
        dt = self.period / self.substeps
        for _ in range(self.substeps):
            self.robot.step(dt)
        self.time = round(self.time + self.period, 9)
        return self.sense()

    def tour(self, duration: float | None = None, pursuit: PursuitConfig | None = None,
             waypoints=None) -> Iterator[Frame]:
        """Drive the waypoints (default: the world's tour), yielding the first frame and every new one."""
        pts = self.world.tour if waypoints is None else np.asarray(waypoints, dtype=float)
        if len(pts) == 0:
            raise ValueError(f"world {self.world.name!r} has no waypoints to tour")
        controller = PurePursuit(pts, pursuit or PursuitConfig.for_robot(self.config.robot))
        self.controller = controller
        end = np.inf if duration is None else self.time + duration
        blocked_since = None
        yield self.last
        while not controller.done and self.time < end - 1e-9:
            v, w = controller.command(self.robot.true_pose, self.last.scan)
            if controller.blocked:
                blocked_since = self.time if blocked_since is None else blocked_since
                if self.time - blocked_since >= BLOCKED_TIMEOUT:
                    return
            else:
                blocked_since = None
            yield self.advance(v, w)
