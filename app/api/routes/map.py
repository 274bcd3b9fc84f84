"""The live map as PNG and as ROS map_server PGM + YAML."""

import asyncio
import io
import tempfile
from pathlib import Path

from fastapi import APIRouter, Response, status
from PIL import Image

from app.api.deps import RuntimeDep
from app.api.errors import ApiError
from slam_core.io.render import map_image
from slam_core.io.ros_map import save_map
from slam_core.occupancy_grid import OccupancyGrid

router = APIRouter(prefix="/map", tags=["map"])


def _grid(runtime) -> OccupancyGrid:
    grid = runtime.current_grid()
    if grid is None:
        raise ApiError(status.HTTP_409_CONFLICT, "no_map", "there is no map yet")
    return grid


def png_bytes(grid: OccupancyGrid) -> bytes:
    out = io.BytesIO()
    Image.fromarray(map_image(grid)).save(out, format="PNG")
    return out.getvalue()


def ros_map_files(grid: OccupancyGrid) -> tuple[bytes, bytes]:
    with tempfile.TemporaryDirectory() as tmp:
        pgm, yml = save_map(grid, Path(tmp) / "map")
        return pgm.read_bytes(), yml.read_bytes()


@router.get(".png", response_class=Response, responses={200: {"content": {"image/png": {}}}})
async def read_map_png(runtime: RuntimeDep) -> Response:
    """The map as a PNG picture (white free, black walls, grey unknown; y up)."""
    data = await asyncio.to_thread(lambda: png_bytes(_grid(runtime)))
    return Response(data, media_type="image/png", headers={"Cache-Control": "no-store"})


@router.get(".pgm", response_class=Response, responses={200: {"content": {"image/x-portable-graymap": {}}}})
async def read_map_pgm(runtime: RuntimeDep) -> Response:
    """The map image of the ROS map_server format."""
    pgm, _ = await asyncio.to_thread(lambda: ros_map_files(_grid(runtime)))
    return Response(pgm, media_type="image/x-portable-graymap", headers={"Cache-Control": "no-store"})


@router.get(".yaml", response_class=Response, responses={200: {"content": {"application/yaml": {}}}})
async def read_map_yaml(runtime: RuntimeDep) -> Response:
    """The map metadata of the ROS map_server format (``image: map.pgm``)."""
    _, yml = await asyncio.to_thread(lambda: ros_map_files(_grid(runtime)))
    return Response(yml, media_type="application/yaml", headers={"Cache-Control": "no-store"})
