"""One robot description: footprint, wheels, laser and limits, read from a YAML file.

Every part that depends on the robot's body reads it from here: the simulator, the
odometry grabber (ticks to metres), the costmap and the controller, and the estimators
(the laser mount). The simulated robot's file ships with the package
(:data:`SIMULATED_ROBOT`) and is the default; a real robot brings its own file with the
same keys (``homebot serve --robot robot.yaml``). Loading is strict: an unknown or
missing key, a value of the wrong type, a non-finite number or a negative one where a
length or a count is expected raises :class:`RobotConfigError` naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path

import yaml

from slam_core.rbpf.laser_mount import LaserMount
from slam_core.sensors.wheel_odometry import DiffDriveGeometry

#: The simulated robot's description, shipped as package data.
SIMULATED_ROBOT = resources.files("slam_core") / "robots" / "simulated.yaml"


class RobotConfigError(ValueError):
    """A robot file that cannot describe a robot; the message names the file and the key."""


@dataclass(frozen=True)
class RobotLimits:
    """Speed and acceleration limits: m/s, rad/s, m/s^2, rad/s^2."""

    v_max: float
    w_max: float
    a_max: float
    alpha_max: float


@dataclass(frozen=True)
class LaserSpec:
    """The 2D laser: its ``mount`` in the base frame, height above the floor (m), beams over a
    full turn and range limits (m)."""

    mount: LaserMount
    height: float
    beams: int
    range_min: float
    range_max: float


@dataclass(frozen=True)
class RobotConfig:
    """A differential-drive robot shaped as a disc of ``footprint_radius`` (m)."""

    name: str
    footprint_radius: float
    wheels: DiffDriveGeometry
    laser: LaserSpec
    limits: RobotLimits

    @property
    def max_wheel_speed(self) -> float:
        """Wheel speed (m/s) above which an encoder reading is taken as corrupt: the fastest a wheel
        turns within the limits (full speed and full turn rate at once), times :data:`WHEEL_SPEED_MARGIN`."""
        fastest = self.limits.v_max + self.limits.w_max * self.wheels.wheel_base / 2.0
        return WHEEL_SPEED_MARGIN * fastest

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def to_yaml(self) -> str:
        return yaml.safe_dump(self.to_dict(), sort_keys=False)


#: An encoder reading that implies a wheel this many times faster than the limits allow is corrupt.
WHEEL_SPEED_MARGIN = 2.0

#: Keys whose value must be > 0; every other number must be >= 0 except the mount's.
POSITIVE = {"footprint_radius", "wheels.wheel_radius", "wheels.wheel_base", "wheels.ticks_per_rev",
            "laser.beams", "laser.range_max", "limits.v_max", "limits.w_max", "limits.a_max",
            "limits.alpha_max"}
#: No number of a robot file is larger (a beam count, encoder ticks, metres).
MAX_NUMBER = 1e6
#: Keys that may take any finite value (a laser behind or right of the centre, turned).
SIGNED = {"laser.mount.x", "laser.mount.y", "laser.mount.theta"}


def load_robot(path: str | Path | None = None) -> RobotConfig:
    """The robot described by the YAML file at ``path`` (``None``: the simulated robot)."""
    source = SIMULATED_ROBOT if path is None else Path(path)
    try:
        data = yaml.safe_load(source.read_bytes().decode("utf-8"))
    except UnicodeDecodeError:
        raise RobotConfigError(f"{source}: not a text file") from None
    except yaml.YAMLError as exc:
        raise RobotConfigError(f"{source}: not valid YAML ({exc})".replace("\n", " ")) from None
    robot = _build(RobotConfig, data, "", source)
    if robot.laser.range_min >= robot.laser.range_max:
        raise RobotConfigError(f"{source}: laser.range_min ({robot.laser.range_min}) must be below "
                               f"laser.range_max ({robot.laser.range_max})")
    return robot


@lru_cache(maxsize=8)
def robot_from(path: Path | None) -> RobotConfig:
    """:func:`load_robot`, read once per process and path."""
    return load_robot(path)


def _build(kind: type, data, prefix: str, source):
    """An instance of the dataclass ``kind`` from the mapping ``data`` found at key ``prefix``."""
    where = prefix.rstrip(".") or "the top level"
    if not isinstance(data, dict):
        raise RobotConfigError(f"{source}: {where} must be a mapping of keys to values")
    hints = typing.get_type_hints(kind)
    names = [f.name for f in dataclasses.fields(kind)]
    unknown = sorted(set(data) - set(names), key=str)
    if unknown:
        raise RobotConfigError(f"{source}: unknown key {prefix}{unknown[0]} (expected: {', '.join(names)})")
    values = {}
    for name in names:
        key = prefix + name
        if name not in data:
            raise RobotConfigError(f"{source}: missing key {key}")
        values[name] = _value(hints[name], data[name], key, source)
    try:
        return kind(**values)
    except ValueError as exc:  # the type's own check (e.g. the laser mount's reach)
        raise RobotConfigError(f"{source}: {where}: {exc}") from None


def _value(kind: type, value, key: str, source):
    if dataclasses.is_dataclass(kind):
        return _build(kind, value, key + ".", source)
    if kind is str:
        if not isinstance(value, str) or not value.strip():
            raise RobotConfigError(f"{source}: {key} must be a non-empty text, got {value!r}")
        return value
    integral = kind is int
    numeric = int if integral else int | float
    if isinstance(value, bool) or not isinstance(value, numeric):
        raise RobotConfigError(f"{source}: {key} must be {'an integer' if integral else 'a number'}, "
                               f"got {value!r}")
    if not math.isfinite(value) or abs(value) > MAX_NUMBER:
        raise RobotConfigError(f"{source}: {key} must be finite and within ±{MAX_NUMBER:g}, got {value!r}")
    if key in POSITIVE and not value > 0:
        raise RobotConfigError(f"{source}: {key} must be positive, got {value!r}")
    if key not in SIGNED and value < 0:
        raise RobotConfigError(f"{source}: {key} must not be negative, got {value!r}")
    return kind(value)
