"""The websocket hub: every client gets the newest frame of each kind, none waits for another.

Publishing never awaits: it stores the frame (serialised once for all clients) in
each client's slots and wakes the client's own sender task. A slot holds one frame
per kind, so a slow client skips stale pose/scan/particle frames instead of
queueing them. Map deltas cannot be skipped (the client's map would go wrong), so
a delta arriving while the previous one is still unsent turns the slot into "send
a FULL frame", which is built once per map sequence and shared by all clients.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
from collections.abc import Awaitable, Callable

from starlette.websockets import WebSocket

log = logging.getLogger(__name__)

FULL_MAP = object()  # slot marker: send the current full map frame


def compact(message: dict) -> str:
    """JSON as sent on the socket: no spaces, ``type`` first."""
    return json.dumps(message, separators=(",", ":"))


class Client:
    """One websocket and its slots (at most one pending frame per kind)."""

    def __init__(self, websocket: WebSocket, full_frame: Callable[[], bytes | None], send_timeout: float):
        self.websocket = websocket
        self.slots: dict[str, object] = {}
        self.wake = asyncio.Event()
        self.full_frame = full_frame
        self.send_timeout = send_timeout
        self.sent = 0
        self.dropped = 0
        self.closed = False

    def offer(self, kind: str, frame: object) -> None:
        if kind in self.slots:
            self.dropped += 1
        self.slots[kind] = frame
        self.wake.set()

    def offer_map(self, delta: bytes | None, empty: bool = False) -> None:
        """A map delta (or ``None`` for a full frame); see the module docstring.

        An ``empty`` delta (no tiles: the map is unchanged) never displaces a pending frame.
        """
        pending = self.slots.get("map")
        if empty and pending is not None:
            return
        if delta is None or pending is not None:
            if pending is not None and pending is not FULL_MAP:
                self.dropped += 1
            self.slots["map"] = FULL_MAP
        else:
            self.slots["map"] = delta
        self.wake.set()

    async def run_sender(self) -> None:
        """Send pending frames until the socket fails or is closed; a send may take ``send_timeout``."""
        ws = self.websocket
        try:
            while not self.closed:
                await self.wake.wait()
                self.wake.clear()
                while self.slots and not self.closed:
                    kind = next(iter(self.slots))
                    frame = self.slots.pop(kind)
                    if frame is FULL_MAP:
                        frame = self.full_frame()
                        if frame is None:
                            continue
                    binary = isinstance(frame, bytes)
                    send: Awaitable = ws.send_bytes(frame) if binary else ws.send_text(frame)
                    async with asyncio.timeout(self.send_timeout):
                        await send
                    self.sent += 1
        except (TimeoutError, RuntimeError, OSError) as exc:
            log.info("websocket client dropped: %s", type(exc).__name__)
        except Exception as exc:  # starlette's disconnect errors vary by server
            log.info("websocket client dropped: %r", exc)
        finally:
            self.closed = True


class Hub:
    """All connected clients; publish JSON objects or map frames to all of them."""

    def __init__(self, full_frame: Callable[[], bytes | None], send_timeout: float):
        self.clients: set[Client] = set()
        self.full_frame = full_frame
        self.send_timeout = send_timeout

    def add(self, websocket: WebSocket) -> Client:
        client = Client(websocket, self.full_frame, self.send_timeout)
        self.clients.add(client)
        return client

    def remove(self, client: Client) -> None:
        client.closed = True
        client.wake.set()
        self.clients.discard(client)

    def publish(self, kind: str, message: dict) -> None:
        """Send ``message`` (with ``type`` = ``kind``) to every client, newest-wins per kind."""
        if not self.clients:
            return
        text = compact({"type": kind, **message})
        for client in list(self.clients):
            client.offer(kind, text)

    def publish_map(self, delta: bytes | None, empty: bool = False) -> None:
        """A map delta frame, or ``None`` when every client needs the full map."""
        for client in list(self.clients):
            client.offer_map(delta, empty)

    async def close_all(self) -> None:
        for client in list(self.clients):
            self.remove(client)
            with contextlib.suppress(Exception):
                await client.websocket.close(code=1001)
