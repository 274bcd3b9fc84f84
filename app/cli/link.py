"""``homebot link PORT``: watch a robot's serial link (bring-up check for firmware)."""

from __future__ import annotations

import json
import time
from dataclasses import asdict
from pathlib import Path

from app.cli.inputs import serial_device
from app.cli.progress import fraction_bar
from app.grabbers.odometry_grabber import DEFAULT_BAUDRATE, OdometryGrabber

POLL = 0.1  # s between progress updates


def register(sub) -> None:
    p = sub.add_parser(
        "link",
        help="read wheel encoders from a serial port and report odometry and link errors",
        description="Open PORT like the server does, decode the robot-link protocol "
        "(app/robot_link/PROTOCOL.md) for a while and report the odometry pose and every "
        "counter: frames, rejected frames per reason, bytes skipped, implausible jumps.",
    )
    p.add_argument("port", help="serial device, e.g. /dev/ttyUSB0 or /dev/serial/by-id/...")
    p.add_argument("--baud", type=int, default=DEFAULT_BAUDRATE, help="baud rate (default %(default)s)")
    p.add_argument("--seconds", type=float, default=5.0, help="how long to listen (default %(default)s)")
    p.add_argument("--robot", type=Path, default=None, metavar="FILE",
                   help="the robot's description (YAML, see README); default: the simulated robot")
    p.add_argument(
        "--max-wheel-speed", type=float, default=None,
        help="m/s beyond which an encoder reading is corrupt (default: twice the fastest wheel the robot "
             "file's limits allow)"
    )
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(run=run)


def run(args) -> int:
    if not args.seconds > 0:
        raise ValueError(f"--seconds must be positive, got {args.seconds}")
    from slam_core.robot_config import load_robot

    robot = load_robot(args.robot)
    speed = robot.max_wheel_speed if args.max_wheel_speed is None else args.max_wheel_speed
    grabber = OdometryGrabber(serial_device(args.port), args.baud, robot.wheels, speed)
    start = time.monotonic()
    with grabber, fraction_bar(f"listening on {args.port}") as progress:
        while (elapsed := time.monotonic() - start) < args.seconds:
            progress(elapsed / args.seconds)
            time.sleep(min(POLL, args.seconds - elapsed))
    stats = grabber.stats()
    _, odo = grabber.odometry.get()
    report = {"port": args.port, "seconds": args.seconds, **asdict(stats)}
    report["rate_hz"] = round(stats.frames_ok / args.seconds, 1)
    report["pose"] = None if odo is None else [float(v) for v in odo.pose]
    report["ticks"] = None if odo is None else list(odo.ticks)
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        for key, value in report.items():
            print(f"{key:24s} {value}")
    if stats.connects == 0:
        print(f"homebot link: could not open {args.port}")
        return 1
    if stats.frames_ok == 0:
        print(
            f"homebot link: no valid frame from {args.port} in {args.seconds:g} s "
            f"({stats.bytes_skipped} bytes skipped, rejected {stats.rejected or 'none'}); "
            "check the baud rate, the wiring and the frame layout in app/robot_link/PROTOCOL.md"
        )
        return 1
    return 0
