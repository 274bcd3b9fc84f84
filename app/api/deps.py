"""Dependencies shared by routes: the runtime, the store, sessions, and token authentication."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from app.api.errors import ApiError
from app.core.config import Settings
from app.core.login_limit import LoginLimiter
from app.core.security import COOKIE_NAME, token_matches
from app.db.sessions import Sessions
from app.db.store import Store
from app.runtime import Runtime

bearer = HTTPBearer(auto_error=False, description="The token printed at first start")


def get_runtime(request: Request) -> Runtime:
    return request.app.state.runtime


RuntimeDep = Annotated[Runtime, Depends(get_runtime)]


def get_settings(runtime: RuntimeDep) -> Settings:
    return runtime.settings


def get_store(runtime: RuntimeDep) -> Store:
    return runtime.store


def get_sessions(request: Request) -> Sessions:
    return request.app.state.sessions


def get_login_limiter(request: Request) -> LoginLimiter:
    return request.app.state.login_limiter


SettingsDep = Annotated[Settings, Depends(get_settings)]
StoreDep = Annotated[Store, Depends(get_store)]
SessionsDep = Annotated[Sessions, Depends(get_sessions)]
LoginLimiterDep = Annotated[LoginLimiter, Depends(get_login_limiter)]


def require_token(request: Request, runtime: RuntimeDep, sessions: SessionsDep,
                  credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)]) -> None:
    """Accept the bearer header (the permanent token) or a live session cookie; 401 otherwise."""
    if credentials is not None:
        ok = token_matches(credentials.credentials, runtime.token)
    else:
        ok = sessions.valid(request.cookies.get(COOKIE_NAME))
    if not ok:
        raise ApiError(status.HTTP_401_UNAUTHORIZED, "unauthorized", "missing or wrong token",
                       headers={"WWW-Authenticate": "Bearer"})


Authorized = Depends(require_token)
