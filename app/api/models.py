"""Request and response bodies (pydantic) shared by the routes."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from app.db.names import check_name

Finite = Field(allow_inf_nan=False)


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Ok(BaseModel):
    ok: bool = True


class Health(BaseModel):
    status: Literal["ok", "degraded"]
    version: str
    reasons: list[str] = []


class Login(Strict):
    token: str = Field(min_length=1, max_length=512)


class PoseBody(Strict):
    x: float = Finite
    y: float = Finite
    yaw: float = Field(0.0, allow_inf_nan=False)


class GoalBody(Strict):
    x: float | None = Field(None, allow_inf_nan=False)
    y: float | None = Field(None, allow_inf_nan=False)
    place: str | None = Field(None, max_length=64)

    @model_validator(mode="after")
    def _one_kind(self):
        has_xy = self.x is not None and self.y is not None
        if has_xy == (self.place is not None) or (self.x is None) != (self.y is None):
            raise ValueError("give either both 'x' and 'y' (metres) or 'place'")
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
    map: str | None = Field(None, max_length=64)
    #: Mapping only: throw the current map away and start an empty one (otherwise every mode
    #: switch keeps the map).
    new_map: bool = False

    @model_validator(mode="after")
    def _new_map_is_for_mapping(self):
        if self.new_map and (self.mode != "mapping" or self.map is not None):
            raise ValueError("'new_map' starts an empty map: only with mode 'mapping' and no 'map'")
        return self

    @field_validator("map")
    @classmethod
    def _map_name(cls, value):
        return None if value is None else check_name(value, "map name")


class ModeResponse(BaseModel):
    mode: str
    mapping: bool


class TeleopBody(Strict):
    v: float = Field(ge=-0.5, le=0.5, allow_inf_nan=False)
    w: float = Field(ge=-2.0, le=2.0, allow_inf_nan=False)


class PlaceBody(Strict):
    name: str = Field(max_length=64)
    x: float = Finite
    y: float = Finite
    yaw: float = Field(0.0, allow_inf_nan=False)

    @field_validator("name")
    @classmethod
    def _name(cls, value):
        return check_name(value, "place name")


class PlacePatch(Strict):
    name: str | None = Field(None, max_length=64)
    x: float | None = Field(None, allow_inf_nan=False)
    y: float | None = Field(None, allow_inf_nan=False)
    yaw: float | None = Field(None, allow_inf_nan=False)

    @field_validator("name")
    @classmethod
    def _name(cls, value):
        return None if value is None else check_name(value, "place name")


class Place(BaseModel):
    name: str
    x: float
    y: float
    yaw: float


class MapBody(Strict):
    name: str = Field(max_length=64)

    @field_validator("name")
    @classmethod
    def _name(cls, value):
        return check_name(value, "map name")


class SavedMap(BaseModel):
    name: str
    created: float
    width: int
    height: int
    resolution: float


class Status(BaseModel):
    mode: str
    mapping: bool
    pose: dict | None
    localized: bool
    worker: dict
    map: dict | None
    goal: dict | None
    nav: dict
    path_length: float
    rates: dict
    clients: int
    sim: bool
    true_pose: list[float] | None
    events: list[dict]
    preparing: dict | None = None  # {"done", "total", "stage"} while the worker warms up its kernels
    time: float
