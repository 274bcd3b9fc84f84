"""Saved maps: save the current map under a name, list, load for localization, delete."""

import asyncio

from fastapi import APIRouter, HTTPException, Path, Response, status

from app.api.deps import RuntimeDep, SettingsDep, StoreDep
from app.api.models import MapBody, SavedMap, Status
from app.api.routes.map import png_bytes
from app.api.routes.mode import send_mode
from app.db import store as db
from app.db.names import check_name
from slam_core.io.render import save_png
from slam_core.io.ros_map import load_map, save_map

router = APIRouter(prefix="/maps", tags=["maps"])

MapName = Path(max_length=64)
MAP_SUFFIXES = (".pgm", ".yaml", ".png")


def _checked(name: str) -> str:
    try:
        return check_name(name, "map name")
    except ValueError as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from None


def _record(store: db.Store, name: str) -> db.MapRecord:
    try:
        return store.get_map(_checked(name))
    except db.NotFound as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc.args[0])) from None


@router.get("", response_model=list[SavedMap])
def read_maps(store: StoreDep) -> list[dict]:
    """All saved maps."""
    return [m.dict() for m in store.list_maps()]


@router.post("", response_model=SavedMap, status_code=status.HTTP_201_CREATED)
async def create_map(body: MapBody, runtime: RuntimeDep, store: StoreDep, settings: SettingsDep) -> dict:
    """Save the current map as ``name`` (PGM + YAML + PNG beside the database)."""
    grid = runtime.current_grid()
    if grid is None:
        raise HTTPException(status.HTTP_409_CONFLICT, "there is no map yet")
    try:
        store.get_map(body.name)
        raise HTTPException(status.HTTP_409_CONFLICT, f"a saved map named {body.name!r} exists")
    except db.NotFound:
        pass
    stem = settings.maps_dir / body.name
    await asyncio.to_thread(save_map, grid, stem)
    await asyncio.to_thread(save_png, grid, stem.with_suffix(".png"))
    try:
        record = store.add_map(body.name, grid.shape[1], grid.shape[0], grid.resolution).dict()
    except db.AlreadyExists as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None
    await runtime.rooms.save_as(body.name)
    await asyncio.to_thread(runtime.zones.save_as, body.name)
    return record


@router.post("/{name}/load", response_model=Status)
async def create_map_load(runtime: RuntimeDep, store: StoreDep, settings: SettingsDep,
                          name: str = MapName) -> dict:
    """Localize on the saved map (switches to localization mode)."""
    record = _record(store, name)
    yaml_path = settings.maps_dir / f"{record.name}.yaml"
    try:
        await asyncio.to_thread(load_map, yaml_path)
    except (OSError, ValueError) as exc:
        raise HTTPException(status.HTTP_409_CONFLICT,
                            f"saved map {record.name!r} is unreadable: {exc}") from None
    send_mode(runtime, "localization", str(yaml_path), record.name)
    await runtime.rooms.use_map(record.name)
    await asyncio.to_thread(runtime.zones.use_map, record.name)
    return runtime.status()


@router.get("/{name}.png", response_class=Response, responses={200: {"content": {"image/png": {}}}})
async def read_map_png(store: StoreDep, settings: SettingsDep, name: str = MapName) -> Response:
    """A saved map as a PNG picture."""
    record = _record(store, name)
    grid = await asyncio.to_thread(load_map, settings.maps_dir / f"{record.name}.yaml")
    return Response(await asyncio.to_thread(png_bytes, grid), media_type="image/png")


@router.delete("/{name}", status_code=status.HTTP_204_NO_CONTENT, response_class=Response)
def delete_map(store: StoreDep, settings: SettingsDep, name: str = MapName) -> Response:
    """Delete a saved map and its files."""
    record = _record(store, name)
    store.delete_map(record.name)
    for suffix in MAP_SUFFIXES:
        (settings.maps_dir / f"{record.name}{suffix}").unlink(missing_ok=True)
    return Response(status_code=status.HTTP_204_NO_CONTENT)
