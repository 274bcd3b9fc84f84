"""A PNG of a localization run for people: the map, the trajectory, where the robot was lost.

The trajectory is drawn green where the localizer said *localized* and orange where
it did not; a red ring marks each place where it stopped being localized (lost or
carried off), a blue ring where it became localized again.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from slam_core.io.render import map_image
from slam_core.occupancy_grid import OccupancyGrid

LOCALIZED = (30, 160, 60)
NOT_LOCALIZED = (240, 140, 20)
LOST = (220, 30, 30)
FOUND = (40, 80, 220)
RING_PIXELS = 5


def save_run_png(grid: OccupancyGrid, poses: np.ndarray, localized: np.ndarray, path,
                 caption: str | None = None) -> Path:
    """Write the map with the per-scan ``poses`` (n, 3) coloured by the ``localized`` flags (n,)."""
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    flags = np.asarray(localized, dtype=bool).reshape(-1)
    if len(flags) != len(poses):
        raise ValueError(f"{len(poses)} poses but {len(flags)} localized flags")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    img = Image.fromarray(map_image(grid)).convert("RGB")
    draw = ImageDraw.Draw(img)
    ny = grid.shape[0]
    cells = grid.world_to_cell(poses[:, :2]) if len(poses) else np.zeros((0, 2), int)
    points = [(int(c[0]), ny - 1 - int(c[1])) for c in cells]
    for i in range(1, len(points)):
        draw.line([points[i - 1], points[i]], fill=LOCALIZED if flags[i] else NOT_LOCALIZED, width=1)
    changes = np.flatnonzero(np.diff(flags.astype(np.int8)))
    for i in changes + 1:
        x, y = points[i]
        colour = FOUND if flags[i] else LOST
        draw.ellipse([x - RING_PIXELS, y - RING_PIXELS, x + RING_PIXELS, y + RING_PIXELS], outline=colour,
                     width=2)
    if caption:
        draw.text((4, 4), caption, fill=(20, 20, 160))
    img.save(path)
    return path
