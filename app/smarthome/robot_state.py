"""What the smart home is told about the robot, read from ``Runtime.status()``."""

from __future__ import annotations

from dataclasses import asdict, dataclass

#: The robot states published on MQTT.
STATES = ("idle", "driving", "mapping", "localizing", "stuck", "error")
#: The name goals to the dock carry (the vacuum entity then says ``returning`` / ``docked``).
DOCK = "dock"


@dataclass(frozen=True)
class RobotState:
    """One state message (``<prefix>/state``)."""

    state: str
    mode: str
    mapping: bool
    localized: bool
    room: str | None
    x: float | None
    y: float | None
    yaw: float | None
    nav_state: str
    reason: str | None
    goal: str | None

    def dict(self) -> dict:
        return asdict(self)

    @property
    def vacuum_state(self) -> str:
        """The state in Home Assistant's vacuum vocabulary."""
        if self.state in ("error", "stuck"):
            return "error"
        if self.state == "driving":
            return "returning" if self.goal == DOCK else "cleaning"
        if self.nav_state == "arrived" and self.goal == DOCK:
            return "docked"
        return "idle"


def robot_state(status: dict) -> RobotState:
    """Condense the server's status into the robot's state and what goes with it."""
    nav = status.get("nav") or {}
    nav_state, reason = nav.get("state", "idle"), nav.get("reason")
    goal = status.get("goal") or {}
    pose = status.get("pose") or {}
    if not (status.get("worker") or {}).get("alive", True):
        state = "error"
    elif nav_state == "stuck" or (nav_state == "failed" and reason and "stuck" in reason):
        state = "stuck"
    elif nav_state == "failed":
        state = "error"
    elif nav_state == "driving":
        state = "driving"
    elif status.get("mode") == "localization" and not status.get("localized"):
        state = "localizing"
    elif status.get("mapping") and status.get("mode") != "localization":
        state = "mapping"
    else:
        state = "idle"
    return RobotState(
        state=state, mode=str(status.get("mode")), mapping=bool(status.get("mapping")),
        localized=bool(status.get("localized")), room=status.get("room"),
        x=_rounded(pose.get("x")), y=_rounded(pose.get("y")), yaw=_rounded(pose.get("yaw")),
        nav_state=nav_state, reason=reason, goal=goal.get("place") if goal.get("place") else
        (None if not goal else f"{goal['x']:.2f}, {goal['y']:.2f}"))


def _rounded(value) -> float | None:
    return None if value is None else round(float(value), 3)
