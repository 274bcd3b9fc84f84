"""Estimator mode (mapping / localization / EKF) and mapping on/off.

A change answers once the worker has made it: 200 with the new status, 409 when the worker
refused it (with its reason), or 202 when it takes longer than ``switching.SWITCH_WAIT_S`` (the
``changed`` event follows on the stream and in ``api/status``).
"""

from fastapi import APIRouter, Response, status

from app.api.deps import RuntimeDep, StoreDep
from app.api.errors import ApiError
from app.api.models import ModeBody, ModeResponse, Status
from app.api.replay_guard import NotReplaying
from app.api.saved_maps import checked_map_file
from app.runtime import Runtime
from app.worker import switching
from app.worker.messages import Command, SetMapping

router = APIRouter(tags=["mode"])


def _answer(runtime: Runtime, response: Response, made: bool) -> dict:
    if not made:
        response.status_code = status.HTTP_202_ACCEPTED
    return runtime.status()


def _refused(exc: switching.SwitchRefused) -> ApiError:
    return ApiError(exc.status, exc.reason, str(exc))


async def apply(runtime: Runtime, response: Response, command: Command,
                refused: str = "mode_refused") -> dict:
    """Send a worker command and wait for its outcome (see the module docstring); ``refused`` is
    the reason of a 409."""
    try:
        return _answer(runtime, response, await switching.send_and_wait(runtime, command, refused))
    except switching.SwitchRefused as exc:
        raise _refused(exc) from None


async def switch_mode(runtime: Runtime, response: Response, mode: str, yaml_path: str | None = None,
                      map_name: str | None = None, new_map: bool = False) -> dict:
    try:
        made = await switching.switch_mode(runtime, mode, yaml_path, map_name, new_map)
    except switching.SwitchRefused as exc:
        raise _refused(exc) from None
    return _answer(runtime, response, made)


@router.get("/mode", response_model=ModeResponse)
def read_mode(runtime: RuntimeDep) -> ModeResponse:
    """The current estimator mode."""
    return ModeResponse(mode=runtime.mode, mapping=runtime.mapping)


@router.put("/mode", response_model=Status, dependencies=[NotReplaying], responses={202: {"model": Status,
                                                            "description": "the worker is still switching"}})
async def update_mode(body: ModeBody, runtime: RuntimeDep, store: StoreDep, response: Response) -> dict:
    """Switch mode, keeping the map; localization runs on a saved map (``map``) or on the current
    one; ``new_map: true`` (mapping only) starts an empty map."""
    yaml_path = None
    if body.map is not None:
        yaml_path = str(await checked_map_file(runtime, store, body.map))
    return await switch_mode(runtime, response, body.mode, yaml_path, body.map, body.new_map)


@router.post("/mapping/start", response_model=Status, dependencies=[NotReplaying],
             responses={202: {"model": Status, "description": "the worker is still switching"}})
async def create_mapping_start(runtime: RuntimeDep, response: Response) -> dict:
    """Map again (mapping mode, the map grows from where it is)."""
    return await apply(runtime, response, SetMapping(True))


@router.post("/mapping/stop", response_model=Status, dependencies=[NotReplaying],
             responses={202: {"model": Status, "description": "the worker is still switching"}})
async def create_mapping_stop(runtime: RuntimeDep, response: Response) -> dict:
    """Freeze the map; the pose follows odometry until mapping or localization starts."""
    return await apply(runtime, response, SetMapping(False))
