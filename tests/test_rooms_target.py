"""Go to a room: the target is a point inside the room that the planner can reach from the robot,
also when a no-go zone covers the room's middle; a room cut off by a virtual wall is refused."""

from __future__ import annotations

import numpy as np
import pytest

from app.navigation.planning import navigable_costmap, plan_path
from app.rooms.service import room_centre
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.planning.zones import NoGoZone, Restrictions, VirtualWall
from slam_core.rooms.layout import RoomLayout
from slam_core.rooms.target import RoomUnreachable, room_target

RES = 0.05
RADIUS = 0.2
WEST, EAST = 1, 2
#: The middle of the east room (x 4..8, y 0..4) and a zone over it that leaves a strip by the south wall.
ZONE = NoGoZone(((4.5, 1.0), (8.5, 1.0), (8.5, 4.5), (4.5, 4.5)))
DOOR_WALL = VirtualWall((4.0, 1.3), (4.0, 2.7))


@pytest.fixture(scope="module")
def home() -> tuple[OccupancyGrid, RoomLayout]:
    """Two 4 x 4 m rooms side by side, a 1 m door at y 1.5..2.5 in the wall at x = 4."""
    nx, ny = int(8 / RES) + 2, int(4 / RES) + 2
    data = np.full((ny, nx), -2.0, np.float32)
    data[[0, -1], :] = data[:, [0, -1]] = 2.0
    wall = int(4 / RES)
    data[:, wall] = 2.0
    data[int(1.5 / RES):int(2.5 / RES), wall] = -2.0
    grid = OccupancyGrid(RES, (-RES, -RES), data=data)
    labels = np.zeros((ny, nx), np.int32)
    free = data < 0
    labels[:, :wall][free[:, :wall]] = WEST
    labels[:, wall + 1:][free[:, wall + 1:]] = EAST
    return grid, RoomLayout(labels, (-RES, -RES), RES, next_id=3)


def _target(home, restrictions: Restrictions, start=(1.0, 2.0), room=EAST):
    grid, layout = home
    return room_target(layout, room, navigable_costmap(grid, restrictions, robot_radius=RADIUS), start)


def _drivable(home, restrictions: Restrictions, start, goal) -> bool:
    path = plan_path(home[0], np.array([*start, 0.0]), goal, restrictions, robot_radius=RADIUS)
    return np.allclose(path[-1], goal)


def test_without_zones_the_target_is_the_rooms_middle(home):
    x, y = _target(home, Restrictions())
    assert home[1].room_at(x, y) == EAST
    assert abs(x - 6.0) < 0.15 and abs(y - 2.0) < 0.15
    assert _drivable(home, Restrictions(), (1.0, 2.0), (x, y))


def test_a_zone_over_the_middle_moves_the_target_to_a_reachable_point_of_the_room(home):
    restrictions = Restrictions(zones=(ZONE,))
    assert ZONE.contains(np.array(room_centre(home[1], EAST)))  # where the robot used to be sent
    x, y = _target(home, restrictions)
    assert home[1].room_at(x, y) == EAST and not ZONE.contains(np.array([x, y]))
    assert _drivable(home, restrictions, (1.0, 2.0), (x, y))


def test_a_start_against_a_wall_still_finds_the_room(home):
    x, y = _target(home, Restrictions(), start=(0.05, 0.05))
    assert home[1].room_at(x, y) == EAST


def test_a_room_cut_off_by_a_virtual_wall_is_refused_with_a_reason(home):
    with pytest.raises(RoomUnreachable, match="no part of room 'Room 2' can be reached") as refused:
        _target(home, Restrictions(walls=(DOOR_WALL,)))
    assert refused.value.reason == "room_unreachable"
    x, y = _target(home, Restrictions(walls=(DOOR_WALL,)), room=WEST)  # its own room still is
    assert home[1].room_at(x, y) == WEST


def test_an_unknown_room_is_a_key_error(home):
    with pytest.raises(KeyError, match="no room with id 9"):
        _target(home, Restrictions(), room=9)
