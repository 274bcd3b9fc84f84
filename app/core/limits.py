"""Request hygiene as pure ASGI middleware: a body size limit (chunked bodies too, whether or not
the route reads them) and JSON bodies (no Content-Type means JSON; another type is a 415)."""

from __future__ import annotations

import json

BODY_METHODS = (b"POST", b"PUT", b"PATCH")


async def send_error(send, status: int, detail: str, reason: str) -> None:
    """The API's error body (``app.api.errors.ErrorBody``) straight from middleware."""
    body = json.dumps({"detail": detail, "reason": reason}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


class BodySizeLimit:
    """Answer 413 to any HTTP request whose body exceeds ``max_bytes``, declared or streamed.

    A declared ``Content-Length`` is checked up front (the server enforces it); any other body
    (chunked) is read before the app runs, at most ``max_bytes`` of it, and handed on whole, so a
    route that never reads its body refuses an oversized one too.
    """

    def __init__(self, app, max_bytes: int):
        self.app = app
        self.max_bytes = max_bytes

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        declared = dict(scope.get("headers", ())).get(b"content-length")
        if declared is not None:
            if declared.isdigit() and int(declared) > self.max_bytes:
                return await self._reject(send)
            return await self.app(scope, receive, send)
        body = bytearray()
        while True:
            message = await receive()
            if message["type"] != "http.request":  # the client went away
                return None
            body += message.get("body", b"")
            if len(body) > self.max_bytes:
                return await self._reject(send)
            if not message.get("more_body", False):
                break
        whole = [{"type": "http.request", "body": bytes(body), "more_body": False}]

        async def replay():
            return whole.pop() if whole else await receive()

        await self.app(scope, replay, send)

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
