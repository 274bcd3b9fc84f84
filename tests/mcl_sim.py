"""Drive the shipped simulator for localization tests: start anywhere on the tour, teleport."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.geometry import compose, relative, wrap_angle
from slam_core.sim.robot import SimRobot
from slam_core.sim.simulator import SimConfig, Simulator
from slam_core.sim.world import World

#: A pose estimate counts as right within these (the issue's tolerances).
GOOD_XY = 0.2
GOOD_THETA = np.radians(10.0)
#: Lidar frames per second in these tests (the filter updates every 0.1 m anyway).
SENSING_HZ = 5.0


def room_of(waypoint_name: str) -> str:
    room = waypoint_name.split("_")[0]
    return "hall" if room == "home" else room


def tour_from(world: World, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The tour's waypoints rotated to start at ``k`` and the pose there, facing the next one."""
    pts = np.roll(world.tour, -k, axis=0)
    heading = np.arctan2(*(pts[1] - pts[0])[::-1])
    return pts, np.array([pts[0, 0], pts[0, 1], heading])


def place(sim: Simulator, pose, seed: int) -> None:
    """Put the simulated robot at ``pose`` (a new robot: its odometry restarts there)."""
    c = sim.config
    sim.robot = SimRobot(sim.world, pose=pose, robot=c.robot, noise=c.noise, rng=np.random.default_rng(seed))
    sim.sense()


@dataclass
class Update:
    travelled: float
    seconds: float  # simulated time since the leg started
    error_xy: float
    error_theta: float
    localized: bool

    @property
    def good(self) -> bool:
        return self.error_xy < GOOD_XY and self.error_theta < GOOD_THETA


class Drive:
    """Feeds one MCL from a simulator; the odometry it sees stays continuous across teleports."""

    def __init__(self, world: World, mcl, seed: int):
        self.world = world
        self.mcl = mcl
        self.sim = Simulator(world, SimConfig(sensing_hz=SENSING_HZ), seed=seed)
        self.seed = seed
        self.travelled = 0.0
        self._odom_fed = None
        self._odom_base = None

    def leg(self, k: int, max_travel: float, stop=None, every_scan: bool = False) -> list[Update]:
        """Teleport to waypoint ``k`` and follow the tour from there for ``max_travel`` metres.

        Records the estimate after each step that updated it (after every scan with ``every_scan``).
        """
        pts, pose = tour_from(self.world, k)
        place(self.sim, pose, self.seed * 1000 + k)
        start = self.travelled
        base = self._odom_fed
        odom0 = self.sim.robot.odometry_pose
        prev = None
        updates: list[Update] = []
        for scans, frame in enumerate(self.sim.tour(waypoints=np.vstack([pts, pts[:1]]))):
            if prev is not None:
                self.travelled += float(np.hypot(*(frame.true_pose[:2] - prev[:2])))
            prev = frame.true_pose
            odom = relative(odom0, frame.odometry_pose)
            fed = odom if base is None else compose(base, odom)
            self._odom_fed = fed
            if self.mcl.step(fed, frame.scan) or every_scan:
                e = self.mcl.estimate()
                u = Update(self.travelled - start, scans / SENSING_HZ,
                           float(np.hypot(*(e.pose[:2] - frame.true_pose[:2]))),
                           float(abs(wrap_angle(e.pose[2] - frame.true_pose[2]))), e.localized)
                updates.append(u)
                if stop is not None and stop(updates):
                    break
            if self.travelled - start >= max_travel:
                break
        return updates
