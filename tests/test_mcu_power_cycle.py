"""An MCU that loses power mid-drive comes back with its counters at 0; the odometry does not jump."""

from __future__ import annotations

import numpy as np

from app.grabbers.odometry_grabber import OdometryGrabber
from app.robot_link.virtual_mcu import VirtualMCU
from tests.test_serial_link_pty import GEOMETRY, WAIT, ArcWheels, drive, wait_until


def test_a_power_cycle_restarts_the_counters_and_the_odometry_continues_without_a_jump():
    wheels = ArcWheels(start=(40_000, 52_000))
    with (
        VirtualMCU(wheels, clock=wheels.clock) as mcu,
        OdometryGrabber(mcu.path, geometry=GEOMETRY, max_wheel_speed=1.0) as grabber,
    ):
        assert grabber.wait_connected(WAIT)
        before = drive(grabber, wheels, 0.2, 0.0, seconds=0.5)
        assert before.pose[0] > 0.09
        mcu.power_cycle(0.2)
        wait_until(lambda: mcu.stats.power_cycles == 1, "the MCU to boot again")
        seq = grabber.odometry.get()[0]
        wait_until(lambda: grabber.odometry.get()[0] > seq, "odometry from the rebooted MCU")
        rebooted = grabber.odometry.get()[1]
        assert max(abs(t) for t in rebooted.ticks) < 50  # the counters start again from 0 ...
        np.testing.assert_allclose(rebooted.pose, before.pose, atol=1e-12)  # ... and are no motion
        start = wheels.moving_time
        assert grabber.send_velocity(0.2, 0.0)
        wait_until(lambda: wheels.moving_time >= start + 0.5, "the second drive")
        assert grabber.send_velocity(0.0, 0.0)
        wait_until(lambda: wheels.commands[-1] == (0.0, 0.0), "the stop command")
        travelled = 0.2 * (wheels.moving_time - start)

        def caught_up():
            return abs(grabber.odometry.get()[1].pose[0] - (before.pose[0] + travelled)) < 2e-3

        wait_until(caught_up, "the odometry to follow the second drive")
        stats = grabber.stats()
    assert stats.odometry_time_gaps == 1 and stats.odometry_jumps_rejected == 0
    assert abs(grabber.odometry.get()[1].pose[1]) < 1e-9
