"""The bridge between the running robot and the smart home: state out, commands in.

Started in the app's lifespan when ``HOMEBOT_MQTT_HOST`` is set. It reads ``Runtime.status()``
and the map snapshot on the event loop (cheap), renders the map PNG and reads SQLite in
threads, and leaves the network to :class:`~app.smarthome.link.MqttLink`'s thread.
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import json
import logging
import time

import numpy as np
from PIL import Image

from app.db.store import NotFound
from app.navigation.navigator import Goal
from app.navigation.planning import PlanningError
from app.runtime import Runtime
from app.smarthome import commands as cmd
from app.smarthome.discovery import Device, discovery_configs
from app.smarthome.link import MqttLink
from app.smarthome.robot_state import DOCK, robot_state
from app.smarthome.topics import Topics
from app.worker import switching
from app.worker.estimators import available_modes
from app.zones.service import ZoneError, replan_for_zones
from slam_core.io.render import map_image
from slam_core.sim.world import load_world

log = logging.getLogger(__name__)

#: Targets (places) are re-read this often, and the go-to select's config republished when they change.
TARGETS_REFRESH_S = 5.0
#: An unchanged state is still republished this often.
STATE_REFRESH_S = 30.0


class MqttBridge:
    """Publishes discovery, state and the map; executes commands and answers each one."""

    def __init__(self, runtime: Runtime):
        s = runtime.settings
        self.runtime = runtime
        self.topics = Topics(s.mqtt_prefix, s.mqtt_discovery_prefix, s.mqtt_client_id)
        self.device = Device(s.mqtt_client_id)
        self.link = MqttLink(s, self.topics, self._connected_from_thread, self._message_from_thread)
        self._loop: asyncio.AbstractEventLoop | None = None
        self._tasks: list[asyncio.Task] = []
        self._running_commands: set[asyncio.Task] = set()
        self._targets: tuple[list[str], list[str]] | None = None
        self._last_state: tuple[str, float] | None = None
        self._map_seq: int | None = None
        self._map_png: bytes | None = None
        self._fresh_session = asyncio.Event()
        self._zones: str | None = None

    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        self.link.start()
        for coro in (self._announcer(), self._state_pump(), self._map_pump()):
            self._tasks.append(asyncio.create_task(coro))

    async def stop(self) -> None:
        tasks = [*self._tasks, *self._running_commands]
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        await asyncio.to_thread(self.link.stop)

    # from paho's thread to the loop
    def _connected_from_thread(self) -> None:
        self._call_soon(self._fresh_session.set)

    def _message_from_thread(self, topic: str, payload: bytes) -> None:
        self._call_soon(lambda: self._start_command(topic, payload))

    def _start_command(self, topic: str, payload: bytes) -> None:
        task = asyncio.create_task(self._handle(topic, payload))
        self._running_commands.add(task)
        task.add_done_callback(self._running_commands.discard)

    def _call_soon(self, callback) -> None:
        loop = self._loop
        if loop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(callback)

    # publishing
    async def _announcer(self) -> None:
        """Discovery configs after every (re)connection, and again when the places change."""
        while True:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._fresh_session.wait(), TARGETS_REFRESH_S)
            fresh = self._fresh_session.is_set()
            self._fresh_session.clear()
            targets = await asyncio.to_thread(self._read_targets)
            if fresh or targets != self._targets:
                self._targets = targets
                for topic, payload in discovery_configs(self.topics, self.device, list(available_modes()),
                                                        *targets).items():
                    self.link.publish(topic, json.dumps(payload), retain=True, qos=1)
            if fresh:
                self._last_state, self._map_png, self._map_seq, self._zones = None, None, None, None
            await self.publish_zones()

    def _read_targets(self) -> tuple[list[str], list[str]]:
        places = [p.name for p in self.runtime.store.list_places()]
        return places, [r["name"] for r in self.runtime.rooms.rooms()]

    async def publish_zones(self) -> None:
        """The zones and walls, retained, when they changed."""
        text = json.dumps([z.dict() for z in await asyncio.to_thread(self.runtime.zones.list)])
        if text != self._zones and self.link.publish(self.topics.zones, text, retain=True, qos=1):
            self._zones = text

    async def _state_pump(self) -> None:
        while True:
            await asyncio.sleep(1.0 / self.runtime.settings.status_hz)
            self.publish_state()

    def publish_state(self) -> None:
        """State and vacuum state, retained; only when changed (or every ``STATE_REFRESH_S``)."""
        state = robot_state(self.runtime.status())
        text = json.dumps(state.dict())
        now = time.monotonic()
        last = self._last_state
        if last is not None and last[0] == text and now - last[1] < STATE_REFRESH_S:
            return
        if self.link.publish(self.topics.state, text, retain=True, qos=1):
            self.link.publish(self.topics.vacuum_state, json.dumps({"state": state.vacuum_state}),
                              retain=True, qos=1)
            self._last_state = (text, now)

    async def _map_pump(self) -> None:
        """The map PNG, at most every ``mqtt_map_interval_s`` and only when the map changed."""
        while True:
            await asyncio.sleep(self.runtime.settings.mqtt_map_interval_s if self._map_png else 1.0)
            snapshot = self.runtime.map_snapshot
            if snapshot is None or snapshot.seq == self._map_seq or not self.link.connected.is_set():
                continue
            png = await asyncio.to_thread(self._render_map)  # the grid is rebuilt there too
            self._map_seq = snapshot.seq
            if png is not None and png != self._map_png and \
                    self.link.publish(self.topics.map_image, png, retain=True, qos=1):
                self._map_png = png

    def _render_map(self) -> bytes | None:
        grid = self.runtime.current_grid()
        return None if grid is None else _png(grid)

    # commands
    async def _handle(self, topic: str, payload: bytes) -> None:
        answer: dict = {"topic": topic}
        try:
            request = cmd.parse(self.topics, topic, payload)
            answer.update(command=_command_name(request.command), id=request.id)
            answer.update(ok=True, **await self._execute(request.command))
        except cmd.CommandError as exc:
            answer.update(ok=False, reason=str(exc))
        except Exception:  # a bug must not take the bridge down: answer and log it
            log.exception("MQTT command on %s failed", topic)
            answer.update(ok=False, reason="internal error")
        self.link.publish(self.topics.result, json.dumps(answer), qos=1)
        self.publish_state()

    async def _execute(self, command: cmd.Command) -> dict:
        runtime, nav = self.runtime, self.runtime.navigator
        if isinstance(command, cmd.Stop):
            nav.take_over()
            nav.cancel()
            return {}
        if isinstance(command, cmd.AddZone | cmd.DeleteZone):
            return await self._edit_zones(command)
        if runtime.settings.replay:
            raise cmd.CommandError(f"replaying the log {runtime.settings.replay!r}: a log cannot be driven")
        if isinstance(command, cmd.SetMode):
            try:
                made = await switching.switch_mode(runtime, command.mode)
            except switching.SwitchRefused as exc:
                raise cmd.CommandError(f"{exc.reason}: {exc}") from None
            return {"mode": command.mode, "switched": made}
        try:
            started = await nav.set_goal(await self._goal(command))
        except PlanningError as exc:
            raise cmd.CommandError(f"{exc.reason}: {exc}") from None
        return {"goal": started["goal"], "length": round(started["length"], 3)}

    async def _edit_zones(self, command: cmd.AddZone | cmd.DeleteZone) -> dict:
        zones = self.runtime.zones
        try:
            if isinstance(command, cmd.AddZone):
                answer = {"zone": (await asyncio.to_thread(zones.add, command.kind, command.points)).dict()}
            else:
                await asyncio.to_thread(zones.delete, command.id)
                answer = {"deleted": command.id}
        except ZoneError as exc:
            raise cmd.CommandError(str(exc)) from None
        await replan_for_zones(self.runtime.navigator)
        await self.publish_zones()
        return answer

    async def _goal(self, command: cmd.Command) -> Goal:
        if isinstance(command, cmd.GoToPoint):
            return Goal(command.x, command.y)
        if isinstance(command, cmd.GoToPlace):
            try:
                place = await asyncio.to_thread(self.runtime.store.get_place, command.name)
            except NotFound as exc:
                raise cmd.CommandError(str(exc.args[0])) from None
            return Goal(place.x, place.y, place.name, yaw=place.yaw)  # its heading too
        if isinstance(command, cmd.GoToDock):
            x, y = await asyncio.to_thread(self._dock)
            return Goal(x, y, DOCK)
        rooms = self.runtime.rooms
        try:
            return await rooms.goal(rooms.find(command.name), self.runtime.navigator)
        except KeyError as exc:
            raise cmd.CommandError(str(exc.args[0])) from None

    def _dock(self) -> tuple[float, float]:
        """The place named ``dock``, else where the robot started its map."""
        try:
            place = self.runtime.store.get_place(DOCK)
            return place.x, place.y
        except NotFound:
            s = self.runtime.settings
            start = load_world(s.world).start if s.simulation else np.zeros(3)
            return float(start[0]), float(start[1])


def _command_name(command: cmd.Command) -> str:
    if isinstance(command, cmd.AddZone):
        return f"add_{command.kind}"
    return {cmd.GoToPlace: "go_to", cmd.GoToRoom: "go_to", cmd.GoToPoint: "go_to", cmd.GoToDock: "dock",
            cmd.Stop: "stop", cmd.SetMode: "set_mode", cmd.DeleteZone: "delete_zone"}[type(command)]


def _png(grid) -> bytes:
    out = io.BytesIO()
    Image.fromarray(map_image(grid)).save(out, format="PNG", optimize=True)
    return out.getvalue()
