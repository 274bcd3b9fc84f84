"""The compiled kernels' shared settings: OpenMP workers that sleep when idle unless told otherwise;
work split over threads."""

import os
import subprocess
import sys

import pytest


@pytest.mark.parametrize(("given", "expected"), [(None, "PASSIVE"), ("ACTIVE", "ACTIVE")])
def test_openmp_workers_sleep_unless_the_environment_says_otherwise(given, expected):
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if given is not None:
        env["OMP_WAIT_POLICY"] = given
    code = "import os, slam_core.jit; print(os.environ['OMP_WAIT_POLICY'])"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == expected


@pytest.mark.parametrize("n", [0, 1, 2, 7, 30])
def test_split_covers_every_item_once_in_contiguous_chunks(n):
    from slam_core.jit import split

    seen = []

    def kernel(first, stop, out):
        out.append((first, stop))

    split(kernel, n, seen)
    chunks = sorted(seen)
    assert [i for first, stop in chunks for i in range(first, stop)] == list(range(n))


def test_split_raises_what_a_chunk_raised():
    from slam_core.jit import split

    def kernel(first, stop):
        if stop == 10:  # the last chunk: on another thread wherever there are two
            raise ValueError("last chunk")

    with pytest.raises(ValueError, match="last chunk"):
        split(kernel, 10)


@pytest.mark.parametrize("options", [{}, {"inline": "always"}])
def test_a_kernel_with_default_arguments_is_refused(options):
    """A call that leaves arguments out takes numba's slow dispatch path every time."""
    from slam_core.jit import njit

    def kernel(a, b=1.0):
        return a + b

    def whole(a, b):
        return a + b

    with pytest.raises(TypeError, match="default arguments"):
        njit(kernel) if not options else njit(**options)(kernel)
    assert (njit(whole) if not options else njit(**options)(whole))(1.0, 2.0) == 3.0
