"""The zone service: the map's no-go zones and virtual walls, stored per map, as planner restrictions."""

from __future__ import annotations

from app.db.rooms import LIVE
from app.db.zones import ZoneRecord, ZoneStore
from app.navigation.navigator import Navigator
from slam_core.planning.errors import PlanningError
from slam_core.planning.zones import NoGoZone, Restrictions, VirtualWall

KINDS = ("zone", "wall")
#: Zones and walls one map may have.
MAX_PER_MAP = 100


class ZoneError(ValueError):
    """A zone or wall that cannot be added or removed; ``str()`` says why."""


def restriction_of(kind: str, points: list[list[float]]) -> NoGoZone | VirtualWall:
    """The planner's shape for one record; ``ZoneError`` when it is not a valid one."""
    if kind not in KINDS:
        raise ZoneError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
    try:
        pairs = tuple((float(x), float(y)) for x, y in points)
    except (TypeError, ValueError):
        raise ZoneError("points must be [x, y] pairs of numbers (metres)") from None
    try:
        if kind == "wall":
            if len(pairs) != 2:
                raise ZoneError(f"a virtual wall has exactly 2 points, got {len(pairs)}")
            return VirtualWall(*pairs)
        return NoGoZone(pairs)
    except ValueError as exc:
        raise ZoneError(str(exc)) from None


class ZoneService:
    """Zones of the live map, or of the saved map being localized in. SQLite calls are short."""

    def __init__(self, store: ZoneStore):
        self.store = store
        self.key = LIVE
        self._restrictions = self._load()

    def _load(self) -> Restrictions:
        shapes = [restriction_of(r.kind, r.points) for r in self.store.list(self.key)]
        return Restrictions(tuple(s for s in shapes if isinstance(s, NoGoZone)),
                            tuple(s for s in shapes if isinstance(s, VirtualWall)))

    def restrictions(self) -> Restrictions:
        return self._restrictions

    def list(self) -> list[ZoneRecord]:
        return self.store.list(self.key)

    def add(self, kind: str, points: list[list[float]]) -> ZoneRecord:
        restriction_of(kind, points)
        if len(self.store.list(self.key)) >= MAX_PER_MAP:
            raise ZoneError(f"this map has {MAX_PER_MAP} zones and walls already")
        record = self.store.add(self.key, kind, [[float(x), float(y)] for x, y in points])
        self._restrictions = self._load()
        return record

    def delete(self, zone_id: int) -> None:
        if not self.store.delete(self.key, zone_id):
            raise ZoneError(f"no zone or wall with id {zone_id}")
        self._restrictions = self._load()

    def use_map(self, name: str) -> None:
        self.key = name
        self._restrictions = self._load()

    def save_as(self, name: str) -> None:
        self.store.copy(self.key, name)


async def replan_for_zones(navigator: Navigator) -> None:
    """After the zones changed: plan the goal being driven to again at once, so the robot does not
    follow an old path into a new zone; a goal that is now impossible stops the robot with the reason."""
    goal = navigator.goal
    if navigator.state != "driving" or goal is None:
        return
    try:
        await navigator.set_goal(goal)
    except PlanningError as exc:
        navigator.cancel("failed", str(exc))
