"""PNG pictures of maps for people: grey unknown, white free, black walls, a red track."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from slam_core.io.caption import draw_caption
from slam_core.occupancy_grid import OccupancyGrid


def map_image(grid: OccupancyGrid) -> np.ndarray:
    """``uint8`` grey image of the occupancy probability, top row = largest y."""
    image = np.empty(grid.shape, np.uint8)
    for rows in grid.row_blocks():
        image[rows] = (255.0 * (1.0 - grid.probability(rows))).round().astype(np.uint8)
    return np.flipud(image)


def save_png(grid: OccupancyGrid, path, trajectory=None, caption: str | None = None) -> Path:
    """Write the map as PNG, with an optional ``(n, 2+)`` trajectory and a caption line."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    img = Image.fromarray(map_image(grid)).convert("RGB")
    draw = ImageDraw.Draw(img)
    if trajectory is not None and len(trajectory) > 1:
        cells = grid.world_to_cell(np.asarray(trajectory)[:, :2])
        ny = grid.shape[0]
        draw.line([(int(c[0]), ny - 1 - int(c[1])) for c in cells], fill=(220, 30, 30), width=1)
    if caption:
        draw_caption(draw, (4, 4), caption, (20, 20, 160))
    img.save(path)
    return path
