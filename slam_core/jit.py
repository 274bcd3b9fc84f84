"""The one place numba's flags are set.

Every kernel in slam_core is compiled through :func:`njit` so that caching and
fast-math choices stay consistent. ``cache=True`` writes the compiled machine
code next to the module, which keeps the second start of a command cheap.
"""

from __future__ import annotations

import numba

#: Options shared by every compiled kernel.
JIT_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}


def njit(*args, **kwargs):
    """``numba.njit`` with the project's defaults (cache on, GIL released)."""
    options = {**JIT_OPTIONS, **kwargs}
    if args and callable(args[0]):
        return numba.njit(**options)(args[0])
    return numba.njit(*args, **options)
