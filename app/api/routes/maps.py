"""Saved maps: save the current map under a name, list, load for localization, delete."""

import asyncio
from typing import Annotated

from fastapi import APIRouter, Path, Response, status

from app.api import path_names  # noqa: F401  (registers {name:name})
from app.api.deps import RuntimeDep, SettingsDep, StoreDep
from app.api.errors import ApiError
from app.api.models import MapBody, MapName, SavedMap, Status
from app.api.replay_guard import NotReplaying
from app.api.routes.map import png_bytes
from app.api.routes.mode import switch_mode
from app.api.saved_maps import MAP_SUFFIXES, checked_map_file, load_saved_map, map_file, map_record
from app.db import store as db
from slam_core.io.render import save_png
from slam_core.io.ros_map import save_map

router = APIRouter(prefix="/maps", tags=["maps"])

MapNameParam = Annotated[MapName, Path(description="the saved map's name")]


@router.get("", response_model=list[SavedMap])
def read_maps(store: StoreDep) -> list[dict]:
    """All saved maps."""
    return [m.dict() for m in store.list_maps()]


@router.post("", response_model=SavedMap, status_code=status.HTTP_201_CREATED)
async def create_map(body: MapBody, runtime: RuntimeDep, store: StoreDep, settings: SettingsDep) -> dict:
    """Save the current map as ``name`` (PGM + YAML + PNG beside the database)."""
    grid = await asyncio.to_thread(runtime.current_grid)  # rebuilt from the shared map: off the loop
    if grid is None:
        raise ApiError(status.HTTP_409_CONFLICT, "no_map", "there is no map yet")
    try:
        store.get_map(body.name)
        raise ApiError(status.HTTP_409_CONFLICT, "name_taken", f"a saved map named {body.name!r} exists")
    except db.NotFound:
        pass
    await asyncio.to_thread(save_map, grid, settings.maps_dir / body.name)
    await asyncio.to_thread(save_png, grid, map_file(settings.maps_dir, body.name, ".png"))
    try:
        record = store.add_map(body.name, grid.shape[1], grid.shape[0], grid.resolution).dict()
    except db.AlreadyExists as exc:
        raise ApiError(status.HTTP_409_CONFLICT, "name_taken", str(exc)) from None
    await runtime.rooms.save_as(body.name)
    await asyncio.to_thread(runtime.zones.save_as, body.name)
    return record


@router.post("/{name:name}/load", response_model=Status, dependencies=[NotReplaying],
             responses={202: {"model": Status, "description": "the worker is still switching"}})
async def create_map_load(runtime: RuntimeDep, store: StoreDep, response: Response,
                          name: MapNameParam) -> dict:
    """Localize on the saved map (switches to localization mode once its files check out)."""
    yaml_path = await checked_map_file(runtime, store, name)
    answer = await switch_mode(runtime, response, "localization", str(yaml_path), name)
    await runtime.use_map(name)
    return answer


@router.get("/{name:name}.png", response_class=Response, responses={200: {"content": {"image/png": {}}}})
async def read_map_png(runtime: RuntimeDep, store: StoreDep, name: MapNameParam) -> Response:
    """A saved map as a PNG picture."""
    grid = await load_saved_map(runtime, map_record(store, name).name)
    return Response(await asyncio.to_thread(png_bytes, grid), media_type="image/png")


@router.delete("/{name:name}", status_code=status.HTTP_204_NO_CONTENT, response_class=Response)
def delete_map(store: StoreDep, settings: SettingsDep, name: MapNameParam) -> Response:
    """Delete a saved map and its files."""
    record = map_record(store, name)
    store.delete_map(record.name)
    for suffix in MAP_SUFFIXES:
        map_file(settings.maps_dir, record.name, suffix).unlink(missing_ok=True)
    return Response(status_code=status.HTTP_204_NO_CONTENT)
