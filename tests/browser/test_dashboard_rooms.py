"""Rooms, no-go zones and the legend in Debian's chromium against a real homebot server.

The rooms found on the live map are listed with their colours and drawn on the map with their
names; "Go" drives the robot to a room; a no-go zone and a virtual wall are drawn with the mouse
and land in the API; the legend explains the colours. The screenshot is test-artifacts/rooms.png.
"""

from __future__ import annotations

import time

import pytest

ZONE_EDGE_RGB = (220, 38, 38)  # rooms.js ZONE_EDGE
TIMEOUT_MS = 60_000

# In the page: how many canvas pixels the rooms-and-zones overlay changes.
OVERLAY_PIXELS_JS = """() => {
    const hb = window.homebot, c = hb.canvas, ctx = c.getContext('2d');
    const grab = () => {
        hb.renderer.draw();
        return new Uint32Array(ctx.getImageData(0, 0, c.width, c.height).data.buffer).slice();
    };
    const kept = hb.renderer.overlays;
    hb.renderer.overlays = [];
    const without = grab();
    hb.renderer.overlays = kept;
    const withIt = grab();
    let n = 0;
    for (let i = 0; i < withIt.length; i++) if (withIt[i] !== without[i]) n++;
    return n;
}"""

COLOUR_PIXELS_JS = """([r, g, b]) => {
    const hb = window.homebot, c = hb.canvas;
    hb.renderer.draw();
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let i = 0; i < d.length; i += 4) if (d[i] === r && d[i + 1] === g && d[i + 2] === b) n++;
    return n;
}"""


def _drive(server, x: float, y: float) -> None:
    assert server.api("POST", "goal", json={"x": x, "y": y}).status_code == 202
    deadline = time.monotonic() + 60
    while server.api("GET", "path").json()["state"] != "arrived":
        assert time.monotonic() < deadline, f"no arrival at ({x}, {y})"
        time.sleep(0.3)


def _click_world(page, x: float, y: float) -> None:
    sx, sy = page.evaluate("([x, y]) => window.homebot.view.worldToScreen(x, y)", [x, y])
    box = page.locator("#map").bounding_box()
    page.mouse.click(box["x"] + sx, box["y"] + sy)


@pytest.fixture(scope="module")
def dashboard(browser, homebot_server):
    for x in (2.2, 3.4, 4.6):  # map the hall on the way east, so there is a room to show
        _drive(homebot_server, x, 3.75)
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.js_errors = errors
    page.goto(f"{homebot_server.url}?token={homebot_server.token}")
    page.wait_for_function("window.homebot.state.online && window.homebot.state.map.ready",
                           timeout=TIMEOUT_MS)
    page.uncheck("[data-layer=scan]")  # the scan's red would look like a zone's edge
    page.uncheck("[data-layer=particles]")
    yield page
    context.close()


def test_rooms_are_listed_and_drawn_in_their_colours(dashboard, homebot_server):
    page = dashboard
    page.wait_for_selector("#rooms li", timeout=TIMEOUT_MS)
    deadline = time.monotonic() + 30  # the map still grows: the list catches up within a refresh
    while True:
        expected = sorted(r["name"] for r in homebot_server.api("GET", "rooms").json())
        names = sorted(page.locator("#rooms li .name").all_inner_texts())
        if names == expected or time.monotonic() > deadline:
            break
        time.sleep(0.5)
    assert names == expected
    colours = page.locator("#rooms li .swatch").evaluate_all("els => els.map(e => e.style.background)")
    assert len(set(colours)) == len(colours) and all(c.startswith("rgb") for c in colours)
    page.wait_for_function("window.homebot.roomsZones.image !== null", timeout=TIMEOUT_MS)
    assert page.evaluate(OVERLAY_PIXELS_JS) > 500  # the rooms' colours and names are on the canvas
    assert page.locator("#legend li").count() == 10
    assert "no-go zones" in page.locator("#legend").inner_text()


def test_a_room_is_renamed_in_the_list(dashboard, homebot_server):
    page = dashboard
    first = page.locator("#rooms li").first
    room = first.get_attribute("data-room")
    first.get_by_role("button", name="Rename").click()
    page.fill("#rooms form.rename input", "Hall")
    page.click("#rooms form.rename button[type=submit]")
    page.wait_for_selector(f"#rooms li[data-room='{room}'] .name:text-is('Hall')", timeout=TIMEOUT_MS)
    assert "Hall" in {r["name"] for r in homebot_server.api("GET", "rooms").json()}


