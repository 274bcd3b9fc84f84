import itertools

import numpy as np
import pytest

from slam_core.sim.raycast import cast_rays, clearance
from slam_core.sim.world import WorldFormatError, load_world, parse_world, world_names

MINIMAL = """
name box
start 1 1 90
room only 0 0 4 3
"""


def test_shipped_worlds_are_listed_and_load_by_name_and_path():
    assert {"flat", "house"} <= set(world_names())
    flat = load_world("flat")
    again = load_world(flat.source)
    assert flat.name == "flat" and np.array_equal(flat.segments, again.segments)


def test_flat_has_rooms_doors_furniture_and_legs():
    w = load_world("flat")
    assert len(w.furniture) >= 8 and len(w.circles) >= 12 and len(w.waypoints) >= 10
    x0, y0, x1, y1 = w.bounds()
    assert (x0, y0, x1, y1) == (0.0, 0.0, 10.0, 8.0)
    # the hall-kitchen door (x 2.5..3.3 on y = 3) is open: a ray from the hall straight
    # south through it reaches the kitchen counter (top edge y = 0.6), 3.15 m away
    r = cast_rays([2.9, 3.75, -np.pi / 2], [0.0], w.segments, w.circles)[0]
    assert r == pytest.approx(3.75 - 0.6)
    # one metre west the wall is closed: 0.75 m to the hall's south wall
    r = cast_rays([1.9, 3.75, -np.pi / 2], [0.0], w.segments, w.circles)[0]
    assert r == pytest.approx(0.75)


def test_house_corridor_is_a_loop():
    """Going round the corridor centreline never touches a wall: the loop is closed and open."""
    w = load_world("house")
    corners = np.array([[3.75, 3.75], [16.25, 3.75], [16.25, 10.25], [3.75, 10.25], [3.75, 3.75]])
    for a, b in itertools.pairwise(corners):
        for t in np.linspace(0, 1, 200):
            p = a + t * (b - a)
            assert clearance(p[0], p[1], w.segments, w.circles) > 0.3


@pytest.mark.parametrize("name", ["flat", "house"])
def test_tour_legs_are_collision_free(name):
    """Every straight leg of the scripted tour keeps the robot disc (0.17 m) plus margin off all geometry."""
    w = load_world(name)
    pts = np.vstack([w.start[:2], w.tour])
    for a, b in itertools.pairwise(pts):
        n = max(2, int(np.hypot(*(b - a)) / 0.02))
        for t in np.linspace(0, 1, n):
            p = a + t * (b - a)
            assert clearance(p[0], p[1], w.segments, w.circles) > 0.25, (name, a, b)


def test_door_cuts_a_gap_in_both_shared_walls():
    text = MINIMAL + "room other 4 0 8 3\ndoor 4 1 4 2\n"
    w = parse_world(text)
    vertical = w.segments[(w.segments[:, 0] == 4) & (w.segments[:, 2] == 4)]
    ys = sorted((min(s[1], s[3]), max(s[1], s[3])) for s in vertical)
    assert ys == [(0, 1), (0, 1), (2, 3), (2, 3)]


def test_minimal_world_fields():
    extra = "leg 2 2 0.05 0.7\ntable t 1 1 2 2\nwaypoint a 2 1\nfurniture box 0.5 3 2 3.5 2 3.5 2.5\n"
    w = parse_world(MINIMAL + extra)
    assert w.name == "box" and w.start[2] == pytest.approx(np.pi / 2)
    assert len(w.segments) == 4 + 3 and w.wall_count == 4  # room walls + triangle edges
    assert w.circles.shape == (5, 3) and np.allclose(w.circle_heights[0], 0.7)
    assert w.landmarks.shape == (5, 2) and w.tour.tolist() == [[2.0, 1.0]]
    low, _ = w.obstacles(min_height=0.6)
    assert len(low) == 4  # the 0.5 m box is below a sensor at 0.6 m


@pytest.mark.parametrize("text, line, words", [
    ("start 1 1 0\nroom r 0 0 4 3\nwal 0 0 1 1\n", 3, "unknown statement"),
    ("start 1 1\nroom r 0 0 4 3\n", 1, "expected 3 numbers"),
    ("start 1 1 0\nroom r 0 0 4 3\ndoor 1 1 2 2\n", 3, "does not lie on any wall"),
    ("start 1 1 0\nroom r 0 0 x 3\n", 2, "'x' is not a number"),
    ("start 1 1 0\nwall 0 0 1 1 2\n", 2, "x y pairs"),
    ("room r 0 0 4 3\n", 1, "no 'start"),
    ("start 1 1 0\nroom r 4 0 0 3\n", 2, "x0 < x1"),
    ("start 1 1 0\nroom r 0 0 4 3\nwaypoint a 1 1\nwaypoint a 2 2\n", 4, "used twice"),
])
def test_errors_name_the_line(text, line, words):
    with pytest.raises(WorldFormatError) as err:
        parse_world(text, source="home.txt")
    assert err.value.line == line and words in str(err.value) and "home.txt:" in str(err.value)


def test_user_file_and_unknown_name(tmp_path):
    f = tmp_path / "mine.txt"
    f.write_text(MINIMAL)
    assert load_world(f).name == "box"
    with pytest.raises(FileNotFoundError, match="flat"):
        load_world("no-such-world")
