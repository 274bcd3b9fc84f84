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
