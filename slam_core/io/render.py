"""PNG pictures of maps for people: grey unknown, white free, black walls, a red track."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image, ImageDraw

from slam_core.io.caption import draw_caption
from slam_core.io.png_rows import PngRows
from slam_core.occupancy_grid import OccupancyGrid, probability

if TYPE_CHECKING:
    from slam_core.map_bands import MapBands


def grey(log_odds: np.ndarray) -> np.ndarray:
    """``uint8`` grey image of grid rows' occupancy probability, top row = largest y."""
    return np.flipud((255.0 * (1.0 - probability(log_odds))).round().astype(np.uint8))


def map_image(grid: OccupancyGrid) -> np.ndarray:
    """``uint8`` grey image of the occupancy probability, top row = largest y."""
    image = np.empty(grid.shape, np.uint8)
    for rows, log_odds in grid.bands():
        image[grid.shape[0] - rows.stop:grid.shape[0] - rows.start] = grey(log_odds)
    return image


def save_png(grid: OccupancyGrid | MapBands, path, trajectory=None, caption: str | None = None) -> Path:
    """Write the map as PNG, with an optional ``(n, 2+)`` trajectory and a caption line, a band of
    rows at a time (the bytes Pillow writes for the whole picture)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ny, nx = grid.shape
    track = []
    if trajectory is not None and len(trajectory) > 1:
        track = [(int(c[0]), ny - 1 - int(c[1])) for c in grid.world_to_cell(np.asarray(trajectory)[:, :2])]
    with PngRows(path, nx, ny) as png:
        for rows, log_odds in grid.bands():
            top = ny - rows.stop  # the band's first picture row
            img = Image.fromarray(grey(log_odds)).convert("RGB")
            draw = ImageDraw.Draw(img)
            if track:  # a width-1 line's pixels do not depend on where the picture is cut
                draw.line([(x, y - top) for x, y in track], fill=(220, 30, 30), width=1)
            if caption:
                draw_caption(draw, (4, 4 - top), caption, (20, 20, 160))
            png.write(np.asarray(img))
    return path
