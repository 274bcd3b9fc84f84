"""Maps in the ROS map_server / Nav2 format: a PGM (or PNG) image plus a YAML file.

The YAML names ``image``, ``resolution`` (m/pixel), ``origin`` (x, y, yaw of the
*lower-left* pixel), ``negate``, ``occupied_thresh``, ``free_thresh`` and ``mode``.
Image row 0 is the top of the map, so rows are flipped against the grid, whose
row 0 is the bottom. In ``trinary`` mode homebot writes free 254, occupied 0 and
unknown 205, as map_saver does.

Reading follows map_server: with ``negate: 0`` a pixel's occupancy is
``p = (255 - value) / 255``; ``p > occupied_thresh`` is occupied, ``p < free_thresh``
free, anything between unknown (in ``scale`` mode, between values keep ``p``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml
from PIL import Image

from slam_core.occupancy_grid import FREE_THRESH, OCCUPIED_THRESH, OccupancyGrid, logit

FREE_VALUE = 254
OCCUPIED_VALUE = 0
UNKNOWN_VALUE = 205


class MapFileError(ValueError):
    """A map YAML or image that cannot be used, with the reason."""


def save_map(grid: OccupancyGrid, stem) -> tuple[Path, Path]:
    """Write ``stem.pgm`` and ``stem.yaml`` (trinary mode); returns both paths."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    trinary = grid.trinary()
    image = np.full(trinary.shape, UNKNOWN_VALUE, np.uint8)
    image[trinary == 0] = FREE_VALUE
    image[trinary == 100] = OCCUPIED_VALUE
    pgm = stem.with_suffix(".pgm")
    Image.fromarray(np.flipud(image)).save(pgm)
    meta = {
        "image": pgm.name,
        "mode": "trinary",
        "resolution": float(grid.resolution),
        "origin": [float(grid.origin[0]), float(grid.origin[1]), 0.0],
        "negate": 0,
        "occupied_thresh": OCCUPIED_THRESH,
        "free_thresh": FREE_THRESH,
    }
    yml = stem.with_suffix(".yaml")
    yml.write_text(yaml.safe_dump(meta, sort_keys=False, default_flow_style=None))
    return pgm, yml


def load_map(yaml_path) -> OccupancyGrid:
    """Read a map_server YAML and its image into an :class:`OccupancyGrid`.

    Occupied cells get the grid's upper clamp, free cells the lower one, unknown
    cells 0 (p = 0.5). A non-zero origin yaw is refused: homebot grids are axis-aligned.
    """
    yaml_path = Path(yaml_path)
    try:
        meta = yaml.safe_load(yaml_path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise MapFileError(f"{yaml_path}: cannot read map YAML ({exc})") from exc
    if not isinstance(meta, dict):
        raise MapFileError(f"{yaml_path}: map YAML must be a mapping")
    for key in ("image", "resolution", "origin"):
        if key not in meta:
            raise MapFileError(f"{yaml_path}: missing key {key!r}")
    try:
        resolution = float(meta["resolution"])
        origin = [float(v) for v in meta["origin"]]
        occ_th = float(meta.get("occupied_thresh", OCCUPIED_THRESH))
        free_th = float(meta.get("free_thresh", FREE_THRESH))
    except (TypeError, ValueError) as exc:
        raise MapFileError(f"{yaml_path}: resolution, origin and thresholds must be numbers ({exc})") from exc
    if not resolution > 0 or len(origin) != 3:
        raise MapFileError(f"{yaml_path}: need resolution > 0 and origin [x, y, yaw]")
    if abs(origin[2]) > 1e-9:
        raise MapFileError(f"{yaml_path}: rotated map origins (yaw {origin[2]}) are not supported")
    mode = meta.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        raise MapFileError(f"{yaml_path}: unknown mode {mode!r}")
    image_path = Path(meta["image"])
    if not image_path.is_absolute():
        image_path = yaml_path.parent / image_path
    try:
        with Image.open(image_path) as img:
            pixels = np.asarray(_to_gray(img), dtype=np.float64)
    except OSError as exc:
        raise MapFileError(f"{image_path}: cannot read map image ({exc})") from exc
    pixels = np.flipud(pixels)
    grid = OccupancyGrid(resolution, origin[:2], shape=pixels.shape)
    m = grid.model
    if mode == "raw":
        p = np.clip(pixels / 100.0, 0.0, 1.0)
        known = pixels <= 100
    else:
        p = pixels / 255.0 if meta.get("negate", 0) else (255.0 - pixels) / 255.0
        known = (p > occ_th) | (p < free_th) if mode == "trinary" else np.ones(p.shape, bool)
    data = np.zeros(pixels.shape, np.float32)
    data[known & (p > occ_th)] = m.l_max
    data[known & (p < free_th)] = m.l_min
    if mode != "trinary":
        between = known & (p >= free_th) & (p <= occ_th)
        data[between] = logit(np.clip(p[between], 1e-3, 1 - 1e-3))
    grid.data = data
    return grid


def _to_gray(img: Image.Image) -> Image.Image:
    if img.mode in ("L", "I", "I;16", "F"):
        return img
    if img.mode in ("LA", "RGBA", "RGB", "P"):
        return img.convert("L")
    return img.convert("L")
