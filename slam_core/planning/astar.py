"""A* on a costmap: 8-connected, octile heuristic, no corner cutting (Hart, Nilsson & Raphael, 1968).

Moving from cell ``a`` to its neighbour ``b`` costs ``|a - b| * w[b]`` in cell
units, with ``|a - b|`` = 1 (orthogonal) or ``diagonal_step`` (``sqrt(2)``), and
``w >= 1`` the costmap weight (``inf`` = never entered). A diagonal move is
allowed only if both orthogonal cells it squeezes between are traversable.
Because ``w >= 1`` the octile distance ``max(dx, dy) + (diagonal_step - 1) *
min(dx, dy)`` is an admissible, consistent heuristic, so a cell's cost is final
when it leaves the open list (a binary heap with lazy deletion, see ``_search``).
With ``diagonal_step=1, corner_cutting=True`` the rules are pyastar2d's (the
benchmark compares the two on those).

Ties on ``f = g + h`` go to the cell nearer the goal: the heuristic is scaled
by ``1 + TIE_BREAK``, which bounds the returned cost to within a relative
``TIE_BREAK`` of optimal and avoids expanding whole plateaus of equal ``f``.

The search polls a one-element ``uint8`` cancel flag every ``CANCEL_POLL``
expansions; another thread sets it (the kernel runs without the GIL).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from slam_core.jit import njit
from slam_core.planning.costmap import Costmap

SQRT2 = math.sqrt(2.0)
#: Relative heuristic inflation that breaks ties toward the goal.
TIE_BREAK = 1e-9
#: Expansions between two reads of the cancel flag.
CANCEL_POLL = 1024
#: Initial binary-heap capacity (it doubles when full).
HEAP_CAPACITY = 1 << 14
#: Entries of the bypass stack (successors expanded without touching the heap).
BYPASS_CAPACITY = 1 << 12

FOUND = 0
UNREACHABLE = 1
CANCELLED = 2
HEAP_FULL = 3

#: Open-list entries hold a cell as ``(y << XY_SHIFT) | x`` (exact in float64), not its index,
#: so no division by the row length is needed when it is popped.
XY_SHIFT = 24
XY_MASK = (1 << XY_SHIFT) - 1

_DX = np.array([1, -1, 0, 0, 1, 1, -1, -1], np.int64)
_DY = np.array([0, 0, 1, -1, 1, -1, 1, -1], np.int64)


@njit(inline="always")
def _sift_up(heap, i):
    """Move entry ``i`` of the interleaved heap ``[key0, cell0, key1, cell1, ...]`` up."""
    key = heap[2 * i]
    val = heap[2 * i + 1]
    while i > 0:
        p = (i - 1) >> 1
        if heap[2 * p] <= key:
            break
        heap[2 * i] = heap[2 * p]
        heap[2 * i + 1] = heap[2 * p + 1]
        i = p
    heap[2 * i] = key
    heap[2 * i + 1] = val


@njit(inline="always")
def _pop_top(heap, size):
    """Drop entry 0; ``size`` entries remain, the last of which sits at index ``size``.

    Floyd's bottom-up deletion: the hole walks down to a leaf along the smaller
    children (one comparison per level, no unpredictable branch), then the last
    entry climbs back up.
    """
    key = heap[2 * size]
    val = heap[2 * size + 1]
    heap[2 * size] = np.inf  # sentinel: a missing right child never wins
    i = 0
    while True:
        c = 2 * i + 1
        if c >= size:
            break
        c += heap[2 * c + 2] < heap[2 * c]  # branch-free choice of the smaller child
        heap[2 * i] = heap[2 * c]
        heap[2 * i + 1] = heap[2 * c + 1]
        i = c
    heap[2 * i] = key
    heap[2 * i + 1] = val
    _sift_up(heap, i)


@njit(inline="always")
def _octile(x, y, gx, gy, diagonal_step):
    ax = abs(x - gx)
    ay = abs(y - gy)
    if ax > ay:
        return ax + (diagonal_step - 1.0) * ay
    return ay + (diagonal_step - 1.0) * ax


@njit
def _search(w, nxp, goal, diagonal_step, corner_cutting, cancel, g, parent, heap, size, stack, top,
            expansions):
    """The A* loop over flat padded weights ``w`` (row length ``nxp``, ``inf`` border).

    Resumable: returns ``(status, size, top, expansions)`` with status
    ``HEAP_FULL`` when ``heap`` must grow (growing inside this loop would make
    numba reference-count the reassigned array on every iteration).

    No closed set: an entry is stale when its key is no longer the cell's
    current ``f`` (a cell's key is recomputed by the same expression, so the
    live entry matches exactly). The heuristic is consistent, so an expanded
    cell is not improved again (if the ``TIE_BREAK`` scaling ever allowed a
    tiny improvement, the cell would simply be pushed and expanded again).

    Bypass: a successor whose key is not above the key being expanded would be
    the very next heap minimum (``f`` never decreases along a path), so it goes
    on a small LIFO ``stack`` expanded before the heap is touched again. In
    open space most moves toward the goal keep ``f`` constant, so most cells
    skip the heap's ``O(log n)`` push and pop.
    """
    gx = goal % nxp
    gy = goal // nxp
    h_scale = 1.0 + TIE_BREAK
    offs = _DX + _DY * nxp
    capacity = heap.shape[0] // 2
    stack_capacity = stack.shape[0] // 2
    while size > 0 or top > 0:
        if size + 8 > capacity:
            return HEAP_FULL, size, top, expansions
        if top > 0:
            top -= 1
            key = stack[2 * top]
            code = np.int64(stack[2 * top + 1])
        else:
            key = heap[0]
            code = np.int64(heap[1])
            size -= 1
            if size > 0:
                _pop_top(heap, size)
        cx = code & XY_MASK
        cy = code >> XY_SHIFT
        cur = cy * nxp + cx
        gc = g[cur]
        if key != gc + h_scale * _octile(cx, cy, gx, gy, diagonal_step):
            continue
        if cur == goal:
            return FOUND, size, top, expansions
        expansions += 1
        if (expansions & (CANCEL_POLL - 1)) == 0 and cancel[0] != 0:
            return CANCELLED, size, top, expansions
        for k in range(8):
            nb = cur + offs[k]
            wn = w[nb]
            if wn == np.inf:
                continue
            if k < 4:
                ng = gc + wn
            else:
                if not corner_cutting and (w[cur + _DX[k]] == np.inf or w[cur + _DY[k] * nxp] == np.inf):
                    continue
                ng = gc + diagonal_step * wn
            if ng < g[nb]:
                g[nb] = ng
                parent[nb] = cur
                nx_ = cx + _DX[k]
                ny_ = cy + _DY[k]
                nkey = ng + h_scale * _octile(nx_, ny_, gx, gy, diagonal_step)
                ncode = (ny_ << XY_SHIFT) | nx_
                if nkey <= key and top < stack_capacity:
                    stack[2 * top] = nkey
                    stack[2 * top + 1] = ncode
                    top += 1
                else:
                    heap[2 * size] = nkey
                    heap[2 * size + 1] = ncode
                    _sift_up(heap, size)
                    size += 1
    return UNREACHABLE, size, top, expansions


@njit
def _astar_kernel(w, nxp, start, goal, diagonal_step, corner_cutting, cancel):
    """A* from padded index ``start`` to ``goal``.

    Returns ``(status, expansions, path, g)``: ``path`` the padded indices from
    start to goal (empty unless found), ``g`` the best known cost of every
    reached cell (exact for every expanded cell).
    """
    n = w.shape[0]
    g = np.full(n, np.inf)
    parent = np.empty(n, np.int32)
    # Keys and cells interleaved in one float64 array (cells < 2**53 are exact):
    # one cache line per heap level instead of two.
    heap = np.empty(2 * HEAP_CAPACITY, np.float64)
    g[start] = 0.0
    parent[start] = start
    heap[0] = (1.0 + TIE_BREAK) * _octile(start % nxp, start // nxp, goal % nxp, goal // nxp, diagonal_step)
    heap[1] = ((start // nxp) << XY_SHIFT) | (start % nxp)
    size = 1
    stack = np.empty(2 * BYPASS_CAPACITY, np.float64)
    top = 0
    expansions = 0
    status = HEAP_FULL
    while status == HEAP_FULL:
        status, size, top, expansions = _search(w, nxp, goal, diagonal_step, corner_cutting, cancel, g,
                                                parent, heap, size, stack, top, expansions)
        if status == HEAP_FULL:
            heap = np.concatenate((heap, np.empty_like(heap)))
    if status != FOUND:
        return status, expansions, np.empty(0, np.int64), g
    length = 1
    c = goal
    while c != start:
        c = parent[c]
        length += 1
    path = np.empty(length, np.int64)
    c = goal
    for i in range(length - 1, -1, -1):
        path[i] = c
        c = parent[c]
    return status, expansions, path, g


@dataclass
class SearchResult:
    """What one A* search found; ``cells`` are ``(ix, iy)`` rows from start to goal."""

    status: int
    cells: np.ndarray
    cost: float
    expansions: int
    settled_cost: np.ndarray

    @property
    def found(self) -> bool:
        return self.status == FOUND

    @property
    def cancelled(self) -> bool:
        return self.status == CANCELLED

    def reachable(self) -> np.ndarray:
        """Cells reached from the start; the whole connected region after an exhausted search."""
        return np.isfinite(self.settled_cost)


def new_cancel_flag() -> np.ndarray:
    """A flag the search polls: set ``flag[0] = 1`` from any thread to stop it."""
    return np.zeros(1, np.uint8)


def astar(costmap: Costmap, start, goal, *, diagonal_step: float = SQRT2, corner_cutting: bool = False,
          cancel: np.ndarray | None = None) -> SearchResult:
    """Cheapest 8-connected path between cells ``start`` and ``goal`` (``(ix, iy)``).

    ``cost`` is in cell units (multiply by the resolution for metres);
    ``inf`` with empty ``cells`` when the goal is unreachable or the search was
    cancelled. The start cell's own weight is never paid, so a search may begin
    on an impassable cell.
    """
    ny, nx = costmap.shape
    for name, c in (("start", start), ("goal", goal)):
        if not costmap.contains_cell(int(c[0]), int(c[1])):
            raise ValueError(f"{name} cell {tuple(int(v) for v in c)} is outside the {nx}x{ny} costmap")
    if diagonal_step < 1.0:
        raise ValueError(f"diagonal_step must be >= 1 (admissible heuristic), got {diagonal_step}")
    if nx + 2 > XY_MASK:
        raise ValueError(f"costmap is {nx} cells wide; at most {XY_MASK - 2} are supported")
    cancel = new_cancel_flag() if cancel is None else cancel
    if cancel.dtype != np.uint8 or cancel.shape != (1,):
        raise ValueError("cancel must be a one-element uint8 array (see new_cancel_flag)")
    nxp = nx + 2
    s = (int(start[1]) + 1) * nxp + int(start[0]) + 1
    t = (int(goal[1]) + 1) * nxp + int(goal[0]) + 1
    status, expansions, path, g = _astar_kernel(costmap.padded_weights(), nxp, s, t, float(diagonal_step),
                                                bool(corner_cutting), cancel)
    cells = np.stack((path % nxp - 1, path // nxp - 1), axis=1)
    settled = g.reshape(ny + 2, nx + 2)[1:-1, 1:-1]
    cost = float(g[t]) if status == FOUND else math.inf
    return SearchResult(int(status), cells, cost, int(expansions), settled)
