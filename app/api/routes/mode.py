"""Estimator mode (mapping / localization / EKF) and mapping on/off."""

from fastapi import APIRouter, HTTPException, status

from app.api.deps import RuntimeDep, StoreDep
from app.api.models import ModeBody, ModeResponse, Status
from app.db.store import NotFound
from app.runtime import Runtime
from app.worker.estimators import available_modes

router = APIRouter(tags=["mode"])


def send_mode(runtime: Runtime, mode: str, yaml_path: str | None = None, map_name: str | None = None,
              new_map: bool = False) -> None:
    if mode not in available_modes():
        have = ", ".join(available_modes())
        raise HTTPException(status.HTTP_409_CONFLICT, f"mode {mode!r} is not available (have: {have})")
    if not runtime.supervisor.send("mode", mode, yaml_path, map_name, new_map):
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, "the worker is not accepting commands")
    runtime.mode = mode


@router.get("/mode", response_model=ModeResponse)
def read_mode(runtime: RuntimeDep) -> ModeResponse:
    """The current estimator mode."""
    return ModeResponse(mode=runtime.mode, mapping=runtime.mapping)


@router.put("/mode", response_model=Status)
def update_mode(body: ModeBody, runtime: RuntimeDep, store: StoreDep) -> dict:
    """Switch mode, keeping the map; localization runs on a saved map (``map``) or on the current
    one; ``new_map: true`` (mapping only) starts an empty map."""
    yaml_path = None
    if body.map is not None:
        try:
            store.get_map(body.map)
        except NotFound as exc:
            raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc.args[0])) from None
        yaml_path = str(runtime.settings.maps_dir / f"{body.map}.yaml")
    send_mode(runtime, body.mode, yaml_path, body.map, body.new_map)
    return runtime.status()


@router.post("/mapping/start", response_model=Status)
def create_mapping_start(runtime: RuntimeDep) -> dict:
    """Map again (mapping mode, the map grows from where it is)."""
    runtime.supervisor.send("mapping", True)
    runtime.mode, runtime.mapping = "mapping", True
    return runtime.status()


@router.post("/mapping/stop", response_model=Status)
def create_mapping_stop(runtime: RuntimeDep) -> dict:
    """Freeze the map; the pose follows odometry until mapping or localization starts."""
    runtime.supervisor.send("mapping", False)
    runtime.mapping = False
    return runtime.status()
