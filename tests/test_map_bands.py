"""The final map by row bands (slam_core.map_bands) and the map files written from bands: the same cells
as CountMap's grid, and the bytes Pillow writes for the whole picture."""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image, ImageDraw, features

from slam_core.count_map import CountMap
from slam_core.io.caption import draw_caption
from slam_core.io.png_rows import PngRows
from slam_core.io.render import map_image, save_png
from slam_core.io.ros_map import FREE_VALUE, OCCUPIED_VALUE, UNKNOWN_VALUE, save_map
from slam_core.map_bands import MapBands
from tests.test_count_map import MODEL, RES, SIZE, updates


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**16), n=st.integers(1, 13), band_cells=st.sampled_from([1, 500, 4000, 1 << 21]))
def test_the_bands_make_the_count_maps_grid_cell_for_cell(seed, n, band_cells):
    """Bands of one row up to the whole map, over submaps that are whole, partial, or one update."""
    poses, scans = updates(seed, n)
    counts = CountMap(RES, MODEL, SIZE)
    counts.update(poses, scans)
    expected, bands = counts.grid(), MapBands(poses, scans, RES, MODEL, SIZE, band_cells)
    mine = bands.grid()
    assert mine.shape == expected.shape == bands.shape and np.array_equal(mine.origin, expected.origin)
    np.testing.assert_array_equal(mine.data, expected.data)
    assert np.count_nonzero(mine.data) > 100
    cells = np.random.default_rng(seed).uniform(-3, 3, (50, 2))
    np.testing.assert_array_equal(bands.world_to_cell(cells), expected.world_to_cell(cells))


def test_no_updates_make_an_empty_map_and_bad_input_is_refused():
    empty = MapBands(np.zeros((0, 3)), [], RES, MODEL, SIZE)
    assert empty.shape == (0, 0) and empty.grid().data.size == 0 and list(empty.bands()) == []
    poses, scans = updates(4, 5)
    with pytest.raises(ValueError, match="poses for"):
        MapBands(poses[:3], scans, RES, MODEL, SIZE)


def pillow_map_files(grid, folder, track, caption):
    """The map files as homebot wrote them with Pillow, from the whole grid."""
    trinary = grid.trinary()
    image = np.full(trinary.shape, UNKNOWN_VALUE, np.uint8)
    image[trinary == 0] = FREE_VALUE
    image[trinary == 100] = OCCUPIED_VALUE
    Image.fromarray(np.flipud(image)).save(folder / "map.pgm")
    img = Image.fromarray(map_image(grid)).convert("RGB")
    draw = ImageDraw.Draw(img)
    ny = grid.shape[0]
    draw.line([(int(c[0]), ny - 1 - int(c[1])) for c in grid.world_to_cell(track[:, :2])], fill=(220, 30, 30),
              width=1)
    draw_caption(draw, (4, 4), caption, (20, 20, 160))
    img.save(folder / "map.png")


@pytest.mark.parametrize("band_cells", [300, 7000, 1 << 21])
def test_map_files_written_by_bands_are_pillows_bytes_for_the_whole_map(tmp_path, band_cells):
    """PGM and PNG (a track crossing the bands, a caption of two lines over a band's edge) from bands
    of a few rows to one band, and from an OccupancyGrid, against Pillow's writes of the whole grid."""
    poses, scans = updates(7, 13)
    bands = MapBands(poses, scans, RES, MODEL, SIZE, band_cells)
    grid = bands.grid()
    track = np.vstack([poses, poses[::-1] + 0.3])
    caption = "homebot RBPF SLAM - a caption long enough to wrap over two lines"
    (tmp_path / "pillow").mkdir()
    pillow_map_files(grid, tmp_path / "pillow", track, caption)
    for name, source in (("bands", bands), ("grid", grid)):
        save_map(source, tmp_path / name / "map")
        save_png(source, tmp_path / name / "map.png", track, caption)
        pgm = (tmp_path / name / "map.pgm").read_bytes()
        assert pgm == (tmp_path / "pillow" / "map.pgm").read_bytes(), name
        assert_same_png(tmp_path / name / "map.png", tmp_path / "pillow" / "map.png")
    pixels = np.asarray(Image.open(tmp_path / "bands" / "map.png")).reshape(-1, 3)
    assert all((pixels == colour).all(axis=1).any() for colour in ((220, 30, 30), (20, 20, 160)))


def pictures():
    rng = np.random.default_rng(5)
    noise = rng.integers(0, 256, (40, 37, 3), dtype=np.uint8)
    smooth = np.cumsum(rng.integers(0, 3, (40, 37, 3)), axis=1).astype(np.uint8)
    flat = np.full((40, 37, 3), 205, np.uint8)
    mixed = np.vstack([flat[:5], smooth[:9], smooth[8:9].repeat(4, 0), noise[:6], flat[:3], smooth[20:]])
    wide = rng.integers(0, 4, (3, 16500, 3), dtype=np.uint8) * 60  # IDAT chunks of 4 * width bytes
    large = np.kron(rng.integers(0, 2, (40, 40, 1), dtype=np.uint8) * 250, np.ones((8, 8, 3), np.uint8))
    return [noise, smooth, flat, mixed, wide, large, noise[:1, :1]]


@pytest.mark.parametrize("picture", pictures(), ids=lambda p: f"{p.shape[1]}x{p.shape[0]}")
def test_a_png_written_by_rows_is_pillows_bytes(tmp_path, picture):
    Image.fromarray(picture).save(tmp_path / "pillow.png")
    cuts = np.random.default_rng(picture.size).integers(0, len(picture) + 1, 3)
    with PngRows(tmp_path / "rows.png", picture.shape[1], picture.shape[0]) as png:
        for part in np.split(picture, np.sort(cuts)):
            png.write(part)
    assert_same_png(tmp_path / "rows.png", tmp_path / "pillow.png")


def assert_same_png(mine, pillows) -> None:
    """The same picture; byte for byte too where Pillow compresses with Python's zlib (this
    machine's; a Pillow that bundles another zlib compresses the same rows into other bytes)."""
    with Image.open(mine) as a, Image.open(pillows) as b:
        assert a.mode == b.mode and np.array_equal(np.asarray(a), np.asarray(b))
    if features.version("zlib") == zlib.ZLIB_RUNTIME_VERSION:
        assert Path(mine).read_bytes() == Path(pillows).read_bytes()


def test_a_png_missing_rows_is_refused(tmp_path):
    with pytest.raises(ValueError, match="1 rows written of 2"), PngRows(tmp_path / "a.png", 3, 2) as png:
        png.write(np.zeros((1, 3, 3), np.uint8))
