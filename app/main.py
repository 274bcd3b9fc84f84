"""The FastAPI app: ``create_app(settings)`` with a lifespan that runs the robot pipeline."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.middleware.cors import CORSMiddleware
from fastapi.responses import JSONResponse
from fastapi.staticfiles import StaticFiles

from app.api.main import api_router, ws_router
from app.core.config import Settings
from app.core.limits import BodySizeLimit
from app.core.security import load_or_create_token
from app.runtime import Runtime

STATIC_DIR = Path(__file__).resolve().parent.parent / "static"


def create_app(settings: Settings | None = None, stop_server: Callable[[], None] | None = None) -> FastAPI:
    """The app; ``stop_server()`` ends the server gracefully (default: SIGTERM to this process)."""
    settings = settings or Settings()
    token, _ = load_or_create_token(settings.data_dir, settings.token)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        runtime = Runtime(settings, token, stop_server)
        app.state.runtime = runtime
        await runtime.start()
        try:
            yield
        finally:
            await runtime.stop()

    app = FastAPI(title="homebot", version="0.1.0", lifespan=lifespan,
                  description="A home robot's SLAM backend: live map, pose, goals, places, saved maps.")
    app.include_router(api_router)
    app.include_router(ws_router)

    @app.api_route("/api/{path:path}", methods=["GET", "POST", "PUT", "PATCH", "DELETE"],
                   include_in_schema=False)
    async def _unknown_api_route(path: str) -> JSONResponse:
        """An unknown API path is a 404 with a reason; it never falls through to the static files."""
        return JSONResponse({"detail": f"no API route /api/{path}"}, status_code=404)

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, exc: RequestValidationError) -> JSONResponse:
        """422 with a JSON-safe reason (also for bodies that are not JSON at all)."""
        errors = [{"loc": list(e.get("loc", ())), "msg": str(e.get("msg", "")), "type": e.get("type")}
                  for e in exc.errors()]
        return JSONResponse({"detail": errors}, status_code=422)

    if settings.cors_origins:
        app.add_middleware(CORSMiddleware, allow_origins=settings.cors_origins, allow_credentials=True,
                           allow_methods=["GET", "POST", "PUT", "PATCH", "DELETE"],
                           allow_headers=["Authorization", "Content-Type"])
    app.add_middleware(BodySizeLimit, max_bytes=settings.max_body_bytes)
    if STATIC_DIR.is_dir():
        app.mount("/", StaticFiles(directory=STATIC_DIR, html=True), name="static")
    return app
