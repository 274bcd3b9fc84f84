"""Floor plans of homes in a plain text format, and their loader.

A world file is read line by line; ``#`` starts a comment, blank lines are
ignored, numbers are metres (x east/forward, y north/left, REP-103) and angles
are **degrees** (the file is for people). One statement per line::

    name     flat                          # optional, defaults to the file's stem
    ceiling  2.5                           # optional ceiling height (m), default 2.5
    start    1.0 3.75 0                    # start pose: x y theta_degrees (required)
    wall     x1 y1 x2 y2 [x3 y3 ...]       # an open polyline of wall segments
    polygon  x1 y1 x2 y2 x3 y3 [...]       # a closed loop of walls (last point joins the first)
    room     NAME x0 y0 x1 y1              # an axis-aligned rectangle of four walls, named
    door     x1 y1 x2 y2                   # a gap: removes the part of every wall it lies on
    furniture NAME HEIGHT x1 y1 x2 y2 x3 y3 [...]   # a solid closed polygon HEIGHT m tall
    leg      x y [RADIUS [HEIGHT]]         # a thin post (table leg), default r 0.025, h 0.72
    table    NAME x0 y0 x1 y1 [HEIGHT]     # four legs inset 5 cm from the rectangle's corners
    waypoint NAME x y                      # a stop of the scripted tour, in file order

Walls have no thickness and reach the ceiling. A ``door`` must be collinear
with, and overlap, at least one wall, otherwise it is an error (so a typo cannot
silently leave a wall closed). Rooms that share a side share a wall, and a door
on that side opens both. Furniture and legs are vertical prisms from the floor to
their height: a lidar mounted lower than a table top sees the legs only. Legs
are the point landmarks for landmark SLAM (:attr:`World.landmarks`).

Consecutive tour waypoints must be joined by straight, collision-free lines;
``tests`` check this for the shipped worlds. Errors name the file and line.

:func:`load_world` takes a path or the name of a shipped world (:func:`world_names`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Folder of the shipped worlds (``<name>.txt``).
WORLDS_DIR = Path(__file__).resolve().parent / "worlds"

DEFAULT_CEILING = 2.5
DEFAULT_LEG_RADIUS = 0.025
DEFAULT_TABLE_HEIGHT = 0.72
#: Table legs sit this far inside the table top's corners.
TABLE_LEG_INSET = 0.05
#: Tolerance (m) for a door lying on a wall.
DOOR_TOLERANCE = 1e-6
#: Wall pieces shorter than this left over after cutting doors are dropped.
MIN_WALL_PIECE = 1e-6
#: No number of a world file is larger (metres or degrees): a home is not 10 km wide.
MAX_NUMBER = 1e4
#: How far beyond the walls' extent the start may lie (m): a robot there still sees them.
START_REACH = 30.0


#: The statements of the format, each handled by ``_Parser._<statement>``.
STATEMENTS = ("name", "ceiling", "start", "wall", "polygon", "room", "door", "furniture", "leg", "table",
              "waypoint")


class WorldFormatError(ValueError):
    """A world file that cannot be read; the message names the file, line and problem."""

    def __init__(self, source, line: int, problem: str):
        super().__init__(f"{source}:{line}: {problem}")
        self.source = str(source)
        self.line = line
        self.problem = problem


@dataclass(frozen=True)
class Furniture:
    name: str
    height: float
    polygon: np.ndarray  # (k, 2), closed implicitly


@dataclass(frozen=True)
class Waypoint:
    name: str
    x: float
    y: float


@dataclass(frozen=True)
class World:
    """The geometry of one home, ready for ray casting.

    ``segments`` ``(n, 4)`` are ``x1 y1 x2 y2`` of every wall piece and furniture
    edge, with their heights in ``segment_heights``; ``circles`` ``(m, 3)`` are
    ``x y radius`` of legs with ``circle_heights``. ``start`` is ``(x, y, theta)``
    in radians.
    """

    name: str
    segments: np.ndarray
    segment_heights: np.ndarray
    circles: np.ndarray
    circle_heights: np.ndarray
    start: np.ndarray
    waypoints: tuple[Waypoint, ...] = ()
    furniture: tuple[Furniture, ...] = ()
    ceiling: float = DEFAULT_CEILING
    source: str = ""
    wall_count: int = field(default=0)

    @property
    def landmarks(self) -> np.ndarray:
        """Centres ``(m, 2)`` of the legs (point landmarks)."""
        return self.circles[:, :2].copy()

    @property
    def tour(self) -> np.ndarray:
        """Waypoint positions ``(k, 2)`` in file order."""
        return np.array([[w.x, w.y] for w in self.waypoints], dtype=float).reshape(-1, 2)

    def tour_poses(self, step: float = 0.1) -> np.ndarray:
        """Poses ``(n, 3)`` every ``step`` metres along the straight legs from the start through the
        waypoints, each heading along its leg."""
        points = np.vstack([self.start[:2], self.tour])
        poses = []
        for a, b in itertools.pairwise(points):
            heading = math.atan2(*(b - a)[::-1])
            for t in np.arange(0.0, 1.0, step / max(math.hypot(*(b - a)), step)):
                poses.append([*(a + t * (b - a)), heading])
        return np.array(poses).reshape(-1, 3)

    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` of all geometry."""
        xs = np.concatenate([self.segments[:, 0], self.segments[:, 2],
                             self.circles[:, 0] - self.circles[:, 2],
                             self.circles[:, 0] + self.circles[:, 2]])
        ys = np.concatenate([self.segments[:, 1], self.segments[:, 3],
                             self.circles[:, 1] - self.circles[:, 2],
                             self.circles[:, 1] + self.circles[:, 2]])
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())

    def obstacles(self, min_height: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Segments and circles at least ``min_height`` tall (what a sensor at that height sees)."""
        seg = self.segments[self.segment_heights > min_height]
        circ = self.circles[self.circle_heights > min_height]
        return np.ascontiguousarray(seg), np.ascontiguousarray(circ)


def world_names() -> list[str]:
    """Names of the shipped worlds (usable with :func:`load_world`)."""
    return sorted(p.stem for p in WORLDS_DIR.glob("*.txt"))


def resolve_world(name_or_path) -> Path:
    """The file of a shipped world's name, or an existing path."""
    path = Path(name_or_path)
    if path.is_file():
        return path
    shipped = WORLDS_DIR / f"{name_or_path}.txt"
    if shipped.is_file():
        return shipped
    raise FileNotFoundError(f"no world file {str(name_or_path)!r} "
                            f"(shipped worlds: {', '.join(world_names())})")


def load_world(name_or_path) -> World:
    """Load a world from a file path or the name of a shipped world (``flat``, ``house``)."""
    path = resolve_world(name_or_path)
    return parse_world(path.read_text(), source=str(path), default_name=path.stem)


def parse_world(text: str, source: str = "<string>", default_name: str = "world") -> World:
    """Parse world-file text (see the module docstring for the format)."""
    return _Parser(source, default_name).parse(text)


class _Parser:
    def __init__(self, source: str, default_name: str):
        self.source = source
        self.name = default_name
        self.ceiling = DEFAULT_CEILING
        self.ceiling_line = 0
        self.start = None
        self.start_line = 0
        self.walls: list[tuple[float, float, float, float]] = []
        self.doors: list[tuple[int, tuple[float, float, float, float]]] = []
        self.furniture: list[Furniture] = []
        self.legs: list[tuple[float, float, float, float]] = []
        self.waypoints: list[Waypoint] = []
        self.line = 0

    def error(self, problem: str) -> WorldFormatError:
        return WorldFormatError(self.source, self.line, problem)

    def numbers(self, fields: list[str], what: str, count: int | None = None,
                minimum: int = 0, even: bool = False) -> list[float]:
        if count is not None and len(fields) != count:
            raise self.error(f"{what}: expected {count} numbers, got {len(fields)}")
        if len(fields) < minimum:
            raise self.error(f"{what}: expected at least {minimum} numbers, got {len(fields)}")
        if even and len(fields) % 2:
            raise self.error(f"{what}: coordinates come in x y pairs, got {len(fields)} numbers")
        values = []
        for f in fields:
            try:
                v = float(f)
            except ValueError:
                raise self.error(f"{what}: {f!r} is not a number") from None
            if not math.isfinite(v):
                raise self.error(f"{what}: {f!r} is not a finite number")
            if abs(v) > MAX_NUMBER:
                raise self.error(f"{what}: {f} is beyond ±{MAX_NUMBER:g} (metres or degrees)")
            values.append(v)
        return values

    def parse(self, text: str) -> World:
        for self.line, raw in enumerate(text.splitlines(), 1):
            fields = raw.split("#", 1)[0].split()
            if not fields:
                continue
            keyword, args = fields[0].lower(), fields[1:]
            if keyword not in STATEMENTS:
                raise self.error(f"unknown statement {fields[0]!r} "
                                 f"(expected one of: {', '.join(STATEMENTS)})")
            getattr(self, f"_{keyword}")(args)
        self.line = max(self.line, 1)
        if self.start is None:
            raise self.error("no 'start x y theta_degrees' line")
        if not self.walls:
            raise self.error("no walls")
        ends = np.array(self.walls).reshape(-1, 2)
        low, high = ends.min(axis=0) - START_REACH, ends.max(axis=0) + START_REACH
        if not ((low <= self.start[:2]) & (self.start[:2] <= high)).all():
            raise WorldFormatError(self.source, self.start_line,
                                   f"start ({self.start[0]:g}, {self.start[1]:g}) lies outside the walls "
                                   f"(more than {START_REACH:g} m beyond them)")
        walls = self._cut_doors()
        return self._build(walls)

    # --- statements -------------------------------------------------------------------------
    def _name(self, args):
        if len(args) != 1:
            raise self.error("name: expected one word")
        self.name = args[0]

    def _ceiling(self, args):
        (h,) = self.numbers(args, "ceiling", count=1)
        if h <= 0:
            raise self.error("ceiling: height must be positive")
        self.ceiling = h

    def _start(self, args):
        x, y, deg = self.numbers(args, "start (x y theta_degrees)", count=3)
        self.start = np.array([x, y, math.atan2(math.sin(math.radians(deg)), math.cos(math.radians(deg)))])
        self.start_line = self.line

    def _wall(self, args):
        pts = self.numbers(args, "wall", minimum=4, even=True)
        self._add_polyline(pts, closed=False)

    def _polygon(self, args):
        pts = self.numbers(args, "polygon", minimum=6, even=True)
        self._add_polyline(pts, closed=True)

    def _room(self, args):
        if len(args) != 5:
            raise self.error(f"room: expected 'room NAME x0 y0 x1 y1', got {len(args)} fields")
        x0, y0, x1, y1 = self._rectangle(args[1:], "room")
        self._add_polyline([x0, y0, x1, y0, x1, y1, x0, y1], closed=True)

    def _door(self, args):
        x1, y1, x2, y2 = self.numbers(args, "door (x1 y1 x2 y2)", count=4)
        if math.hypot(x2 - x1, y2 - y1) <= DOOR_TOLERANCE:
            raise self.error("door: the two ends are the same point")
        self.doors.append((self.line, (x1, y1, x2, y2)))

    def _furniture(self, args):
        if len(args) < 8:
            raise self.error("furniture: expected 'furniture NAME HEIGHT x1 y1 x2 y2 x3 y3 ...'")
        (height,) = self.numbers(args[1:2], "furniture height", count=1)
        if height <= 0:
            raise self.error("furniture: height must be positive")
        pts = self.numbers(args[2:], "furniture polygon", minimum=6, even=True)
        poly = np.array(pts, dtype=float).reshape(-1, 2)
        if abs(_polygon_area(poly)) < 1e-9:
            raise self.error("furniture: polygon has no area")
        self.furniture.append(Furniture(args[0], height, poly))

    def _leg(self, args):
        if not 2 <= len(args) <= 4:
            raise self.error("leg: expected 'leg x y [radius [height]]'")
        values = self.numbers(args, "leg")
        x, y = values[:2]
        r = values[2] if len(values) > 2 else DEFAULT_LEG_RADIUS
        h = values[3] if len(values) > 3 else DEFAULT_TABLE_HEIGHT
        if r <= 0 or h <= 0:
            raise self.error("leg: radius and height must be positive")
        self.legs.append((x, y, r, h))

    def _table(self, args):
        if len(args) not in (5, 6):
            raise self.error("table: expected 'table NAME x0 y0 x1 y1 [height]'")
        x0, y0, x1, y1 = self._rectangle(args[1:5], "table")
        h = self.numbers(args[5:], "table height")[0] if len(args) == 6 else DEFAULT_TABLE_HEIGHT
        if h <= 0:
            raise self.error("table: height must be positive")
        if min(x1 - x0, y1 - y0) <= 2 * TABLE_LEG_INSET + 2 * DEFAULT_LEG_RADIUS:
            raise self.error("table: too small for four legs")
        i = TABLE_LEG_INSET + DEFAULT_LEG_RADIUS
        for x, y in ((x0 + i, y0 + i), (x1 - i, y0 + i), (x1 - i, y1 - i), (x0 + i, y1 - i)):
            self.legs.append((x, y, DEFAULT_LEG_RADIUS, h))

    def _waypoint(self, args):
        if len(args) != 3:
            raise self.error("waypoint: expected 'waypoint NAME x y'")
        x, y = self.numbers(args[1:], "waypoint", count=2)
        if any(w.name == args[0] for w in self.waypoints):
            raise self.error(f"waypoint: name {args[0]!r} used twice")
        self.waypoints.append(Waypoint(args[0], x, y))

    # --- helpers ----------------------------------------------------------------------------
    def _rectangle(self, args, what):
        x0, y0, x1, y1 = self.numbers(args, f"{what} corners (x0 y0 x1 y1)", count=4)
        if x1 <= x0 or y1 <= y0:
            raise self.error(f"{what}: need x0 < x1 and y0 < y1 (lower-left then upper-right corner)")
        return x0, y0, x1, y1

    def _add_polyline(self, pts, closed):
        xy = np.array(pts, dtype=float).reshape(-1, 2)
        if closed:
            xy = np.vstack([xy, xy[:1]])
        for a, b in itertools.pairwise(xy):
            if math.hypot(*(b - a)) <= MIN_WALL_PIECE:
                raise self.error(f"wall piece from ({a[0]}, {a[1]}) to ({b[0]}, {b[1]}) has no length")
            self.walls.append((a[0], a[1], b[0], b[1]))

    def _cut_doors(self) -> list[tuple[float, float, float, float]]:
        walls = list(self.walls)
        for line, door in self.doors:
            self.line = line
            out, touched = [], False
            for wall in walls:
                pieces = _subtract_collinear(wall, door)
                touched |= pieces is not None
                out.extend([wall] if pieces is None else pieces)
            if not touched:
                raise self.error(f"door ({door[0]}, {door[1]}) - ({door[2]}, {door[3]}) "
                                 "does not lie on any wall")
            walls = out
        return walls

    def _build(self, walls) -> World:
        segs = [list(w) for w in walls]
        heights = [self.ceiling] * len(walls)
        for f in self.furniture:
            ring = np.vstack([f.polygon, f.polygon[:1]])
            for a, b in itertools.pairwise(ring):
                segs.append([a[0], a[1], b[0], b[1]])
                heights.append(min(f.height, self.ceiling))
        legs = np.array(self.legs, dtype=float).reshape(-1, 4)
        return World(
            name=self.name,
            segments=np.ascontiguousarray(np.array(segs, dtype=float).reshape(-1, 4)),
            segment_heights=np.array(heights, dtype=float),
            circles=np.ascontiguousarray(legs[:, :3]),
            circle_heights=np.ascontiguousarray(np.minimum(legs[:, 3], self.ceiling)),
            start=self.start,
            waypoints=tuple(self.waypoints),
            furniture=tuple(self.furniture),
            ceiling=self.ceiling,
            source=self.source,
            wall_count=len(walls),
        )


def _subtract_collinear(wall, door):
    """Pieces of ``wall`` left after removing ``door``, or None if the door is not on it."""
    ax, ay, bx, by = wall
    dx, dy = bx - ax, by - ay
    length = math.hypot(dx, dy)
    ux, uy = dx / length, dy / length
    # Both door ends must lie on the wall's line.
    for px, py in ((door[0], door[1]), (door[2], door[3])):
        if abs((px - ax) * uy - (py - ay) * ux) > DOOR_TOLERANCE:
            return None
    t1 = (door[0] - ax) * ux + (door[1] - ay) * uy
    t2 = (door[2] - ax) * ux + (door[3] - ay) * uy
    lo, hi = min(t1, t2), max(t1, t2)
    if hi <= DOOR_TOLERANCE or lo >= length - DOOR_TOLERANCE:
        return None
    pieces = []
    if lo > MIN_WALL_PIECE:
        pieces.append((ax, ay, ax + ux * lo, ay + uy * lo))
    if hi < length - MIN_WALL_PIECE:
        pieces.append((ax + ux * hi, ay + uy * hi, bx, by))
    return pieces


def _polygon_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
