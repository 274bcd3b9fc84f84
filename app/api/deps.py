"""Dependencies shared by routes: the runtime, the store, and token authentication."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, HTTPException, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from app.core.config import Settings
from app.core.security import COOKIE_NAME, token_matches
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


SettingsDep = Annotated[Settings, Depends(get_settings)]
StoreDep = Annotated[Store, Depends(get_store)]


def require_token(request: Request, runtime: RuntimeDep,
                  credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)]) -> None:
    """Accept the bearer header or the login cookie; 401 otherwise."""
    given = credentials.credentials if credentials else request.cookies.get(COOKIE_NAME)
    if not token_matches(given, runtime.token):
        raise HTTPException(status.HTTP_401_UNAUTHORIZED, "missing or wrong token",
                            headers={"WWW-Authenticate": "Bearer"})


Authorized = Depends(require_token)
