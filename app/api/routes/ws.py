"""The websocket ``ws``: live pose, particles, scan, path, status and binary map frames."""

import asyncio
import contextlib
import json
import logging

from fastapi import APIRouter, WebSocket, WebSocketDisconnect
from pydantic import ValidationError

from app.api.errors import validation_detail
from app.api.models import GoalBody, TeleopBody
from app.core.security import COOKIE_NAME, origin_allowed, token_matches
from app.db.store import NotFound
from app.navigation.navigator import Goal
from app.navigation.planning import PlanningError
from app.runtime import Runtime
from app.streaming.hub import compact

log = logging.getLogger(__name__)

PROTOCOL_VERSION = 1
UNAUTHORIZED_CLOSE = 4401
FORBIDDEN_ORIGIN_CLOSE = 4403
MAX_CLIENT_MESSAGE = 4096

router = APIRouter(tags=["stream"])


async def _handle(runtime: Runtime, client, text: str) -> None:
    """One client -> server message (goal, cancel, teleop, ping); errors go back as ``error``."""

    def reply(kind: str, body: dict) -> None:
        client.offer(kind, compact({"type": kind, **body}))

    try:
        if len(text) > MAX_CLIENT_MESSAGE:
            raise ValueError(f"message longer than {MAX_CLIENT_MESSAGE} characters")
        message = json.loads(text)
        if not isinstance(message, dict) or not isinstance(message.get("type"), str):
            raise ValueError("a message is a JSON object with a 'type'")
        kind = message.pop("type")
        if kind == "ping":
            reply("pong", message)
        elif kind == "cancel":
            runtime.navigator.take_over()
            runtime.navigator.cancel()
        elif kind == "teleop":
            body = TeleopBody(**message)
            runtime.navigator.teleop(body.v, body.w)
        elif kind == "goal":
            body = GoalBody(**message)
            if body.place is not None:
                place = runtime.store.get_place(body.place)
                goal = Goal(place.x, place.y, place.name, yaw=place.yaw, explore=body.explore)
            else:
                goal = Goal(body.x, body.y, yaw=body.yaw, explore=body.explore)
            await runtime.navigator.set_goal(goal)
        else:
            raise ValueError(f"unknown message type {kind!r}")
    except ValidationError as exc:
        reply("error", {"detail": validation_detail(exc), "reason": "invalid_request"})
    except NotFound as exc:
        reply("error", {"detail": str(exc.args[0]), "reason": "not_found"})
    except PlanningError as exc:
        reply("error", {"detail": str(exc), "reason": exc.reason})
    except (ValueError, TypeError) as exc:
        reply("error", {"detail": str(exc), "reason": "invalid_request"})


@router.websocket("/ws")
async def stream(websocket: WebSocket) -> None:
    """Check the page's Origin, authenticate (``?token=`` or the session cookie), then stream."""
    runtime: Runtime = websocket.app.state.runtime
    await websocket.accept()
    secure = websocket.url.scheme == "wss"
    if not origin_allowed(websocket.headers.get("origin"), websocket.headers.get("host"), secure,
                          runtime.settings.cors_origins):
        await websocket.close(code=FORBIDDEN_ORIGIN_CLOSE, reason="origin not allowed")
        return
    given = websocket.query_params.get("token")
    authorized = (token_matches(given, runtime.token) if given
                  else websocket.app.state.sessions.valid(websocket.cookies.get(COOKIE_NAME)))
    if not authorized:
        await websocket.close(code=UNAUTHORIZED_CLOSE, reason="missing or wrong token")
        return
    client = runtime.hub.add(websocket)
    client.offer("hello", compact({"type": "hello", "protocol": PROTOCOL_VERSION, "mode": runtime.mode,
                                   "tile_size": runtime.settings.tile_size, "token_ok": True}))
    client.offer("status", compact({"type": "status", **runtime.status()}))
    client.offer_map(None)
    sender = asyncio.create_task(client.run_sender())
    try:
        while not client.closed:
            receive = asyncio.ensure_future(websocket.receive_text())
            done, _ = await asyncio.wait({receive, sender}, return_when=asyncio.FIRST_COMPLETED)
            if receive not in done:
                receive.cancel()
                break
            await _handle(runtime, client, receive.result())
    except (WebSocketDisconnect, RuntimeError, KeyError):
        pass
    finally:
        runtime.hub.remove(client)
        sender.cancel()
        with contextlib.suppress(asyncio.CancelledError, Exception):
            await sender
        with contextlib.suppress(Exception):
            await websocket.close()
