"""Every MQTT topic homebot uses, derived from the topic prefix and the discovery prefix."""

from __future__ import annotations

from dataclasses import dataclass

#: Availability payloads (Home Assistant's defaults).
ONLINE = "online"
OFFLINE = "offline"


@dataclass(frozen=True)
class Topics:
    """``prefix`` is homebot's own tree; ``discovery`` is Home Assistant's (``homeassistant``)."""

    prefix: str = "homebot"
    discovery: str = "homeassistant"
    node: str = "homebot"

    @property
    def availability(self) -> str:
        return f"{self.prefix}/availability"

    @property
    def state(self) -> str:
        """JSON: state, mode, localized, room, position, navigation (retained)."""
        return f"{self.prefix}/state"

    @property
    def vacuum_state(self) -> str:
        """JSON ``{"state": ...}`` in the vacuum entity's vocabulary (retained)."""
        return f"{self.prefix}/vacuum/state"

    @property
    def map_image(self) -> str:
        """The map as PNG bytes (retained)."""
        return f"{self.prefix}/map/image"

    @property
    def zones(self) -> str:
        """JSON list of the map's no-go zones and virtual walls ``{"id", "kind", "points"}`` (retained)."""
        return f"{self.prefix}/zones"

    @property
    def command(self) -> str:
        """JSON commands: ``{"command": "go_to" | "stop" | "set_mode" | "dock", ...}``."""
        return f"{self.prefix}/command"

    @property
    def result(self) -> str:
        """One JSON answer per command: ``{"ok": bool, "command": ..., "reason": ...}``."""
        return f"{self.prefix}/command/result"

    @property
    def goto_set(self) -> str:
        """The go-to select's command topic: the name of a target option."""
        return f"{self.prefix}/goto/set"

    @property
    def mode_set(self) -> str:
        return f"{self.prefix}/mode/set"

    @property
    def stop_press(self) -> str:
        return f"{self.prefix}/stop/press"

    @property
    def dock_press(self) -> str:
        return f"{self.prefix}/dock/press"

    @property
    def vacuum_command(self) -> str:
        """The vacuum entity's command topic (``stop``, ``return_to_base``)."""
        return f"{self.prefix}/vacuum/command"

    @property
    def vacuum_send_command(self) -> str:
        """The vacuum entity's ``send_command`` topic (same JSON as :attr:`command`)."""
        return f"{self.prefix}/vacuum/send_command"

    def commands(self) -> tuple[str, ...]:
        """The topics homebot subscribes to."""
        return (self.command, self.goto_set, self.mode_set, self.stop_press, self.dock_press,
                self.vacuum_command, self.vacuum_send_command)

    def config(self, component: str, object_id: str) -> str:
        """A discovery config topic: ``<discovery>/<component>/<node>/<object_id>/config``."""
        return f"{self.discovery}/{component}/{self.node}/{object_id}/config"
