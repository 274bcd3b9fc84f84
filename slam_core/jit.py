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

The particle filter's per-particle kernels are compiled serial and split over threads by
:func:`split`: a ``parallel=True`` kernel links and optimises a copy of everything it calls two
or three times more (the parallel body, its wrapper, the caller), which made the three filter
kernels ~8 s of a cold compile (``benchmarks/RESULTS.md``, "cold compile").

Kernels take no default arguments: numba's dispatcher matches a call's argument types in C, but
a call from Python that leaves arguments out goes through its Python path every time (0.4 ms a
call; 5,000 of the back end's searches on intel spent 2 s there).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numba

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

#: Options shared by every compiled kernel.
JIT_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}


def njit(*args, **kwargs):
    """``numba.njit`` with the project's defaults (cache on, GIL released); a kernel with default
    arguments is refused (``TypeError``)."""
    options = {**JIT_OPTIONS, **kwargs}
    if args and callable(args[0]):
        return numba.njit(**options)(_without_defaults(args[0]))
    compile_ = numba.njit(*args, **options)
    return lambda function: compile_(_without_defaults(function))


def _without_defaults(function):
    if function.__defaults__ or function.__kwdefaults__:
        raise TypeError(f"kernel {function.__qualname__} has default arguments: "
                        "pass them all (see slam_core.jit)")
    return function


_pool: ThreadPoolExecutor | None = None


def _forget_pool() -> None:
    global _pool
    _pool = None  # a forked child has none of its parent's threads


os.register_at_fork(after_in_child=_forget_pool)


def split(kernel, n: int, *args) -> None:
    """Run ``kernel(first, stop, *args)`` over ``range(n)`` in equal contiguous chunks, one per
    thread (numba's thread count), the first chunk on the calling thread. The kernel must release
    the GIL (``nogil``) and write only the outputs of its own items."""
    global _pool
    threads = max(min(numba.config.NUMBA_NUM_THREADS, n), 1)
    bounds = [n * i // threads for i in range(threads + 1)]
    if threads > 1 and _pool is None:
        _pool = ThreadPoolExecutor(numba.config.NUMBA_NUM_THREADS - 1, thread_name_prefix="split")
    others = [_pool.submit(kernel, bounds[i], bounds[i + 1], *args) for i in range(1, threads)]
    kernel(0, bounds[1], *args)
    for job in others:
        job.result()
