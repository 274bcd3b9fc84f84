"""Progress bars for long commands (tqdm on stderr, quiet when not on a terminal)."""

from __future__ import annotations

from contextlib import contextmanager

from tqdm import tqdm


@contextmanager
def fraction_bar(description: str, unit: str = "%"):
    """A bar driven by a callback taking the fraction done (0..1)."""
    bar = tqdm(total=100, desc=description, unit=unit, leave=False, disable=None,
               bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}")

    def update(fraction: float) -> None:
        bar.update(max(0.0, 100.0 * fraction - bar.n))

    try:
        yield update
    finally:
        bar.close()


@contextmanager
def count_bar(description: str, total: int | None, unit: str):
    """A bar counting items (e.g. scans) with their rate and the time left."""
    bar = tqdm(total=total, desc=description, unit=unit, leave=False, disable=None)
    try:
        yield bar.update
    finally:
        bar.close()
