"""The simulated robot in its own process: physics, lidar, and the virtual MCU on a pty.

The server talks to it exactly as to a real robot: odometry and velocity commands go
over the serial link (the server's robot link opens the pty path with pyserial),
scans arrive in a shared slot (:mod:`app.robot.scan_slot`); a real robot's come from
``settings.sensor_source``.
Ground truth is published in a shared array for status and tests only. SIGUSR1 cuts the
virtual MCU's power for a moment (tests of recovery: it reboots with its counters at 0).
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import time
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path

import numpy as np

from app.robot.scan_slot import ScanSlot
from app.worker.lifeline import bind_to_parent
from slam_core.robot_config import RobotConfig

PHYSICS_HZ = 100.0
SCAN_HZ = 15.0
#: The MCU stops the wheels when no velocity command came for this long (s).
COMMAND_TIMEOUT = 1.0
STARTUP_TIMEOUT = 60.0


@dataclass
class SimHandles:
    """What the server keeps of the simulator process."""

    process: mp.Process
    port: str
    scans: ScanSlot
    truth: mp.Array  # x, y, yaw, sim time
    stop: mp.Event

    def true_pose(self) -> np.ndarray:
        with self.truth.get_lock():
            return np.array(self.truth[:3])

    def shutdown(self, timeout: float = 5.0) -> None:
        self.stop.set()
        self.process.join(timeout)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(timeout)


def start_simulator(world: str, seed: int, link: Path, robot: RobotConfig,
                    ctx=None) -> tuple[SimHandles, Connection]:
    """Start the simulator process for ``robot``; its serial device will appear at ``link`` (see
    :func:`wait_ready`)."""
    ctx = ctx or mp.get_context("spawn")
    scans = ScanSlot.create(ctx)
    truth = ctx.Array("d", 4)
    stop = ctx.Event()
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=run_simulator,
                       args=(world, seed, robot, str(link), scans, truth, stop, child, os.getpid()),
                       name="homebot-sim", daemon=True)
    proc.start()
    child.close()
    return SimHandles(proc, str(link), scans, truth, stop), parent


def wait_ready(handles: SimHandles, ready: Connection) -> None:
    """Block until the simulator runs; raise its start-up error if it failed."""
    if not ready.poll(STARTUP_TIMEOUT):
        handles.process.terminate()
        raise RuntimeError("the simulator did not start")
    message = ready.recv()
    if isinstance(message, Exception):
        handles.process.join(5)
        raise message


def run_simulator(world_name: str, seed: int, robot_config: RobotConfig, link: str, scans: ScanSlot, truth,
                  stop, ready, parent_pid: int) -> None:
    """The simulator process: step physics in real time, scan, serve the MCU pty."""
    # The server stops us through ``stop``, after its robot link (a Ctrl-C or a service manager's
    # SIGTERM reaches every process of the group at once) ...
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    bind_to_parent(parent_pid)  # ... and we end when it dies
    from app.robot_link.virtual_mcu import VirtualMCU
    from slam_core.sim.lidar import Lidar, LidarConfig
    from slam_core.sim.robot import SimRobot
    from slam_core.sim.world import load_world

    try:
        world = load_world(world_name)
        rng = np.random.default_rng(seed)
        robot = SimRobot(world, robot=robot_config, rng=np.random.default_rng(seed + 1))
        lidar = Lidar(world, LidarConfig(robot_config.laser))
        lidar.scan(robot.true_pose, rng)  # compile the ray caster before reporting ready
        mcu = VirtualMCU(robot, command_timeout=COMMAND_TIMEOUT, link=link).start()
    except Exception as exc:  # reported to the parent, which raises it
        ready.send(RuntimeError(f"simulator failed to start: {exc}"))
        return
    signal.signal(signal.SIGUSR1, lambda *_: mcu.power_cycle())  # fault injection: an MCU power cut
    ready.send(mcu.path)
    dt = 1.0 / PHYSICS_HZ
    scan_every = max(1, round(PHYSICS_HZ / SCAN_HZ))
    tick = 0
    next_time = time.monotonic()
    try:
        while not stop.is_set():
            robot.step(dt)
            pose = robot.true_pose
            with truth.get_lock():
                truth[:] = [pose[0], pose[1], pose[2], robot.time]
            tick += 1
            if tick % scan_every == 0:
                scans.write(lidar.scan(pose, rng, timestamp=time.time()))
            next_time += dt
            delay = next_time - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            elif delay < -1.0:  # far behind (machine busy): do not try to catch up
                next_time = time.monotonic()
    finally:
        mcu.stop()
