"""The one open route: is the server up?"""

from fastapi import APIRouter

from app.api.models import Health

VERSION = "0.1.0"

router = APIRouter(prefix="/health", tags=["health"])


@router.get("", response_model=Health)
def read_health() -> Health:
    """Liveness check (no token needed)."""
    return Health(status="ok", version=VERSION)
