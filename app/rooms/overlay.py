"""The rooms as the dashboard draws them: a colour per room and a translucent RGBA picture."""

from __future__ import annotations

import base64
import colorsys
import io

import numpy as np
from PIL import Image

from slam_core.rooms.layout import RoomLayout

#: Opacity of the room colours over the map.
ALPHA = 110
GOLDEN = 0.381966


def room_colour(room: int) -> tuple[int, int, int]:
    """A distinct, stable colour per room id (hues a golden angle apart)."""
    r, g, b = colorsys.hsv_to_rgb((room * GOLDEN) % 1.0, 0.55, 0.95)
    return round(r * 255), round(g * 255), round(b * 255)


def overlay(layout: RoomLayout | None, labels_at: dict[int, tuple[float, float]]) -> dict:
    """``{origin, resolution, width, height, image, rooms}``; the PNG's row 0 is the grid's row 0
    (smallest y), as the dashboard draws map tiles. ``labels_at`` is where each room's name goes."""
    if layout is None or not layout.ids():
        return {"origin": [0.0, 0.0], "resolution": 0.05, "width": 0, "height": 0, "image": None, "rooms": []}
    ids = layout.ids()
    palette = np.zeros((int(layout.labels.max()) + 1, 4), np.uint8)
    for room in ids:
        palette[room] = (*room_colour(room), ALPHA)
    rgba = palette[layout.labels]
    out = io.BytesIO()
    Image.fromarray(rgba, "RGBA").save(out, format="PNG", optimize=True)
    ny, nx = layout.labels.shape
    return {"origin": list(layout.origin), "resolution": layout.resolution, "width": nx, "height": ny,
            "image": "data:image/png;base64," + base64.b64encode(out.getvalue()).decode("ascii"),
            "rooms": [{"id": room, "name": layout.name(room), "colour": "#{:02x}{:02x}{:02x}".format(
                *room_colour(room)), "label": [round(v, 3) for v in labels_at[room]]} for room in ids]}
