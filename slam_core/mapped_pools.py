"""Large pools in private anonymous memory of their own, grown in place.

A pool grown by copying holds its old rows twice for a moment; one grown by ``ndarray.resize``
zeroes (and so holds) its new rows at once. A pool here lives in an anonymous mapping: its pages
take memory only when first written, and growing it remaps the mapping (``mremap`` on Linux),
which neither copies nor touches the old rows.
"""

from __future__ import annotations

import mmap

import numpy as np


class MappedPools:
    """The mappings of an owner's pools, each pool an attribute of the owner by name. Only the owner
    may refer to a pool for :meth:`grow` to remap it; a pool that has another view (or a system
    without ``mremap``) is copied into a new mapping instead. The owner passes itself to
    :meth:`grow` (kept here, it would make a reference cycle: pools freed only by the collector)."""

    def __init__(self):
        self._memory: dict[str, mmap.mmap] = {}

    def __contains__(self, name: str) -> bool:
        return name in self._memory

    def zeros(self, name: str, shape: tuple[int, ...], dtype) -> np.ndarray:
        """A zeroed array of ``shape`` in a mapping of its own, for the owner's pool ``name``."""
        dtype = np.dtype(dtype)
        count = int(np.prod(shape))
        memory = mmap.mmap(-1, max(count * dtype.itemsize, 1), flags=mmap.MAP_PRIVATE)
        self._memory[name] = memory
        return np.frombuffer(memory, dtype, count).reshape(shape)

    def grow(self, owner: object, name: str, length: int) -> None:
        """Give ``owner.<name>`` ``length`` rows, the new ones zero."""
        array = owner.__dict__.pop(name)  # so that only this refers to it
        dtype, rows, shape = array.dtype, array.shape, (length, *array.shape[1:])
        count = int(np.prod(shape))
        memory = self._memory[name]
        try:
            del array
            memory.resize(max(count * dtype.itemsize, 1))
        except (BufferError, SystemError):  # another view of it; or no mremap (not Linux)
            old = np.frombuffer(memory, dtype, int(np.prod(rows))).reshape(rows)
            grown = self.zeros(name, shape, dtype)
            grown[:len(old)] = old
        else:
            grown = np.frombuffer(memory, dtype, count).reshape(shape)
        setattr(owner, name, grown)
