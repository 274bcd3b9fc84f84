"""All routers: ``api/...`` (token required except health and login) and the websocket."""

from fastapi import APIRouter

from app.api.deps import Authorized
from app.api.errors import ERROR_RESPONSES, OPEN_ERROR_RESPONSES
from app.api.routes import (
    health,
    login,
    map,
    maps,
    mode,
    navigation,
    places,
    robot,
    rooms,
    sessions,
    status,
    ws,
    zones,
)

api_router = APIRouter(prefix="/api")
api_router.include_router(health.router, responses=OPEN_ERROR_RESPONSES)
api_router.include_router(login.router, responses=ERROR_RESPONSES)
for module in (status, robot, map, navigation, mode, places, maps, sessions, rooms, zones):
    api_router.include_router(module.router, dependencies=[Authorized], responses=ERROR_RESPONSES)

ws_router = ws.router
