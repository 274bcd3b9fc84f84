"""Coordinates the API accepts: inside the current map's bounds plus ``MAP_MARGIN_M``."""

from __future__ import annotations

from fastapi import status

from app.api.errors import ApiError
from app.runtime import Runtime

#: How far (m) outside the current map a pose or place may lie (the map grows as the robot explores).
MAP_MARGIN_M = 2.0


def require_in_map(runtime: Runtime, x: float, y: float, what: str) -> None:
    """422 ``outside_map`` unless (x, y) lies within the map's bounds plus the margin; 409 without a map."""
    snap = runtime.map_snapshot  # its bounds only: the grid is not rebuilt on the event loop
    if snap is None:
        raise ApiError(status.HTTP_409_CONFLICT, "no_map", "there is no map yet")
    x0, y0 = float(snap.origin[0]), float(snap.origin[1])
    x1 = x0 + snap.width * snap.resolution
    y1 = y0 + snap.height * snap.resolution
    if not (x0 - MAP_MARGIN_M <= x <= x1 + MAP_MARGIN_M and y0 - MAP_MARGIN_M <= y <= y1 + MAP_MARGIN_M):
        raise ApiError(status.HTTP_422_UNPROCESSABLE_CONTENT, "outside_map",
                       f"{what} ({x:.2f}, {y:.2f}) is outside the map: x {x0:.2f}..{x1:.2f}, "
                       f"y {y0:.2f}..{y1:.2f} m (plus {MAP_MARGIN_M:g} m)")
