"""The one open route: is the server up, and is the robot fit to work?"""

from fastapi import APIRouter, Request

from app.api.models import Health

VERSION = "0.1.0"

router = APIRouter(prefix="/health", tags=["health"])


def degraded_reasons(runtime) -> list[str]:
    """Why the robot cannot be trusted right now (empty when all is well)."""
    if runtime is None or runtime.supervisor is None:
        return ["starting"]
    worker = runtime.supervisor.health
    reasons = []
    if worker.crash_looping:
        reasons.append(f"worker crash-looping ({worker.failures} failed starts in a row; "
                       f"last error: {worker.last_error})")
    elif not worker.alive:
        reasons.append("worker not running (restarting)")
    latest = runtime.latest
    if runtime.preparing is not None:
        p = runtime.preparing
        reasons.append(f"preparing the estimator {p['done'] + 1}/{p['total']}: {p['stage']}")
    elif latest is None:
        reasons.append("no pose yet (worker starting)")
    elif latest.relocalizing:
        reasons.append("not localized: looking for the robot in the restored map; mapping paused")
    elif not latest.localized:
        reasons.append("not localized")
    return reasons


@router.get("", response_model=Health)
def read_health(request: Request) -> Health:
    """Liveness and fitness (no token needed): ``ok``, or ``degraded`` with the reasons."""
    reasons = degraded_reasons(getattr(request.app.state, "runtime", None))
    return Health(status="degraded" if reasons else "ok", version=VERSION, reasons=reasons)
