"""Exchange the token for a browser session cookie (random, expiring, revoked by logout)."""

from fastapi import APIRouter, Request, Response, status

from app.api.deps import Authorized, LoginLimiterDep, RuntimeDep, SessionsDep
from app.api.errors import ApiError
from app.api.models import Login, Ok
from app.core.security import COOKIE_NAME, COOKIE_SAMESITE, token_matches

router = APIRouter(tags=["login"])


def _cookie_path(request: Request) -> str:
    return (request.scope.get("root_path") or "").rstrip("/") + "/"


@router.post("/login", response_model=Ok)
def create_login(body: Login, request: Request, response: Response, runtime: RuntimeDep,
                 sessions: SessionsDep, limiter: LoginLimiterDep) -> Ok:
    """Check the token and set the ``homebot_session`` cookie (429 after repeated wrong tokens)."""
    client = request.client.host if request.client else "unknown"
    wait = limiter.retry_after(client)
    if wait > 0:
        raise ApiError(status.HTTP_429_TOO_MANY_REQUESTS, "too_many_logins",
                       f"too many wrong tokens; try again in {wait:.0f} s",
                       headers={"Retry-After": str(max(1, round(wait)))})
    if not token_matches(body.token, runtime.token):
        limiter.failed(client)
        raise ApiError(status.HTTP_401_UNAUTHORIZED, "unauthorized", "wrong token")
    response.set_cookie(COOKIE_NAME, sessions.create(), max_age=int(sessions.lifetime_s), httponly=True,
                        samesite=COOKIE_SAMESITE, secure=request.url.scheme == "https",
                        path=_cookie_path(request))
    return Ok()


@router.post("/logout", response_model=Ok, dependencies=[Authorized])
def delete_login(request: Request, response: Response, sessions: SessionsDep) -> Ok:
    """End the browser session: the cookie's token stops working at once."""
    sessions.revoke(request.cookies.get(COOKIE_NAME))
    response.delete_cookie(COOKIE_NAME, path=_cookie_path(request), httponly=True, samesite=COOKIE_SAMESITE,
                           secure=request.url.scheme == "https")
    return Ok()
