"""Robot status and the exit signal."""

import os
import signal

from fastapi import APIRouter

from app.api.deps import RuntimeDep
from app.api.models import Ok, Status

router = APIRouter(tags=["status"])


@router.get("/status", response_model=Status)
def read_status(runtime: RuntimeDep) -> dict:
    """Mode, pose, localized flag, worker health, map size, navigation, rates."""
    return runtime.status()


@router.post("/shutdown", response_model=Ok)
def create_shutdown() -> Ok:
    """Save the map (PGM + YAML + PNG) and stop the server."""
    os.kill(os.getpid(), signal.SIGTERM)
    return Ok()
