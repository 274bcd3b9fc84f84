"""Commands that change what the worker does (mode, mapping, sessions), sent and waited for.

Shared by the REST routes and the MQTT bridge, so both answer the same: the change was made, it
is still under way after ``SWITCH_WAIT_S`` (the ``changed`` event follows), or it was refused
(:class:`SwitchRefused`, with the HTTP status the REST API answers and a reason).
"""

from __future__ import annotations

import asyncio
import time
from typing import TYPE_CHECKING

from app.worker.estimators import available_modes
from app.worker.messages import Command, SetMode

if TYPE_CHECKING:
    from app.runtime import Runtime

#: How long a change is waited for before it is answered as still under way.
SWITCH_WAIT_S = 15.0
POLL_S = 0.05
#: Worker events that end the wait: the change happened, or it did not.
DONE_EVENTS = ("changed", "error", "crashed", "restarted")


class SwitchRefused(Exception):
    """A change that was not made; ``str()`` says why, ``reason`` is the short code."""

    def __init__(self, status: int, reason: str, message: str):
        super().__init__(message)
        self.status, self.reason = status, reason


def _events_after(runtime: Runtime, marker: dict | None) -> list[dict]:
    events = list(runtime.events)
    for i in range(len(events) - 1, -1, -1):
        if events[i] is marker:
            return events[i + 1:]
    return events if marker is None else []


async def send_and_wait(runtime: Runtime, command: Command, refused: str = "mode_refused") -> bool:
    """Send ``command`` and wait for its outcome: ``True`` when made, ``False`` when still under way;
    :class:`SwitchRefused` when refused (``refused`` is then its reason) or the worker is gone."""
    marker = runtime.events[-1] if runtime.events else None
    if not runtime.supervisor.send(command):
        raise SwitchRefused(503, "worker_unavailable", "the worker is not accepting commands")
    deadline = time.monotonic() + SWITCH_WAIT_S
    while time.monotonic() < deadline:
        await asyncio.sleep(POLL_S)
        done = [e for e in _events_after(runtime, marker) if e.get("event") in DONE_EVENTS]
        if not done:
            continue
        event = done[0]
        if event["event"] == "changed":
            return True
        if event["event"] == "error":
            raise SwitchRefused(409, refused, str(event.get("detail")))  # paths as DATA/... (supervisor)
        raise SwitchRefused(503, "worker_restarting",
                            "the worker stopped while switching; it restarts from its checkpoint")
    return False


async def switch_mode(runtime: Runtime, mode: str, yaml_path: str | None = None, map_name: str | None = None,
                      new_map: bool = False) -> bool:
    """Switch the estimator's mode (see :func:`send_and_wait`); a mode this install lacks, or
    localization without a map, is refused before anything is sent."""
    if mode not in available_modes():
        raise SwitchRefused(409, "mode_unavailable",
                            f"mode {mode!r} is not available (have: {', '.join(available_modes())})")
    if mode == "localization" and yaml_path is None and runtime.map_snapshot is None:
        raise SwitchRefused(409, "no_map", "there is no map to localize on yet")
    return await send_and_wait(runtime, SetMode(mode, yaml_path, map_name, new_map))
