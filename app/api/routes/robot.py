"""The robot's description, as its robot file gives it (the dashboard draws its footprint from it)."""

from fastapi import APIRouter

from app.api.deps import RuntimeDep
from app.api.models import RobotDescription

router = APIRouter(prefix="/robot", tags=["robot"])


@router.get("", response_model=RobotDescription)
def read_robot(runtime: RuntimeDep) -> dict:
    """Footprint radius, wheels, laser (its mount in the base frame) and limits; SI units."""
    return runtime.settings.robot_config().to_dict()
