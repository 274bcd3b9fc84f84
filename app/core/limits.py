"""Request hygiene as pure ASGI middleware: a body size limit (streamed bodies counted too, not just
Content-Length) and JSON bodies (no Content-Type means JSON; another type is a 415)."""

from __future__ import annotations

import json

BODY_METHODS = (b"POST", b"PUT", b"PATCH")


class BodyTooLarge(Exception):
    pass


async def send_error(send, status: int, detail: str, reason: str) -> None:
    """The API's error body (``app.api.errors.ErrorBody``) straight from middleware."""
    body = json.dumps({"detail": detail, "reason": reason}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


class BodySizeLimit:
    """Answer 413 to any HTTP request whose body exceeds ``max_bytes``, declared or streamed."""

    def __init__(self, app, max_bytes: int):
        self.app = app
        self.max_bytes = max_bytes

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        for name, value in scope.get("headers", ()):
            if name == b"content-length" and value.isdigit() and int(value) > self.max_bytes:
                return await self._reject(send)
        seen = 0
        exceeded = started = False

        async def limited_receive():
            nonlocal seen, exceeded
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > self.max_bytes:
                    exceeded = True
                    raise BodyTooLarge
            return message

        async def tracking_send(message):
            # The app may turn the aborted read into its own error answer: send the 413 instead.
            nonlocal started
            if exceeded:
                if message["type"] == "http.response.start" and not started:
                    started = True
                    await self._reject(send)
                return
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        try:
            await self.app(scope, limited_receive, tracking_send)
        except BodyTooLarge:
            if not started:
                await self._reject(send)

    async def _reject(self, send) -> None:
        await send_error(send, 413, f"request body larger than {self.max_bytes} bytes", "body_too_large")


class JsonBodies:
    """A body without Content-Type is read as JSON; a body of another type is refused with 415."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or scope["method"].encode() not in BODY_METHODS:
            return await self.app(scope, receive, send)
        headers = dict(scope.get("headers", ()))
        has_body = headers.get(b"content-length", b"0") not in (b"0", b"") or b"transfer-encoding" in headers
        content_type = headers.get(b"content-type", b"").split(b";")[0].strip().lower()
        if has_body and not content_type:
            scope = {**scope, "headers": [*scope["headers"], (b"content-type", b"application/json")]}
        elif has_body and content_type != b"application/json" and not content_type.endswith(b"+json"):
            return await send_error(send, 415, "send the body as JSON (Content-Type: application/json)",
                                    "unsupported_media_type")
        await self.app(scope, receive, send)
