"""Goals, the scripted tour, the current path, the initial pose and teleoperation."""

from fastapi import APIRouter, status

from app.api.bounds import require_in_map
from app.api.deps import RuntimeDep, StoreDep
from app.api.errors import ApiError
from app.api.models import GoalBody, GoalResponse, Ok, PathResponse, PoseBody, TeleopBody
from app.api.replay_guard import NotReplaying
from app.db.store import NotFound
from app.navigation.navigator import Goal
from app.navigation.planning import PlanningError
from app.runtime import Runtime
from app.worker.messages import SetPose

router = APIRouter(tags=["navigation"])


async def start_goal(runtime: Runtime, goal: Goal) -> dict:
    """Plan and start; 422 with the planner's reason when the goal cannot be reached."""
    try:
        return await runtime.navigator.set_goal(goal)
    except PlanningError as exc:
        raise ApiError(status.HTTP_422_UNPROCESSABLE_CONTENT, exc.reason, str(exc)) from None


def goal_for(body: GoalBody, store) -> Goal:
    """The goal a request names: a point (with an optional heading) or a stored place."""
    if body.place is None:
        return Goal(body.x, body.y, yaw=body.yaw, explore=body.explore)
    try:
        place = store.get_place(body.place)
    except NotFound as exc:
        raise ApiError(status.HTTP_404_NOT_FOUND, "not_found", str(exc.args[0])) from None
    return Goal(place.x, place.y, place.name, yaw=place.yaw, explore=body.explore)


@router.post("/goal", response_model=GoalResponse, status_code=status.HTTP_202_ACCEPTED,
             dependencies=[NotReplaying])
async def create_goal(body: GoalBody, runtime: RuntimeDep, store: StoreDep) -> dict:
    """Drive to ``{x, y[, yaw]}`` (metres, radians, map frame) or to a named ``{place}``.

    Goals in unexplored space are refused (``goal_in_unknown``) and paths avoid it, unless
    ``explore`` is true.
    """
    return await start_goal(runtime, goal_for(body, store))


@router.delete("/goal", response_model=Ok)
def delete_goal(runtime: RuntimeDep) -> Ok:
    """Cancel the goal and stop the robot."""
    runtime.navigator.take_over()
    runtime.navigator.cancel()
    return Ok()


@router.post("/tour", response_model=Ok, dependencies=[NotReplaying])
def create_tour(runtime: RuntimeDep) -> Ok:
    """Simulation only: cancel the goal and drive the world's scripted tour again from its start."""
    conflict = status.HTTP_409_CONFLICT
    if not runtime.settings.simulation:
        raise ApiError(conflict, "not_simulated", "only the simulated robot has a scripted tour")
    if not runtime.navigator.start_tour():
        raise ApiError(conflict, "no_tour", f"the world {runtime.settings.world!r} has no tour")
    return Ok()


@router.get("/path", response_model=PathResponse)
def read_path(runtime: RuntimeDep) -> dict:
    """The goal, the planned path and the navigation state."""
    return runtime.navigator.snapshot()


@router.post("/pose", response_model=Ok, dependencies=[NotReplaying])
def create_pose(body: PoseBody, runtime: RuntimeDep) -> Ok:
    """Set the initial pose (re-initialises the estimator around it); it must lie near the map."""
    require_in_map(runtime, body.x, body.y, "pose")
    if not runtime.supervisor.send(SetPose(body.x, body.y, body.yaw)):
        raise ApiError(status.HTTP_503_SERVICE_UNAVAILABLE, "worker_unavailable",
                       "the worker is not accepting commands")
    return Ok()


@router.post("/teleop", response_model=Ok, dependencies=[NotReplaying])
def create_teleop(body: TeleopBody, runtime: RuntimeDep) -> Ok:
    """Drive by hand: ``v`` m/s, ``w`` rad/s for half a second (send repeatedly); cancels a goal."""
    runtime.navigator.teleop(body.v, body.w)
    return Ok()
