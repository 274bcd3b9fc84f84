"""Names users give places and maps: safe as file names, no path traversal."""

from __future__ import annotations

import re

NAME_PATTERN = re.compile(r"[A-Za-z0-9_\-](?:[A-Za-z0-9 _\-.]{0,62}[A-Za-z0-9_\-.])?")


def check_name(name: str, what: str = "name") -> str:
    """Return ``name`` when it is acceptable, or raise ``ValueError`` saying what is allowed."""
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name) or ".." in name:
        raise ValueError(f"bad {what} {name!r}: use 1-64 letters, digits, spaces, '_', '-', '.'; "
                         "no '..', not starting with '.' or a space, not ending with a space")
    return name
