"""The FastAPI app: ``create_app(settings)`` with a lifespan that runs the robot pipeline."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.staticfiles import StaticFiles

from app.api import docs, errors
from app.api.main import api_router, ws_router
from app.core.config import Settings
from app.core.limits import BodySizeLimit, JsonBodies
from app.core.login_limit import LoginLimiter
from app.core.security import load_or_create_token
from app.db.sessions import Sessions
from app.runtime import Runtime
from app.smarthome import start_smart_home

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
        bridge = await start_smart_home(runtime)
        try:
            yield
        finally:
            if bridge is not None:
                await bridge.stop()
            await runtime.stop()

    app = FastAPI(title="homebot", version="0.1.0", lifespan=lifespan, docs_url=None, redoc_url=None,
                  description="A home robot's SLAM backend: live map, pose, goals, places, saved maps.")
    app.state.sessions, app.state.login_limiter = Sessions(settings.db_path), LoginLimiter()
    app.include_router(api_router)
    app.include_router(ws_router)
    errors.install(app)
    docs.install(app)

    if settings.cors_origins:
        # A wildcard origin never gets credentials: any site could then act with the user's cookie.
        credentials = "*" not in settings.cors_origins
        app.add_middleware(CORSMiddleware, allow_origins=settings.cors_origins, allow_credentials=credentials,
                           allow_methods=["GET", "POST", "PUT", "PATCH", "DELETE"],
                           allow_headers=["Authorization", "Content-Type"])
    app.add_middleware(JsonBodies)
    app.add_middleware(BodySizeLimit, max_bytes=settings.max_body_bytes)
    if STATIC_DIR.is_dir():
        app.mount("/", StaticFiles(directory=STATIC_DIR, html=True), name="static")
    return app
