"""No-go zones (polygons) and virtual walls (segments) of the map in use: list, add, delete."""

from __future__ import annotations

import asyncio
from typing import Annotated, Literal

from fastapi import APIRouter, HTTPException, Path, Response, status
from pydantic import BaseModel, ConfigDict, Field

from app.api.deps import RuntimeDep
from app.api.models import Coordinate
from app.db.zones import MAX_ID
from app.zones.service import ZoneError, replan_for_zones

router = APIRouter(prefix="/zones", tags=["zones"])

Point = Annotated[list[Coordinate], Field(min_length=2, max_length=2)]


class Zone(BaseModel):
    id: int
    kind: Literal["zone", "wall"]
    points: list[list[float]]


class ZoneBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    kind: Literal["zone", "wall"] = Field(description="'zone': a polygon of 3+ points; 'wall': a segment")
    points: list[Point] = Field(min_length=2, max_length=64, description="[[x, y], ...] metres, map frame")


@router.get("", response_model=list[Zone])
def read_zones(runtime: RuntimeDep) -> list[dict]:
    """The map's no-go zones and virtual walls."""
    return [z.dict() for z in runtime.zones.list()]


@router.post("", response_model=Zone, status_code=status.HTTP_201_CREATED)
async def create_zone(body: ZoneBody, runtime: RuntimeDep) -> dict:
    """Add a no-go zone or a virtual wall; the next plan keeps out of it."""
    try:
        record = await asyncio.to_thread(runtime.zones.add, body.kind, body.points)
    except ZoneError as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from None
    await replan_for_zones(runtime.navigator)
    return record.dict()


@router.delete("/{zone_id:int}", status_code=status.HTTP_204_NO_CONTENT, response_class=Response)
async def delete_zone(runtime: RuntimeDep, zone_id: int = Path(ge=1, le=MAX_ID)) -> Response:
    """Remove a zone or wall."""
    try:
        await asyncio.to_thread(runtime.zones.delete, zone_id)
    except ZoneError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from None
    await replan_for_zones(runtime.navigator)
    return Response(status_code=status.HTTP_204_NO_CONTENT)
