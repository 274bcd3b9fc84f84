"""One error body for every failure: ``{"detail": "what went wrong", "reason": "machine_word"}``.

Routes raise :class:`ApiError` (or FastAPI's ``HTTPException``, which gets the status's
default reason); :func:`install` turns those, validation errors, unknown paths and wrong
methods into that body. ``ERROR_RESPONSES`` documents it in the OpenAPI of every route.
"""

from __future__ import annotations

from fastapi import FastAPI, HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field, ValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match, Mount

#: The reason an error gets when the code raising it did not name one.
DEFAULT_REASONS = {
    400: "body_not_json", 401: "unauthorized", 403: "forbidden", 404: "not_found",
    405: "method_not_allowed", 409: "conflict", 413: "body_too_large", 415: "unsupported_media_type",
    422: "invalid_request", 429: "too_many_requests", 500: "internal_error", 503: "unavailable",
}


class ErrorBody(BaseModel):
    """Every error answer (4xx and 5xx)."""

    detail: str = Field(description="What went wrong, for a person")
    reason: str = Field(description="What went wrong, for a program (e.g. `goal_in_unknown`, `not_found`)")


class ApiError(HTTPException):
    """An HTTP error with a machine-readable ``reason``."""

    def __init__(self, status_code: int, reason: str, detail: str, headers: dict | None = None):
        super().__init__(status_code, detail, headers)
        self.reason = reason


def error_response(status_code: int, detail: str, reason: str | None = None,
                   headers: dict | None = None) -> JSONResponse:
    body = {"detail": detail, "reason": reason or DEFAULT_REASONS.get(status_code, "error")}
    return JSONResponse(body, status_code=status_code, headers=headers)


def _described(*codes: int) -> dict:
    return {code: {"model": ErrorBody, "description": DEFAULT_REASONS[code].replace("_", " ")}
            for code in codes}


#: Errors any token-protected route may answer.
ERROR_RESPONSES = _described(400, 401, 404, 405, 409, 413, 415, 422, 429, 503)
#: Errors of the open routes (no token).
OPEN_ERROR_RESPONSES = _described(400, 404, 405, 413, 415, 422, 429, 503)


def validation_detail(exc: RequestValidationError | ValidationError) -> str:
    """``body.x: Input should be a finite number; ...`` from pydantic's error list."""
    parts = []
    for error in exc.errors():
        where = ".".join(str(p) for p in error.get("loc", ()))
        message = str(error.get("msg", "invalid"))
        message = message.removeprefix("Value error, ")
        parts.append(f"{where}: {message}" if where else message)
    return "; ".join(parts) or "invalid request"


HTTP_METHODS = ("GET", "POST", "PUT", "PATCH", "DELETE")


def _allowed_methods(app: FastAPI, scope: dict) -> set[str]:
    """The methods some documented route answers on this request's path (for 405 and ``Allow``)."""
    routes = [r for r in app.router.routes
              if getattr(r, "include_in_schema", True) and not isinstance(r, Mount)]
    allowed = set()
    for method in HTTP_METHODS:
        probe = {**scope, "method": method}
        if any(route.matches(probe)[0] == Match.FULL for route in routes):
            allowed.add(method)
    return allowed


def install(app: FastAPI) -> None:
    """Error handlers and the catch-all for unknown ``/api`` paths."""

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        detail = exc.detail if isinstance(exc.detail, str) else str(exc.detail)
        return error_response(exc.status_code, detail, getattr(exc, "reason", None), exc.headers)

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        return error_response(422, validation_detail(exc), "invalid_request")

    @app.api_route("/api/{path:path}", methods=["GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"],
                   include_in_schema=False)
    async def _unknown_api_route(path: str, request: Request) -> JSONResponse:
        """A wrong method is a 405 (with ``Allow``), an unknown path a 404; never the static files."""
        allowed = _allowed_methods(app, request.scope)
        if allowed:
            methods = ", ".join(sorted(allowed))
            return error_response(405, f"{request.method} is not allowed on /api/{path}; use {methods}",
                                  headers={"Allow": methods})
        return error_response(404, f"no API route /api/{path}")
