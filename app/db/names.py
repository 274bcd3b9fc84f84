"""Names users give places and maps: any script's letters, safe as file names, no path traversal.

A name is 1-64 characters of any script: letters, digits, spaces and punctuation, except a dot
(a dot would change a map file's suffix: ``home.bak`` must never touch ``home``), path separators,
the characters file systems refuse (``: * ? " < > |``) and control characters; no space at either
end; at most :data:`MAX_NAME_BYTES` in UTF-8, so that a name with the longest suffix homebot adds
(``.session.npz.partial``) stays within the 255-byte file-name limit of common file systems
(64 characters of most scripts fit; 50 emoji do). Names are compared in Unicode NFC form.

The rule is written as one regular expression that Python's ``re`` and ECMAScript's ``RegExp``
(JSON Schema's dialect: the OpenAPI schema, Swagger UI's "Try it out") read alike: the characters
left out are listed, so no engine's idea of a "word character" enters into it.
"""

from __future__ import annotations

import re
import unicodedata

MAX_NAME_LENGTH = 64
MAX_NAME_BYTES = 200
#: What a name never holds: dots, path separators, what file systems refuse, control characters
#: and UTF-16 surrogates (a lone one cannot be written to a file name).
_LEFT_OUT = r'/\\.:*?"<>|\x00-\x1f\x7f\ud800-\udfff'
#: The rule as a regular expression, read alike by Python ``re`` and ECMAScript ``RegExp``.
NAME_REGEX = rf"^[^\s{_LEFT_OUT}](?:[^{_LEFT_OUT}]{{0,62}}[^\s{_LEFT_OUT}])?$"
NAME_RULE = ("1-64 characters of any script (letters, digits, spaces, punctuation) except "
             "'.', '/', '\\', ':', '*', '?', '\"', '<', '>', '|' and control characters; "
             f"no space at either end; at most {MAX_NAME_BYTES} bytes in UTF-8")
_NAME = re.compile(NAME_REGEX)


def check_name(name: str, what: str = "name") -> str:
    """``name`` in NFC form when it is acceptable, else ``ValueError`` saying what is allowed."""
    if not isinstance(name, str):
        raise ValueError(f"bad {what}: a name is a string")
    normal = unicodedata.normalize("NFC", name)
    if not _NAME.fullmatch(normal) or len(normal.encode("utf-8", "surrogatepass")) > MAX_NAME_BYTES:
        shown = normal if len(normal) <= MAX_NAME_LENGTH else normal[:MAX_NAME_LENGTH] + "..."
        raise ValueError(f"bad {what} {shown!r}: use {NAME_RULE}")
    return normal
