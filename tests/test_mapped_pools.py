"""Mapped pools grow in place, keeping their rows; a pool with another view is copied instead."""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.count_map import CountMap
from slam_core.mapped_pools import MappedPools
from slam_core.occupancy_grid import SensorModel
from slam_core.rbpf.tiled_map import TiledMaps


class Owner:
    pass


@settings(max_examples=30, deadline=None)
@given(lengths=st.lists(st.integers(0, 300), min_size=1, max_size=6),
       dtype=st.sampled_from([np.int32, np.float32]))
def test_growing_keeps_every_row_and_adds_zeros(lengths, dtype):
    owner = Owner()
    pools = MappedPools()
    owner.pool = pools.zeros("pool", (0, 3, 2), dtype)
    expected = np.zeros((0, 3, 2), dtype)
    rng = np.random.default_rng(len(lengths))
    for extra in lengths:
        pools.grow(owner, "pool", len(owner.pool) + extra)
        expected = np.concatenate([expected, np.zeros((extra, 3, 2), dtype)])
        assert owner.pool.dtype == dtype and np.array_equal(owner.pool, expected)
        rows = rng.integers(0, len(expected), 5) if len(expected) else []
        for r in rows:  # write some rows, as a pool's users do
            owner.pool[r] = expected[r] = r + 1


def test_a_pool_with_another_view_is_copied_and_the_view_keeps_its_values():
    owner = Owner()
    pools = MappedPools()
    owner.pool = pools.zeros("pool", (4, 2), np.float32)
    owner.pool[:] = np.arange(8).reshape(4, 2)
    view = owner.pool[1:3]
    pools.grow(owner, "pool", 6)
    assert np.array_equal(owner.pool[:4], np.arange(8).reshape(4, 2)) and not owner.pool[4:].any()
    owner.pool[1] = -1  # the copy is the owner's own
    assert np.array_equal(view, [[2, 3], [4, 5]])
    assert "pool" in pools and "other" not in pools


@pytest.mark.parametrize("make", [lambda: TiledMaps(2, 0.05, capacity=64),
                                  lambda: CountMap(0.05, SensorModel(), 5)], ids=["tiled maps", "count map"])
def test_an_owner_is_freed_as_soon_as_it_is_dropped(make):
    """No reference cycle: a loop closure's many submap maps go when dropped, not when the collector runs."""
    gc.disable()
    try:
        owner = make()
        gone = weakref.ref(owner)
        del owner
        assert gone() is None
    finally:
        gc.enable()
