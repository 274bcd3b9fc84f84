"""Captions on map pictures draw every letter of the data credit (no "missing glyph" boxes)."""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from slam_core.datasets import CREDIT
from slam_core.io.caption import MISSING, _glyph, caption_font, drawable, wrapped
from slam_core.io.render import save_png
from slam_core.occupancy_grid import OccupancyGrid


def _all_drawn(text: str, font) -> bool:
    missing = _glyph(font, MISSING)
    return all(ch == " " or _glyph(font, ch) != missing for ch in text)


def test_the_credit_is_drawn_letter_for_letter_or_without_accents():
    assert "ä" in CREDIT
    for font in (caption_font(), ImageFont.load_default(size=11)):
        shown = drawable(CREDIT, font)
        assert _all_drawn(shown, font), shown
        assert len(shown) == len(CREDIT)
        for before, after in zip(CREDIT, shown, strict=True):
            assert after == before or (not before.isascii() and after.isascii() and after.isalpha())


def test_a_map_picture_with_the_credit_has_no_box_where_the_umlaut_is(tmp_path):
    grid = OccupancyGrid(0.05, (0, 0), shape=(60, 400))
    umlaut = np.asarray(Image.open(save_png(grid, tmp_path / "a.png", caption="Dirk Hähnel")).convert("L"))
    # The same caption with the font's "missing" box where the ä is, drawn the way the picture is.
    boxed = Image.open(save_png(grid, tmp_path / "b.png")).convert("RGB")
    ImageDraw.Draw(boxed).text((4, 4), f"Dirk H{MISSING}hnel", fill=(20, 20, 160), font=caption_font())
    assert (umlaut[:20] < 150).sum() > 30  # the caption is there
    assert not np.array_equal(umlaut, np.asarray(boxed.convert("L")))


def test_a_caption_wider_than_the_picture_wraps_onto_lines_that_fit():
    font = caption_font()
    width = 120
    lines = wrapped(CREDIT, width, font)
    assert len(lines) > 1 and " ".join(lines) == " ".join(CREDIT.split())
    for line in lines:
        assert font.getlength(line) <= width or " " not in line, line


def test_a_narrow_picture_shows_its_whole_caption(tmp_path):
    grid = OccupancyGrid(0.05, (0, 0), shape=(200, 100))  # 100 px wide, the credit is far wider
    picture = np.asarray(Image.open(save_png(grid, tmp_path / "n.png", caption=CREDIT)).convert("RGB"))
    ink = (picture[..., 2] > 120) & (picture[..., 0] < 80)  # the caption's blue
    rows = np.flatnonzero(ink.any(axis=1))
    assert rows.max() - rows.min() > 2 * 11  # more than two lines of text
    assert not ink[:, -3:].any()  # nothing drawn into the right edge: it wrapped, it was not cut
