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
from typing import TYPE_CHECKING

import numpy as np
import yaml
from PIL import Image

from slam_core.occupancy_grid import FREE_THRESH, OCCUPIED_THRESH, OccupancyGrid, logit, probability

if TYPE_CHECKING:
    from slam_core.map_bands import MapBands

FREE_VALUE = 254
OCCUPIED_VALUE = 0
UNKNOWN_VALUE = 205


class MapFileError(ValueError):
    """A map YAML or image that cannot be used: ``path`` (the file) and ``problem`` (what is wrong)."""

    path: Path
    problem: str


def save_map(grid: OccupancyGrid | MapBands, stem) -> tuple[Path, Path]:
    """Write ``stem.pgm`` and ``stem.yaml`` (trinary mode), a band of rows at a time; returns both paths."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    pgm = stem.with_suffix(".pgm")
    ny, nx = grid.shape
    with open(pgm, "wb") as out:
        out.write(b"P5\n%d %d\n255\n" % (nx, ny))  # as Pillow writes a grey PGM
        for _, log_odds in grid.bands():
            out.write(_trinary_pixels(log_odds).tobytes())
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


def _trinary_pixels(log_odds: np.ndarray) -> np.ndarray:
    """The image rows (top row first) of grid rows' log-odds: free, occupied or unknown."""
    p = probability(log_odds)
    image = np.full(p.shape, UNKNOWN_VALUE, np.uint8)
    image[p < FREE_THRESH] = FREE_VALUE
    image[p > OCCUPIED_THRESH] = OCCUPIED_VALUE
    return np.flipud(image)


#: Largest map image accepted (pixels), checked from the image header before any decoding.
MAX_MAP_CELLS = 4096 * 4096
#: Largest map YAML read (bytes); real ones are a few hundred.
MAX_YAML_BYTES = 64 * 1024
#: Origins farther than this from zero (m) are refused: no home is that large.
MAX_ORIGIN_M = 1e5
#: Resolutions accepted (m per pixel).
RESOLUTION_RANGE = (1e-4, 10.0)


def _problem(path: Path, problem: str) -> MapFileError:
    error = MapFileError(f"{path}: {problem}")
    error.path, error.problem = path, problem
    return error


def _read_meta(yaml_path: Path) -> dict:
    try:
        if yaml_path.stat().st_size > MAX_YAML_BYTES:
            raise _problem(yaml_path, f"map YAML larger than {MAX_YAML_BYTES} bytes")
        meta = yaml.safe_load(yaml_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else type(exc).__name__
        raise _problem(yaml_path, f"cannot read map YAML ({reason})") from exc
    if not isinstance(meta, dict):
        raise _problem(yaml_path, "map YAML must be a mapping")
    for key in ("image", "resolution", "origin"):
        if key not in meta:
            raise _problem(yaml_path, f"missing key {key!r}")
    if not isinstance(meta["image"], str) or not meta["image"]:
        raise _problem(yaml_path, "'image' must be a file name")
    return meta


def _number(yaml_path: Path, meta: dict, key: str, default=None) -> float:
    value = meta.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _problem(yaml_path, f"resolution, origin and thresholds must be numbers ({key}: {value!r})")
    if not np.isfinite(value):
        raise _problem(yaml_path, f"{key} must be finite, got {value}")
    return float(value)


def _checked_meta(yaml_path: Path, meta: dict) -> tuple[float, list[float], float, float, str]:
    """Resolution, origin, thresholds and mode, each finite and within range."""
    resolution = _number(yaml_path, meta, "resolution")
    origin = meta["origin"]
    if not isinstance(origin, list):
        raise _problem(yaml_path, f"resolution, origin and thresholds must be numbers (origin: {origin!r})")
    origin = [_number(yaml_path, {"origin": v}, "origin") for v in origin]
    occ_th = _number(yaml_path, meta, "occupied_thresh", OCCUPIED_THRESH)
    free_th = _number(yaml_path, meta, "free_thresh", FREE_THRESH)
    if not resolution > 0 or len(origin) != 3:
        raise _problem(yaml_path, "need resolution > 0 and origin [x, y, yaw]")
    if not RESOLUTION_RANGE[0] <= resolution <= RESOLUTION_RANGE[1]:
        raise _problem(yaml_path, f"resolution {resolution:g} m outside {RESOLUTION_RANGE[0]:g}.."
                                  f"{RESOLUTION_RANGE[1]:g}")
    if max(abs(origin[0]), abs(origin[1])) > MAX_ORIGIN_M:
        raise _problem(yaml_path, f"origin farther than {MAX_ORIGIN_M:g} m from zero")
    if abs(origin[2]) > 1e-9:
        raise _problem(yaml_path, f"rotated map origins (yaw {origin[2]:g}) are not supported")
    if not 0.0 <= free_th < occ_th <= 1.0:
        raise _problem(yaml_path, "need 0 <= free_thresh < occupied_thresh <= 1, "
                                  f"got {free_th:g}, {occ_th:g}")
    mode = meta.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        raise _problem(yaml_path, f"unknown mode {mode!r}")
    if meta.get("negate", 0) not in (0, 1):
        raise _problem(yaml_path, f"negate must be 0 or 1, got {meta.get('negate')!r}")
    return resolution, origin, occ_th, free_th, mode


def _read_pixels(image_path: Path, max_cells: int) -> np.ndarray:
    """The image as grey values, its size checked from the header before decoding."""
    try:
        with Image.open(image_path) as img:
            width, height = img.size
            if width * height > max_cells:
                raise _problem(image_path, f"map image {width} x {height} is too large (more than "
                                           f"{max_cells} cells)")
            return np.asarray(_to_gray(img), dtype=np.float64)
    except MapFileError:
        raise
    except Image.DecompressionBombError as exc:
        raise _problem(image_path, "map image is too large (decompression bomb)") from exc
    except Image.UnidentifiedImageError as exc:
        raise _problem(image_path, "cannot read map image (not a picture format homebot reads)") from exc
    except (OSError, SyntaxError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc) or type(exc).__name__
        reason = reason.replace(str(image_path), image_path.name)  # the caller decides how much path to show
        raise _problem(image_path, f"cannot read map image ({reason})") from exc


def load_map(yaml_path, max_cells: int = MAX_MAP_CELLS) -> OccupancyGrid:
    """Read a map_server YAML and its image into an :class:`OccupancyGrid`.

    Occupied cells get the grid's upper clamp, free cells the lower one, unknown
    cells 0 (p = 0.5). A non-zero origin yaw is refused: homebot grids are axis-aligned.
    Every field is checked (finite, in range) and the image's size is read from its
    header before it is decoded; any problem is a :class:`MapFileError` whose
    ``problem`` names it (``path`` is the file).
    """
    yaml_path = Path(yaml_path)
    meta = _read_meta(yaml_path)
    resolution, origin, occ_th, free_th, mode = _checked_meta(yaml_path, meta)
    image_path = Path(meta["image"])
    if not image_path.is_absolute():
        image_path = yaml_path.parent / image_path
    pixels = np.flipud(_read_pixels(image_path, max_cells))
    if pixels.ndim != 2 or pixels.size == 0:
        raise _problem(image_path, "map image must be a non-empty grey image")
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
