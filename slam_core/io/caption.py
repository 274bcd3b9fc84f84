"""Caption lines on map pictures that show every letter: ä and ü, not boxes.

Pillow's built-in font has no glyph for most non-ASCII letters and draws its "missing" box instead.
The caption uses DejaVu Sans when the system has it (Debian's ``fonts-dejavu-core``); otherwise a
letter the font lacks is written without its accent (``ä`` -> ``a``), which reads better than a box.
"""

from __future__ import annotations

import unicodedata
from functools import cache

from PIL import ImageDraw, ImageFont

CAPTION_SIZE = 11
SYSTEM_FONT = "DejaVuSans.ttf"
#: A code point no font has a glyph for: what the font draws for a missing letter.
MISSING = "\uffff"


@cache
def caption_font() -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    try:
        return ImageFont.truetype(SYSTEM_FONT, CAPTION_SIZE)
    except OSError:
        return ImageFont.load_default(size=CAPTION_SIZE)


def _glyph(font, text: str) -> bytes:
    mask = font.getmask(text)
    return bytes(mask) + bytes(str(mask.size), "ascii")


def drawable(text: str, font=None) -> str:
    """``text`` with every letter ``font`` cannot draw replaced by its unaccented form."""
    font = font or caption_font()
    missing = _glyph(font, MISSING)
    out = []
    for ch in text:
        if ch.isascii() or _glyph(font, ch) != missing:
            out.append(ch)
        else:
            plain = "".join(c for c in unicodedata.normalize("NFKD", ch) if not unicodedata.combining(c))
            out.append(plain if plain.isascii() and plain else "?")
    return "".join(out)


def wrapped(text: str, width: float, font=None) -> list[str]:
    """``text`` broken at spaces into lines no wider than ``width`` pixels (a word longer than
    that stands on a line of its own)."""
    font = font or caption_font()
    lines: list[str] = []
    for word in text.split():
        if lines and font.getlength(f"{lines[-1]} {word}") <= width:
            lines[-1] = f"{lines[-1]} {word}"
        else:
            lines.append(word)
    return lines


def draw_caption(draw: ImageDraw.ImageDraw, xy: tuple[int, int], text: str, fill) -> None:
    """Draw a caption at ``xy`` (top left) with a font that shows its letters, wrapped to the
    picture's width."""
    font = caption_font()
    width = draw.im.size[0] - xy[0] - 4
    for row, line in enumerate(wrapped(drawable(text, font), width, font)):
        draw.text((xy[0], xy[1] + row * (CAPTION_SIZE + 3)), line, fill=fill, font=font)
