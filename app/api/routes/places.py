"""Named places ("kitchen", "sofa"): create, list, rename, delete, go to."""

from typing import Annotated

from fastapi import APIRouter, Path, Response, status

from app.api import path_names  # noqa: F401  (registers {name:name})
from app.api.bounds import require_in_map
from app.api.deps import RuntimeDep, StoreDep
from app.api.errors import ApiError
from app.api.models import GoalResponse, Place, PlaceBody, PlaceName, PlacePatch
from app.api.routes.navigation import start_goal
from app.db import store as db
from app.navigation.navigator import Goal

router = APIRouter(prefix="/places", tags=["places"])

PlaceNameParam = Annotated[PlaceName, Path(description="the place's name")]


def _get(store: db.Store, name: str) -> db.Place:
    try:
        return store.get_place(name)
    except db.NotFound as exc:
        raise ApiError(status.HTTP_404_NOT_FOUND, "not_found", str(exc.args[0])) from None


@router.get("", response_model=list[Place])
def read_places(store: StoreDep) -> list[dict]:
    """All places, by name."""
    return [p.dict() for p in store.list_places()]


@router.post("", response_model=Place, status_code=status.HTTP_201_CREATED)
def create_place(body: PlaceBody, store: StoreDep, runtime: RuntimeDep) -> dict:
    """Add a place near the map (409 when the name is taken)."""
    require_in_map(runtime, body.x, body.y, "place")
    try:
        return store.add_place(db.Place(body.name, body.x, body.y, body.yaw)).dict()
    except db.AlreadyExists as exc:
        raise ApiError(status.HTTP_409_CONFLICT, "name_taken", str(exc)) from None


@router.get("/{name:name}", response_model=Place)
def read_place(store: StoreDep, name: PlaceNameParam) -> dict:
    """One place."""
    return _get(store, name).dict()


@router.patch("/{name:name}", response_model=Place)
def update_place(body: PlacePatch, store: StoreDep, runtime: RuntimeDep, name: PlaceNameParam) -> dict:
    """Rename or move a place (a moved place must lie near the map)."""
    old = _get(store, name)
    new = db.Place(body.name if body.name is not None else old.name,
                   body.x if body.x is not None else old.x,
                   body.y if body.y is not None else old.y,
                   body.yaw if body.yaw is not None else old.yaw)
    if body.x is not None or body.y is not None:
        require_in_map(runtime, new.x, new.y, "place")
    try:
        return store.update_place(old.name, new).dict()
    except db.AlreadyExists as exc:
        raise ApiError(status.HTTP_409_CONFLICT, "name_taken", str(exc)) from None
    except db.NotFound as exc:
        raise ApiError(status.HTTP_404_NOT_FOUND, "not_found", str(exc.args[0])) from None


@router.delete("/{name:name}", status_code=status.HTTP_204_NO_CONTENT, response_class=Response)
def delete_place(store: StoreDep, name: PlaceNameParam) -> Response:
    """Forget a place."""
    try:
        store.delete_place(name)
    except db.NotFound as exc:
        raise ApiError(status.HTTP_404_NOT_FOUND, "not_found", str(exc.args[0])) from None
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.post("/{name:name}/go", response_model=GoalResponse, status_code=status.HTTP_202_ACCEPTED)
async def create_place_goal(runtime: RuntimeDep, store: StoreDep, name: PlaceNameParam) -> dict:
    """Drive to the place and turn to its heading."""
    place = _get(store, name)
    return await start_goal(runtime, Goal(place.x, place.y, place.name, yaw=place.yaw))
