"""Where a saved map's files live and whether they can be used, without leaking server paths."""

from __future__ import annotations

import asyncio
from pathlib import Path

from fastapi import status

from app.api.errors import ApiError
from app.db import store as db
from app.runtime import Runtime
from slam_core.io.ros_map import MapFileError, load_map
from slam_core.occupancy_grid import OccupancyGrid

#: The files of one saved map: ``maps/NAME.pgm``, ``.yaml``, ``.png`` (names have no dots, so no clash).
MAP_SUFFIXES = (".pgm", ".yaml", ".png")


def map_file(maps_dir: Path, name: str, suffix: str = ".yaml") -> Path:
    """One file of a saved map (``name`` passed :func:`app.db.names.check_name`: no dots, no slashes)."""
    return maps_dir / f"{name}{suffix}"


def map_record(store: db.Store, name: str) -> db.MapRecord:
    try:
        return store.get_map(name)
    except db.NotFound as exc:
        raise ApiError(status.HTTP_404_NOT_FOUND, "not_found", str(exc.args[0])) from None


async def load_saved_map(runtime: Runtime, name: str) -> OccupancyGrid:
    """The saved map's grid; 409 ``map_unreadable`` naming the problem (never an absolute path)."""
    yaml_path = map_file(runtime.settings.maps_dir, name)
    try:
        return await asyncio.to_thread(load_map, yaml_path, runtime.settings.map_capacity_cells)
    except MapFileError as exc:
        raise ApiError(status.HTTP_409_CONFLICT, "map_unreadable",
                       f"saved map {name!r} cannot be used: {exc.path.name}: {exc.problem}") from None


async def checked_map_file(runtime: Runtime, store: db.Store, name: str) -> Path:
    """The YAML of a saved map that exists (404) and loads (409), for the worker to read."""
    record = map_record(store, name)
    await load_saved_map(runtime, record.name)
    return map_file(runtime.settings.maps_dir, record.name)
