"""Names users give places and maps: any script's letters, safe as file names, no path traversal.

A name is 1-64 characters: letters of any script, digits, ``_``, ``-`` and inner spaces. No dots
(a dot would change a map file's suffix: ``home.bak`` must never touch ``home``), no path
separators, no control characters. Names are compared in Unicode NFC form.
"""

from __future__ import annotations

import re
import unicodedata

MAX_NAME_LENGTH = 64
#: The rule as a regular expression (Python ``re``; ``\\w`` is any script's letters, digits and ``_``).
NAME_REGEX = r"^\w(?:[\w \-]{0,62}[\w\-])?$"
NAME_RULE = ("1-64 letters (any script), digits, '_', '-' and spaces; no dots, no slashes, "
             "no space at either end")
_NAME = re.compile(NAME_REGEX)


def check_name(name: str, what: str = "name") -> str:
    """``name`` in NFC form when it is acceptable, else ``ValueError`` saying what is allowed."""
    if not isinstance(name, str):
        raise ValueError(f"bad {what}: a name is a string")
    normal = unicodedata.normalize("NFC", name)
    if not _NAME.fullmatch(normal):
        shown = normal if len(normal) <= MAX_NAME_LENGTH else normal[:MAX_NAME_LENGTH] + "..."
        raise ValueError(f"bad {what} {shown!r}: use {NAME_RULE}")
    return normal
