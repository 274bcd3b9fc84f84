"""Exchange the token for an HttpOnly cookie (the browser's way in)."""

from fastapi import APIRouter, HTTPException, Request, Response, status

from app.api.deps import Authorized, RuntimeDep
from app.api.models import Login, Ok
from app.core.security import COOKIE_NAME, token_matches

COOKIE_MAX_AGE_S = 30 * 24 * 3600

router = APIRouter(tags=["login"])


def _cookie_path(request: Request) -> str:
    return (request.scope.get("root_path") or "").rstrip("/") + "/"


@router.post("/login", response_model=Ok)
def create_login(body: Login, request: Request, response: Response, runtime: RuntimeDep) -> Ok:
    """Check the token and set the ``homebot_token`` cookie."""
    if not token_matches(body.token, runtime.token):
        raise HTTPException(status.HTTP_401_UNAUTHORIZED, "wrong token")
    response.set_cookie(COOKIE_NAME, runtime.token, max_age=COOKIE_MAX_AGE_S, httponly=True,
                        samesite="strict", secure=request.url.scheme == "https", path=_cookie_path(request))
    return Ok()


@router.post("/logout", response_model=Ok, dependencies=[Authorized])
def delete_login(request: Request, response: Response) -> Ok:
    """Clear the cookie."""
    response.delete_cookie(COOKIE_NAME, path=_cookie_path(request))
    return Ok()