def test_a_room_is_split_along_a_drawn_line_and_merged_back(dashboard, homebot_server):
    page = dashboard
    hall = page.locator("#rooms li", has=page.locator(".name:text-is('Hall')"))
    hall_id = int(hall.get_attribute("data-room"))
    before = {r["id"] for r in homebot_server.api("GET", "rooms").json()}
    hall.get_by_role("button", name="Split").click()
    assert "Split the room" in page.locator("#hint").inner_text()
    _click_world(page, 3.0, 2.9)  # across the hall (y 3.0 to 4.5) at x = 3
    _click_world(page, 3.0, 4.6)
    page.wait_for_function(f"document.querySelectorAll('#rooms li').length === {len(before) + 1}",
                           timeout=TIMEOUT_MS)
    rooms = {r["id"]: r for r in homebot_server.api("GET", "rooms").json()}
    (new,) = rooms.keys() - before
    assert rooms[new]["centroid"][0] < 3.0 < rooms[hall_id]["centroid"][0]  # the west part is new
    page.locator(f"#rooms li[data-room='{new}'] select").select_option(str(hall_id))
    page.wait_for_function(f"document.querySelectorAll('#rooms li').length === {len(before)}",
                           timeout=TIMEOUT_MS)
    assert {r["id"] for r in homebot_server.api("GET", "rooms").json()} == before


def test_go_drives_the_robot_to_the_room(dashboard, homebot_server):
    page = dashboard
    first = page.locator("#rooms li").first
    name = first.locator(".name").inner_text()
    first.get_by_role("button", name="Go").click()
    page.wait_for_function(f"window.homebot.state.path.goal?.place === {name!r}", timeout=TIMEOUT_MS)
    page.wait_for_function("window.homebot.state.path.state === 'arrived'", timeout=TIMEOUT_MS)
    assert homebot_server.api("GET", "status").json()["room"] == name
    # The robot's details name its room, and no path length is left over after arrival.
    page.wait_for_function(f"window.homebot.state.status?.room === {name!r} && "
                           "window.homebot.state.status?.nav?.state === 'arrived'", timeout=TIMEOUT_MS)
    details = dict(zip(page.locator("#details dt").all_inner_texts(),
                       page.locator("#details dd").all_inner_texts(), strict=True))
    assert details["room"] == name and details["path"] == "—"


def test_the_sidebar_shows_only_what_works_in_mapping_mode(dashboard, homebot_server):
    page = dashboard
    assert page.locator("#mode-map").is_hidden()  # "Map for localization": only in localization mode
    assert page.locator("[data-layer=landmarks]").is_hidden()  # landmarks: only in EKF mode
    assert page.locator("[data-layer=path]").is_visible()
    long_name = "the long sofa by the living room window"
    added = homebot_server.api("POST", "places", json={"name": long_name, "x": 2.0, "y": 3.8})
    assert added.status_code == 201
    page.evaluate("window.homebot.panels.refreshPlaces()")
    coords = page.locator(f"li.place[data-name='{long_name}'] .coords")
    coords.wait_for()
    assert coords.inner_text() == "(2.0, 3.8)"
    assert coords.evaluate("e => e.scrollWidth <= e.clientWidth")  # not cut off by the long name


def test_a_zone_and_a_wall_are_drawn_with_the_mouse(dashboard, homebot_server, artifacts):
    page = dashboard
    pose = page.evaluate("window.homebot.state.pose")
    corners = [(pose["x"] + 0.6, pose["y"] - 0.4), (pose["x"] + 1.2, pose["y"] - 0.4),
               (pose["x"] + 1.2, pose["y"] + 0.4), (pose["x"] + 0.6, pose["y"] + 0.4)]
    page.click("#zone-draw")
    assert "corners" in page.locator("#hint").inner_text()
    for x, y in corners:
        _click_world(page, x, y)
    page.click("#zone-finish")
    page.wait_for_selector("#zones li", timeout=TIMEOUT_MS)
    zones = homebot_server.api("GET", "zones").json()
    assert len(zones) == 1 and zones[0]["kind"] == "zone"
    for (x, y), (zx, zy) in zip(corners, zones[0]["points"], strict=True):
        assert abs(x - zx) < 0.05 and abs(y - zy) < 0.05
    assert page.evaluate(COLOUR_PIXELS_JS, list(ZONE_EDGE_RGB)) > 50

    page.click("#wall-draw")
    _click_world(page, pose["x"] - 0.5, pose["y"] - 0.6)
    _click_world(page, pose["x"] - 0.5, pose["y"] + 0.6)
    page.wait_for_function("document.querySelectorAll('#zones li').length === 2", timeout=TIMEOUT_MS)
    assert [z["kind"] for z in homebot_server.api("GET", "zones").json()] == ["zone", "wall"]
    page.screenshot(path=str(artifacts / "rooms.png"))

    page.locator("#zones li").first.locator("button").click()
    page.wait_for_function("document.querySelectorAll('#zones li').length === 1", timeout=TIMEOUT_MS)
    assert [z["kind"] for z in homebot_server.api("GET", "zones").json()] == ["wall"]
    assert page.js_errors == []
