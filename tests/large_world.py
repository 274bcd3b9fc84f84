"""Large hand-made worlds for the loop-closing tests: a long ring corridor whose walls carry
boxes at irregular places (so every stretch looks different), and two identical corridors."""

from __future__ import annotations

import itertools

import numpy as np

from slam_core.geometry import compose, relative


def box(x, y, w, h) -> list[list[float]]:
    return [[x, y, x + w, y], [x + w, y, x + w, y + h], [x + w, y + h, x, y + h], [x, y + h, x, y]]


def rectangle(x0, y0, x1, y1) -> list[list[float]]:
    return [[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]]


def ring_world(length=70.0, width=40.0, corridor=3.0, seed=0, period=None) -> np.ndarray:
    """Segments of a rectangular ring corridor ``corridor`` m wide, boxes along both walls: at
    irregular places, or (``period`` m) one every ``period`` m, their sizes a little different
    (a street of look-alike doorways: each place fits best where it is, the next one less well)."""
    rng = np.random.default_rng(seed)
    segments = rectangle(0, 0, length, width) + rectangle(corridor, corridor, length - corridor,
                                                          width - corridor)
    for inset in (0.0, corridor):  # the outer wall, then the inner one
        x0, y0, x1, y1 = inset, inset, length - inset, width - inset
        edges = [((x0, y0), (1, 0), x1 - x0, 1), ((x1, y0), (0, 1), y1 - y0, -1),
                 ((x1, y1), (-1, 0), x1 - x0, 1), ((x0, y1), (0, -1), y1 - y0, -1)]
        side = 1.0 if inset == 0.0 else -1.0  # boxes stand inside the corridor
        for (sx, sy), (dx, dy), span, turn in edges:
            at = rng.uniform(1.0, 4.0)
            while at < span - 2.0:
                if period is None:
                    w, d = rng.uniform(0.3, 1.2), rng.uniform(0.2, 0.6)
                else:
                    w, d = 0.8 + rng.uniform(-0.25, 0.25), 0.4 + rng.uniform(-0.15, 0.15)
                nx, ny = -dy * turn * side, dx * turn * side  # into the corridor
                cx, cy = sx + dx * at, sy + dy * at
                xs = [cx, cx + dx * w, cx + nx * d, cx + dx * w + nx * d]
                ys = [cy, cy + dy * w, cy + ny * d, cy + dy * w + ny * d]
                segments += box(min(xs), min(ys), max(xs) - min(xs), max(ys) - min(ys))
                at += w + rng.uniform(1.5, 6.0) if period is None else period
    return np.array(segments, float)


def ring_tour(length=70.0, width=40.0, corridor=3.0, step=0.5, overlap=25.0) -> np.ndarray:
    """Poses along the ring's centre line, once round and ``overlap`` m into a second lap."""
    c = corridor / 2
    corners = np.array([[c, c], [length - c, c], [length - c, width - c], [c, width - c], [c, c]])
    points = []
    for a, b in itertools.pairwise(corners):
        n = int(np.ceil(np.hypot(*(b - a)) / step))
        points += [a + (b - a) * k / n for k in range(n)]
    lap = np.array(points)
    extra = int(overlap / step)
    xy = np.concatenate([lap, lap[:extra]])
    th = np.arctan2(*np.roll(xy - np.roll(xy, 1, axis=0), -1, axis=0)[:, ::-1].T)
    th[-1] = th[-2]
    return np.column_stack([xy, th])


def drifted(truth: np.ndarray, turn_bias: float, scale: float = 1.0) -> np.ndarray:
    """The path as a filter whose heading creeps by ``turn_bias`` per step reports it."""
    steps = relative(truth[:-1], truth[1:]) * np.array([scale, scale, 1.0])
    steps[:, 2] += turn_bias
    out = [truth[0].copy()]
    for s in steps:
        out.append(compose(out[-1], s))
    return np.array(out)


def twin_corridors(length=30.0, corridor=2.5, apart=8.0, seed=1) -> np.ndarray:
    """Two identical corridors ``apart`` m from each other (the second is the first moved
    north), both open at the west end into a connecting corridor, with the same boxes."""
    rng = np.random.default_rng(seed)
    boxes = []
    at = 2.0
    while at < length - 2.0:
        w, d = rng.uniform(0.3, 1.0), rng.uniform(0.2, 0.5)
        south = rng.random() < 0.5
        boxes.append((at, 0.0 if south else corridor - d, w, d))
        at += w + rng.uniform(1.5, 4.0)
    segments = []
    for dy in (0.0, apart):
        segments += [[0, dy, length, dy], [length, dy, length, dy + corridor],
                     [length, dy + corridor, 0, dy + corridor]]
        segments += [s for x, y, w, d in boxes for s in box(x, y + dy, w, d)]
    # the connector west of both: its east wall has the two corridors' openings
    segments += [[-3.0, -0.0, -3.0, apart + corridor], [-3.0, 0.0, 0.0, 0.0],
                 [-3.0, apart + corridor, 0.0, apart + corridor], [0.0, corridor, 0.0, apart]]
    return np.array(segments, float)


def twin_tour(length=30.0, corridor=2.5, apart=8.0, step=0.4) -> np.ndarray:
    """Down the first corridor and back, through the connector, down the second."""
    c = corridor / 2
    legs = [((0.5, c), (length - 2.0, c)), ((length - 2.0, c), (-1.5, c)), ((-1.5, c), (-1.5, apart + c)),
            ((-1.5, apart + c), (length - 2.0, apart + c))]
    poses = []
    for (x0, y0), (x1, y1) in legs:
        n = int(np.ceil(np.hypot(x1 - x0, y1 - y0) / step))
        th = np.arctan2(y1 - y0, x1 - x0)
        poses += [(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n, th) for k in range(n)]
    return np.array(poses)
