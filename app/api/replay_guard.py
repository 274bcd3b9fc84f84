"""While a log replays, the robot cannot be driven: routes that would are refused with 409."""

from fastapi import Depends, status

from app.api.deps import RuntimeDep
from app.api.errors import ApiError


def refuse_during_replay(runtime: RuntimeDep) -> None:
    if runtime.settings.replay:
        raise ApiError(status.HTTP_409_CONFLICT, "replaying",
                       f"replaying the log {runtime.settings.replay!r}: a log cannot be driven, "
                       "so goals, teleop, the pose and the mode are refused")


NotReplaying = Depends(refuse_during_replay)
