"""Request and response bodies (pydantic) shared by the routes."""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

from app.db.names import MAX_NAME_LENGTH, NAME_REGEX, NAME_RULE, check_name

#: No coordinate beyond this (m) is ever accepted; the routes then hold it to the map's bounds.
COORDINATE_LIMIT_M = 1000.0

#: A position in metres (map frame): a JSON number (not a string, not a boolean), finite, bounded.
Coordinate = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-COORDINATE_LIMIT_M,
                                    le=COORDINATE_LIMIT_M)]
#: A heading in radians, counter-clockwise from the map's x axis.
Yaw = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-2 * math.pi, le=2 * math.pi)]


def _name_type(what: str):
    return Annotated[str, Field(min_length=1, max_length=MAX_NAME_LENGTH, description=NAME_RULE,
                                json_schema_extra={"pattern": NAME_REGEX}),
                     AfterValidator(lambda value: check_name(value, what))]


PlaceName = _name_type("place name")
MapName = _name_type("map name")
SessionName = _name_type("session name")


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Ok(BaseModel):
    ok: bool = True


class Health(BaseModel):
    status: Literal["ok", "degraded"]
    version: str
    reasons: list[str] = []


class Login(Strict):
    token: str = Field(min_length=1, max_length=512, strict=True)


class PoseBody(Strict):
    """Where the robot is (metres, radians; within the map's bounds plus a margin)."""

    x: Coordinate
    y: Coordinate
    yaw: Yaw = 0.0


class GoalAtPoint(Strict):
    """A goal at ``x``, ``y`` (metres, map frame), reached facing ``yaw`` if given."""

    x: Coordinate
    y: Coordinate
    yaw: Yaw = None  # left out: any heading will do
    explore: bool = Field(False, strict=True, description="allow the path through unexplored space")


class GoalAtPlace(Strict):
    """A goal at a named place (its position and heading)."""

    place: PlaceName
    explore: bool = Field(False, strict=True, description="allow the path through unexplored space")


def _goal_schema(schema: dict) -> None:
    """The schema says what the validator enforces: a point or a place, never both, no nulls."""
    description = schema.get("description")
    schema.clear()
    schema.update(description=description,
                  oneOf=[GoalAtPoint.model_json_schema(), GoalAtPlace.model_json_schema()])


class GoalBody(Strict):
    """Either both ``x`` and ``y`` (and optionally ``yaw``), or ``place``."""

    model_config = ConfigDict(extra="forbid", json_schema_extra=_goal_schema)

    x: Coordinate | None = None
    y: Coordinate | None = None
    yaw: Yaw | None = None
    place: PlaceName | None = None
    explore: bool = Field(False, strict=True)

    @model_validator(mode="before")
    @classmethod
    def _no_nulls(cls, data):
        if isinstance(data, dict) and any(value is None for value in data.values()):
            raise ValueError("null is not a value: leave the field out")
        return data

    @model_validator(mode="after")
    def _one_kind(self):
        has_xy = self.x is not None and self.y is not None
        if has_xy == (self.place is not None) or (self.x is None) != (self.y is None):
            raise ValueError("give either both 'x' and 'y' (metres) or 'place'")
        if self.place is not None and self.yaw is not None:
            raise ValueError("a place has its own heading: give 'yaw' only with 'x' and 'y'")
        return self


class GoalResponse(BaseModel):
    goal: dict
    path: list[list[float]]
    length: float


class PathResponse(BaseModel):
    goal: dict | None
    path: list[list[float]]
    state: str
    reason: str | None


class ModeBody(Strict):
    mode: Literal["mapping", "localization", "ekf"]
    map: MapName | None = None
    #: Mapping only: throw the current map away and start an empty one (otherwise every mode
    #: switch keeps the map).
    new_map: bool = Field(False, strict=True, description="mapping only: start an empty map")

    @model_validator(mode="after")
    def _new_map_is_for_mapping(self):
        if self.new_map and (self.mode != "mapping" or self.map is not None):
            raise ValueError("'new_map' starts an empty map: only with mode 'mapping' and no 'map'")
        return self


class ModeResponse(BaseModel):
    mode: str
    mapping: bool


class TeleopBody(Strict):
    v: float = Field(strict=True, ge=-0.5, le=0.5, allow_inf_nan=False)
    w: float = Field(strict=True, ge=-2.0, le=2.0, allow_inf_nan=False)


class PlaceBody(Strict):
    """A named place; ``x``, ``y`` within the map's bounds plus a margin."""

    name: PlaceName
    x: Coordinate
    y: Coordinate
    yaw: Yaw = 0.0


class PlacePatch(Strict):
    name: PlaceName | None = None
    x: Coordinate | None = None
    y: Coordinate | None = None
    yaw: Yaw | None = None


class Place(BaseModel):
    name: str
    x: float
    y: float
    yaw: float


class MapBody(Strict):
    name: MapName


class SessionBody(Strict):
    name: SessionName


class SavedSession(BaseModel):
    name: str
    saved: float = Field(description="when it was saved (Unix time, s)")
    bytes: int


class SavedMap(BaseModel):
    name: str
    created: float
    width: int
    height: int
    resolution: float


class RobotWheels(BaseModel):
    wheel_radius: float
    wheel_base: float
    ticks_per_rev: int


class LaserMountPose(BaseModel):
    x: float
    y: float
    theta: float


class RobotLaser(BaseModel):
    mount: LaserMountPose
    height: float
    beams: int
    range_min: float
    range_max: float


class RobotLimitsModel(BaseModel):
    v_max: float
    w_max: float
    a_max: float
    alpha_max: float


class RobotDescription(BaseModel):
    """The robot file in use (``homebot serve --robot``): metres, seconds, radians."""

    name: str
    footprint_radius: float
    wheels: RobotWheels
    laser: RobotLaser
    limits: RobotLimitsModel


class Status(BaseModel):
    mode: str
    mapping: bool = Field(description="false while `mapping/stop` holds the map frozen (the pose then "
                          "follows odometry), true otherwise in every mode: not the mode, see `mode`")
    pose: dict | None
    localized: bool
    room: str | None = None
    worker: dict
    map: dict | None
    goal: dict | None
    nav: dict
    path_length: float
    rates: dict
    clients: int
    sim: bool
    replay: dict | None = None
    loops: dict | None = None
    odometry: dict | None = Field(None, description="how the odometry errs, as the estimator's matches "
                                  "measured it (kept across restarts); null in modes without one")
    #: REP-105 frames: {"map_to_odom": [x, y, yaw], "map_to_odom_seq", "odom": [x, y, yaw], "odom_t"}
    frames: dict | None = None
    true_pose: list[float] | None
    events: list[dict]
    preparing: dict | None = None  # {"done", "total", "stage"} while the worker warms up its kernels
    time: float
