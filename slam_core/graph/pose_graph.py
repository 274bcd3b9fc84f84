"""SE(2) pose graph optimisation: sparse Gauss-Newton with a robust kernel on loop edges.

Nodes are poses ``x_i``; an edge ``(i, j, z, Omega)`` says that pose ``j`` seen
from pose ``i`` is ``z`` with information ``Omega``. The optimiser minimises
``sum_k w_k e_k^T Omega_k e_k`` with ``e = t2v(z^-1 (x_i^-1 x_j))`` (in the frame of the
measured pose ``x_i z``: ``Omega`` is on that frame's axes), the
Jacobians of Grisetti et al., "A tutorial on graph-based SLAM" (2010), and node 0
held fixed. Edges marked robust get Huber weights (iteratively reweighted), so
that a false loop closure pulls with a bounded force instead of bending the map.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.linalg import spsolve

from slam_core.geometry import relative, wrap_angle


@dataclass
class PoseGraph:
    """Poses and relative-pose constraints between them."""

    poses: np.ndarray
    i: list[int] = field(default_factory=list)
    j: list[int] = field(default_factory=list)
    z: list[np.ndarray] = field(default_factory=list)
    information: list[np.ndarray] = field(default_factory=list)
    robust: list[bool] = field(default_factory=list)

    def __post_init__(self):
        self.poses = np.array(self.poses, dtype=float).reshape(-1, 3)

    @property
    def n_edges(self) -> int:
        return len(self.i)

    def add_edge(self, i: int, j: int, z, information, robust: bool = False) -> None:
        """Constrain pose ``j`` in the frame of pose ``i`` to ``z`` (information ``3 x 3``)."""
        n = len(self.poses)
        if not (0 <= i < n and 0 <= j < n) or i == j:
            raise ValueError(f"edge ({i}, {j}) does not join two of the {n} nodes")
        self.i.append(int(i))
        self.j.append(int(j))
        self.z.append(np.asarray(z, dtype=float).reshape(3))
        self.information.append(np.asarray(information, dtype=float).reshape(3, 3))
        self.robust.append(bool(robust))

    def residuals(self, poses: np.ndarray | None = None) -> np.ndarray:
        """Edge errors ``(m, 3)`` at ``poses`` (default: the graph's poses)."""
        x = self.poses if poses is None else poses
        return _errors(x, *self._arrays()[:3])[0]

    def chi2(self, poses: np.ndarray | None = None) -> np.ndarray:
        """Per-edge ``e^T Omega e``."""
        e = self.residuals(poses)
        return np.einsum("ma,mab,mb->m", e, np.array(self.information).reshape(-1, 3, 3), e)

    def _arrays(self):
        return (np.array(self.i, np.int64), np.array(self.j, np.int64),
                np.array(self.z, dtype=float).reshape(-1, 3),
                np.array(self.information, dtype=float).reshape(-1, 3, 3),
                np.array(self.robust, np.bool_))


def _errors(x: np.ndarray, i: np.ndarray, j: np.ndarray, z: np.ndarray):
    """Errors ``(m, 3)`` and the Jacobians ``A = de/dx_i``, ``B = de/dx_j`` ``(m, 3, 3)``."""
    xi, xj = x[i], x[j]
    ci, si = np.cos(xi[:, 2]), np.sin(xi[:, 2])
    cz, sz = np.cos(z[:, 2]), np.sin(z[:, 2])
    dx, dy = xj[:, 0] - xi[:, 0], xj[:, 1] - xi[:, 1]
    # the translation of x_j in the frame of x_i, then in the frame of z
    lx, ly = ci * dx + si * dy, -si * dx + ci * dy
    ex, ey = cz * (lx - z[:, 0]) + sz * (ly - z[:, 1]), -sz * (lx - z[:, 0]) + cz * (ly - z[:, 1])
    e = np.column_stack([ex, ey, wrap_angle(xj[:, 2] - xi[:, 2] - z[:, 2])])
    m = len(i)
    rzt = np.empty((m, 2, 2))
    rzt[:, 0, 0], rzt[:, 0, 1], rzt[:, 1, 0], rzt[:, 1, 1] = cz, sz, -sz, cz
    rit = np.empty((m, 2, 2))
    rit[:, 0, 0], rit[:, 0, 1], rit[:, 1, 0], rit[:, 1, 1] = ci, si, -si, ci
    rot = np.einsum("mab,mbc->mac", rzt, rit)
    # d(R_i^T (t_j - t_i)) / d theta_i
    dlt = np.column_stack([-si * dx + ci * dy, -ci * dx - si * dy])
    a = np.zeros((m, 3, 3))
    b = np.zeros((m, 3, 3))
    a[:, :2, :2] = -rot
    a[:, :2, 2] = np.einsum("mab,mb->ma", rzt, dlt)
    a[:, 2, 2] = -1.0
    b[:, :2, :2] = rot
    b[:, 2, 2] = 1.0
    return e, a, b


def optimize(graph: PoseGraph, iterations: int = 20, huber: float = 1.0,
             tolerance: float = 1e-6) -> np.ndarray:
    """Optimised poses ``(n, 3)`` of ``graph`` (node 0 fixed); ``graph.poses`` is unchanged.

    ``huber`` is the kernel's width in units of the edge's standard error: a robust
    edge whose normalised error ``sqrt(e^T Omega e)`` exceeds it is down-weighted by
    ``huber / sqrt(e^T Omega e)``.
    """
    x = graph.poses.copy()
    if graph.n_edges == 0 or len(x) < 2:
        return x
    i, j, z, info, robust = graph._arrays()
    n = len(x)
    rows = np.concatenate([3 * i, 3 * i, 3 * j, 3 * j])[:, None, None] + np.arange(3)[None, :, None]
    cols = np.concatenate([3 * i, 3 * j, 3 * i, 3 * j])[:, None, None] + np.arange(3)[None, None, :]
    rows = np.broadcast_to(rows, (len(rows), 3, 3)).ravel()
    cols = np.broadcast_to(cols, (len(cols), 3, 3)).ravel()
    for _ in range(iterations):
        e, a, b = _errors(x, i, j, z)
        chi = np.sqrt(np.maximum(np.einsum("ma,mab,mb->m", e, info, e), 0.0))
        w = np.where(robust & (chi > huber), huber / np.maximum(chi, 1e-12), 1.0)
        wo = info * w[:, None, None]
        at_o = np.einsum("mba,mbc->mac", a, wo)
        bt_o = np.einsum("mba,mbc->mac", b, wo)
        blocks = np.concatenate([at_o @ a, at_o @ b, bt_o @ a, bt_o @ b])
        h = coo_matrix((blocks.ravel(), (rows, cols)), shape=(3 * n, 3 * n)).tocsc()
        g = np.zeros(3 * n)
        np.add.at(g, (3 * i[:, None] + np.arange(3)).ravel(), np.einsum("mab,mb->ma", at_o, e).ravel())
        np.add.at(g, (3 * j[:, None] + np.arange(3)).ravel(), np.einsum("mab,mb->ma", bt_o, e).ravel())
        free = slice(3, 3 * n)
        step = spsolve(h[free, free], -g[free], permc_spec="MMD_AT_PLUS_A")  # H is symmetric
        x[1:] += step.reshape(-1, 3)
        x[:, 2] = wrap_angle(x[:, 2])
        if np.max(np.abs(step)) < tolerance:
            break
    return x


def chain_edges(graph: PoseGraph, poses: np.ndarray, information) -> None:
    """Add an edge between each pair of consecutive ``poses`` with their relative pose."""
    rel = relative(poses[:-1], poses[1:])
    info = np.broadcast_to(np.asarray(information, dtype=float), (len(rel), 3, 3))
    for k in range(len(rel)):
        graph.add_edge(k, k + 1, rel[k], info[k])
