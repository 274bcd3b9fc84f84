"""Estimator mode (mapping / localization / EKF) and mapping on/off.

A change answers once the worker has made it: 200 with the new status, 409 when the worker
refused it (with its reason), or 202 when it takes longer than ``SWITCH_WAIT_S`` (the
``changed`` event follows on the stream and in ``api/status``).
"""

import asyncio
import time

from fastapi import APIRouter, Response, status

from app.api.deps import RuntimeDep, StoreDep
from app.api.errors import ApiError
from app.api.models import ModeBody, ModeResponse, Status
from app.api.replay_guard import NotReplaying
from app.api.saved_maps import checked_map_file
from app.runtime import Runtime
from app.worker.estimators import available_modes
from app.worker.messages import Command, SetMapping, SetMode

router = APIRouter(tags=["mode"])

#: How long a request waits for the worker to confirm a change before answering 202.
SWITCH_WAIT_S = 15.0
POLL_S = 0.05
#: Worker events that end the wait: the change happened, or it did not.
DONE_EVENTS = ("changed", "error", "crashed", "restarted")


def _events_after(runtime: Runtime, marker: dict | None) -> list[dict]:
    events = list(runtime.events)
    for i in range(len(events) - 1, -1, -1):
        if events[i] is marker:
            return events[i + 1:]
    return events if marker is None else []


async def apply(runtime: Runtime, response: Response, command: Command,
                refused: str = "mode_refused") -> dict:
    """Send a worker command and wait for its outcome (see the module docstring); ``refused`` is
    the reason of a 409."""
    marker = runtime.events[-1] if runtime.events else None
    if not runtime.supervisor.send(command):
        raise ApiError(status.HTTP_503_SERVICE_UNAVAILABLE, "worker_unavailable",
                       "the worker is not accepting commands")
    deadline = time.monotonic() + SWITCH_WAIT_S
    while time.monotonic() < deadline:
        await asyncio.sleep(POLL_S)
        done = [e for e in _events_after(runtime, marker) if e.get("event") in DONE_EVENTS]
        if not done:
            continue
        event = done[0]
        if event["event"] == "changed":
            return runtime.status()
        if event["event"] == "error":
            raise ApiError(status.HTTP_409_CONFLICT, refused, str(event.get("detail")))  # paths as DATA/...
        raise ApiError(status.HTTP_503_SERVICE_UNAVAILABLE, "worker_restarting",
                       "the worker stopped while switching; it restarts from its checkpoint")
    response.status_code = status.HTTP_202_ACCEPTED
    return runtime.status()


async def switch_mode(runtime: Runtime, response: Response, mode: str, yaml_path: str | None = None,
                      map_name: str | None = None, new_map: bool = False) -> dict:
    if mode not in available_modes():
        have = ", ".join(available_modes())
        raise ApiError(status.HTTP_409_CONFLICT, "mode_unavailable",
                       f"mode {mode!r} is not available (have: {have})")
    if mode == "localization" and yaml_path is None and runtime.current_grid() is None:
        raise ApiError(status.HTTP_409_CONFLICT, "no_map", "there is no map to localize on yet")
    return await apply(runtime, response, SetMode(mode, yaml_path, map_name, new_map))


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
