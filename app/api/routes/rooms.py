"""Rooms of the map in use: list, rename, merge, split along a line, go to."""

from __future__ import annotations

import asyncio
from typing import Annotated

from fastapi import APIRouter, HTTPException, Path, status
from pydantic import BaseModel, ConfigDict, Field, field_validator

from app.api.deps import RuntimeDep
from app.api.errors import ApiError
from app.api.models import Coordinate, GoalResponse
from app.api.replay_guard import NotReplaying
from app.api.routes.navigation import start_goal
from app.db.names import check_name
from app.navigation.planning import PlanningError
from app.rooms.overlay import overlay
from app.rooms.service import RoomService, room_centre
from slam_core.rooms.layout import RoomEditError

router = APIRouter(prefix="/rooms", tags=["rooms"])

RoomId = Path(ge=1, le=1_000_000)
Point = Annotated[list[Coordinate], Field(min_length=2, max_length=2)]


class Room(BaseModel):
    id: int
    name: str
    area: float = Field(description="square metres")
    centroid: list[float]


class RoomPatch(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(max_length=64)

    @field_validator("name")
    @classmethod
    def _name(cls, value: str) -> str:
        return check_name(value, "room name")


class MergeBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    keep: int = Field(ge=1, description="the room that stays (its id and name)")
    absorb: int = Field(ge=1, description="the room that joins it")


class SplitBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    a: Point = Field(description="[x, y] of one end of the line (metres, map frame)")
    b: Point = Field(description="[x, y] of the other end")


async def _edited(rooms: RoomService, change) -> list[dict]:
    try:
        await rooms.edit(change)
    except RoomEditError as exc:
        code = status.HTTP_404_NOT_FOUND if str(exc).startswith("no room") else status.HTTP_409_CONFLICT
        raise HTTPException(code, str(exc)) from None
    return await asyncio.to_thread(rooms.rooms)


@router.get("", response_model=list[Room])
def read_rooms(runtime: RuntimeDep) -> list[dict]:
    """The rooms found on the map (ids stay the same as the map grows)."""
    return runtime.rooms.rooms()


@router.get("/overlay")
async def read_overlay(runtime: RuntimeDep) -> dict:
    """The rooms for drawing: ``{origin, resolution, width, height, image (PNG data URL), rooms}``."""
    layout = runtime.rooms.layout

    def build() -> dict:
        return overlay(layout, {} if layout is None else {r: room_centre(layout, r) for r in layout.ids()})

    return await asyncio.to_thread(build)


@router.patch("/{room:int}", response_model=list[Room])
async def update_room(body: RoomPatch, runtime: RuntimeDep, room: int = RoomId) -> list[dict]:
    """Rename a room (409 when another room has that name)."""
    return await _edited(runtime.rooms, lambda layout: layout.renamed(room, body.name))


@router.post("/merge", response_model=list[Room])
async def create_merge(body: MergeBody, runtime: RuntimeDep) -> list[dict]:
    """Merge ``absorb`` into ``keep``."""
    return await _edited(runtime.rooms, lambda layout: layout.merged(body.keep, body.absorb))


@router.post("/{room:int}/split", response_model=list[Room])
async def create_split(body: SplitBody, runtime: RuntimeDep, room: int = RoomId) -> list[dict]:
    """Split a room along the line through ``a`` and ``b``; the part left of a->b gets a new id."""
    return await _edited(runtime.rooms, lambda layout: layout.split(room, body.a, body.b))


@router.post("/{room:int}/go", response_model=GoalResponse, status_code=status.HTTP_202_ACCEPTED,
             dependencies=[NotReplaying])
async def create_room_goal(runtime: RuntimeDep, room: int = RoomId) -> dict:
    """Drive into the room: to its point farthest from walls and doorways among those the robot can
    reach (422 ``room_unreachable`` when walls, no-go zones or unmapped space cut it off)."""
    try:
        goal = await runtime.rooms.goal(room, runtime.navigator)
    except KeyError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc.args[0])) from None
    except PlanningError as exc:
        raise ApiError(status.HTTP_422_UNPROCESSABLE_CONTENT, exc.reason, str(exc)) from None
    return await start_goal(runtime, goal)
