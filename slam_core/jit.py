"""The one place numba's flags are set.

Every kernel in slam_core is compiled through :func:`njit` so that caching and
fast-math choices stay consistent. ``cache=True`` writes the compiled machine
code next to the module, which keeps the second start of a command cheap.

The parallel kernels run on numba's OpenMP pool. OpenMP's default lets a worker that
finished its share spin for a while before sleeping; the filter launches several short
parallel kernels per update with Python work between them, so on a 2-core machine the
spinning worker took a core from the main thread and from other processes (see
``benchmarks/RESULTS.md``, "where intel's time goes"). Unless the environment says
otherwise, workers sleep at once (``OMP_WAIT_POLICY=PASSIVE``, read
when numba first loads its OpenMP pool, after this module is imported).
"""

from __future__ import annotations

import os

import numba

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

#: Options shared by every compiled kernel.
JIT_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}


def njit(*args, **kwargs):
    """``numba.njit`` with the project's defaults (cache on, GIL released)."""
    options = {**JIT_OPTIONS, **kwargs}
    if args and callable(args[0]):
        return numba.njit(**options)(args[0])
    return numba.njit(*args, **options)
