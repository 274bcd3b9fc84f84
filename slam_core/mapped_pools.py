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
    """The mapped pools of ``owner``, each an attribute of it by name. Only ``owner`` may refer to
    a pool for :meth:`grow` to remap it; a pool that has another view (or a system without
    ``mremap``) is copied into a new mapping instead."""

    def __init__(self, owner: object):
        self._owner = owner
        self._memory: dict[str, mmap.mmap] = {}

    def __contains__(self, name: str) -> bool:
        return name in self._memory

    def zeros(self, name: str, shape: tuple[int, ...], dtype) -> None:
        """Make ``owner.<name>`` a zeroed array of ``shape``, in a mapping of its own."""
        dtype = np.dtype(dtype)
        count = int(np.prod(shape))
        memory = mmap.mmap(-1, max(count * dtype.itemsize, 1), flags=mmap.MAP_PRIVATE)
        self._memory[name] = memory
        setattr(self._owner, name, np.frombuffer(memory, dtype, count).reshape(shape))

    def grow(self, name: str, length: int) -> None:
        """Give ``owner.<name>`` ``length`` rows, the new ones zero."""
        array = self._owner.__dict__.pop(name)  # so that only this refers to it
        dtype, rows, shape = array.dtype, array.shape, (length, *array.shape[1:])
        count = int(np.prod(shape))
        memory = self._memory[name]
        try:
            del array
            memory.resize(max(count * dtype.itemsize, 1))
        except (BufferError, SystemError):  # another view of it; or no mremap (not Linux)
            old = np.frombuffer(memory, dtype, int(np.prod(rows))).reshape(rows)
            self.zeros(name, shape, dtype)
            getattr(self._owner, name)[:len(old)] = old
            return
        setattr(self._owner, name, np.frombuffer(memory, dtype, count).reshape(shape))
