"""Mapping sessions: save the session so far under a name, list, continue one, delete.

A session is what the loop-closing back end works on (every update's pose, odometry and scan;
see :mod:`slam_core.session`), kept in ``DATA/sessions/NAME.session.npz``. Continuing one maps
on in its map: the worker first finds the robot in it, then new rooms join the same map and
loops close against the old part. Save and continue answer once the worker has done it (see
:mod:`app.api.routes.mode`).
"""

from typing import Annotated

from fastapi import APIRouter, Path, Response, status

from app.api import path_names  # noqa: F401  (registers {name:name})
from app.api.deps import RuntimeDep, SettingsDep
from app.api.errors import ApiError
from app.api.models import Ok, SavedSession, SessionBody, SessionName, Status
from app.api.replay_guard import NotReplaying
from app.api.routes.mode import apply
from app.worker.messages import ResumeSession, SaveSession
from slam_core.session import SUFFIX

router = APIRouter(prefix="/sessions", tags=["sessions"])

SessionNameParam = Annotated[SessionName, Path(description="the saved session's name")]


def _existing(settings, name: str):
    path = settings.session_file(name)
    if not path.is_file():
        raise ApiError(status.HTTP_404_NOT_FOUND, "not_found", f"no saved session named {name!r}")
    return path


@router.get("", response_model=list[SavedSession])
def read_sessions(settings: SettingsDep) -> list[dict]:
    """All saved sessions, newest first."""
    found = sorted(settings.sessions_dir.glob(f"*{SUFFIX}"), key=lambda p: p.stat().st_mtime, reverse=True)
    return [{"name": p.name[: -len(SUFFIX)], "saved": p.stat().st_mtime, "bytes": p.stat().st_size}
            for p in found]


@router.post("", response_model=Status, status_code=status.HTTP_201_CREATED, dependencies=[NotReplaying],
             responses={202: {"model": Status, "description": "the worker is still saving"}})
async def create_session(body: SessionBody, runtime: RuntimeDep, settings: SettingsDep,
                         response: Response) -> dict:
    """Save the mapping session so far as ``name`` (replacing a session of that name)."""
    settings.sessions_dir.mkdir(parents=True, exist_ok=True)
    answer = await apply(runtime, response, SaveSession(str(settings.session_file(body.name))),
                         refused="session_refused")
    if response.status_code != status.HTTP_202_ACCEPTED:
        response.status_code = status.HTTP_201_CREATED
    return answer


@router.post("/{name:name}/resume", response_model=Status, dependencies=[NotReplaying],
             responses={202: {"model": Status, "description": "the worker is still switching"}})
async def create_session_resume(name: SessionNameParam, runtime: RuntimeDep, settings: SettingsDep,
                                response: Response) -> dict:
    """Continue mapping in the saved session (mapping mode; the robot is found in its map first)."""
    return await apply(runtime, response, ResumeSession(str(_existing(settings, name))),
                       refused="session_refused")


@router.delete("/{name:name}", response_model=Ok)
def delete_session(name: SessionNameParam, settings: SettingsDep) -> dict:
    """Delete a saved session."""
    _existing(settings, name).unlink()
    return {"ok": True}
