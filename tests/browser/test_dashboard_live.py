"""The dashboard in Debian's chromium against a real homebot server in simulation mode.

Most tests share one page, signed in by its fixture: watch the map grow, click a goal, see the path
drawn and the robot's marker move toward it, drive by hand, take the screenshot, survive a server
restart. Each also passes alone. Checks read the canvas pixels the user sees, not only the page's
state.
"""

from __future__ import annotations

import math
import time

import pytest

ROBOT_RGB = [(15, 118, 110), (180, 83, 9)]  # renderer.js COLORS.robot, robotLost
PATH_RGB = (37, 99, 235)  # renderer.js COLORS.path
GOAL_MIN_M, GOAL_MAX_M = 1.0, 2.5  # how far from the robot the clicked goal is
CLEARANCE_M = 0.35
STREAM_TIMEOUT_MS = 20_000
TELEOP_TIMEOUT_MS = 15_000
PLAN_TIMEOUT_MS = 60_000  # the first goal compiles the planner's kernels when numba's cache is cold

# In the page: how many canvas pixels show a known map cell (exact palette colours 0..100 %).
KNOWN_PIXELS_JS = """async () => {
    const { PALETTE } = await import('./js/maptiles.js');
    const known = new Set(Array.from(PALETTE.subarray(0, 101)));
    const hb = window.homebot;
    hb.renderer.draw();
    const c = hb.canvas;
    const pixels = new Uint32Array(c.getContext('2d').getImageData(0, 0, c.width, c.height).data.buffer);
    let n = 0;
    for (const p of pixels) if (known.has(p)) n++;
    return n;
}"""

# In the page: centroid (CSS px) of the robot marker's pixels, drawn now.
MARKER_JS = """(colors) => {
    const hb = window.homebot;
    hb.renderer.draw();
    const c = hb.canvas, dpr = hb.renderer.dpr;
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let sx = 0, sy = 0, n = 0;
    for (let i = 0; i < d.length; i += 4) {
        if (colors.some(([r, g, b]) => d[i] === r && d[i + 1] === g && d[i + 2] === b)) {
            const k = i / 4; sx += k % c.width; sy += Math.floor(k / c.width); n++;
        }
    }
    return n ? [sx / n / dpr, sy / n / dpr, n] : null;
}"""

# In the page: a free map cell GOAL_MIN..GOAL_MAX m from the robot with CLEARANCE all round, farthest first.
PICK_GOAL_JS = """([dmin, dmax, clearance]) => {
    const FREE_BELOW = 45;  // occupancy percent: more likely free than not
    const hb = window.homebot, map = hb.state.map, pose = hb.state.pose, res = map.meta.resolution;
    const free = (x, y) => { const v = map.cellAt(x, y); return v !== 255 && v < FREE_BELOW; };
    let best = null;
    for (let r = dmax; r >= dmin && !best; r -= 0.1) {
        for (let k = 0; k < 72 && !best; k++) {
            const a = pose.yaw + (k % 2 ? 1 : -1) * Math.ceil(k / 2) * (Math.PI / 36);
            const x = pose.x + r * Math.cos(a), y = pose.y + r * Math.sin(a);
            let ok = true;
            for (let dx = -clearance; dx <= clearance && ok; dx += res)
                for (let dy = -clearance; dy <= clearance && ok; dy += res)
                    if (dx * dx + dy * dy <= clearance * clearance && !free(x + dx, y + dy)) ok = false;
            if (ok) best = [x, y];
        }
    }
    if (!best) return null;
    const [sx, sy] = hb.view.worldToScreen(best[0], best[1]);
    return { x: best[0], y: best[1], sx, sy };
}"""


def state(page, expr: str):
    return page.evaluate(f"() => {expr}")


def pose(page) -> dict:
    return state(page, "window.homebot.state.pose")


def canvas_origin(page) -> tuple[float, float]:
    box = page.locator("#map").bounding_box()
    return box["x"], box["y"]


def sign_in(page, token: str) -> None:
    """Through the login form, until the stream is online with a map."""
    page.fill("#token-input", token)
    page.click("#login-button")
    page.wait_for_selector("#app", state="visible")
    page.wait_for_function("window.homebot.state.online && window.homebot.state.map.ready",
                           timeout=STREAM_TIMEOUT_MS)


@pytest.fixture(scope="module")
def dashboard(browser, homebot_server):
    """One signed-in dashboard page for the tests of this module."""
    context = browser.new_context(viewport={"width": 1280, "height": 800})
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.js_errors = errors
    page.goto(homebot_server.url)
    page.wait_for_selector("#login", state="visible")
    sign_in(page, homebot_server.token)
    yield page
    context.close()


def test_login_form_rejects_a_wrong_token_then_signs_in(browser, homebot_server):
    context = browser.new_context(viewport={"width": 1280, "height": 800})
    page = context.new_page()
    try:
        page.goto(homebot_server.url)
        page.wait_for_selector("#login", state="visible")
        assert page.locator("#app").is_hidden(), "nothing of the robot is shown before login"
        page.fill("#token-input", "not-the-token-at-all")
        page.click("#login-button")
        page.wait_for_function("document.getElementById('login-error').textContent.length > 0")
        assert "not right" in page.locator("#login-error").inner_text()

        sign_in(page, homebot_server.token)
        assert page.locator("#st-conn").inner_text().strip() == "online"
        assert page.locator("#offline-banner").is_hidden()
        page.wait_for_function("window.homebot.state.status && window.homebot.state.pose",
                               timeout=STREAM_TIMEOUT_MS)
        assert page.locator("#st-mode").inner_text().startswith("Mapping")
        assert "Hz" in page.locator("#st-rate").inner_text()
        # the marker's size is the robot file's footprint
        page.wait_for_function("window.homebot.state.robot !== null", timeout=STREAM_TIMEOUT_MS)
        assert state(page, "window.homebot.state.robot.footprint_radius") == \
            homebot_server.api("GET", "robot").json()["footprint_radius"]
    finally:
        context.close()


def test_click_sends_a_goal_the_path_is_drawn_and_the_robot_drives_there(dashboard, homebot_server):
    page = dashboard
    # Scan and particles hidden so that the map's own pixels can be counted exactly.
    page.uncheck("[data-layer=scan]")
    page.uncheck("[data-layer=particles]")
    # A touch of wheel zoom: the view stops fitting the growing map and stays put from here on.
    box = page.locator("#map").bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.mouse.wheel(0, -40)
    page.wait_for_function("window.homebot.userMovedView")
    scale = state(page, "window.homebot.view.scale")
    known_before = page.evaluate(KNOWN_PIXELS_JS)
    marker_before = page.evaluate(MARKER_JS, ROBOT_RGB)
    assert marker_before is not None, "the robot's marker is drawn"
    start = pose(page)

    # A free spot to drive to, once the first scans have made one certain enough.
    goal = page.wait_for_function(PICK_GOAL_JS, arg=[GOAL_MIN_M, GOAL_MAX_M, CLEARANCE_M],
                                  timeout=STREAM_TIMEOUT_MS).json_value()
    ox, oy = canvas_origin(page)
    page.mouse.click(ox + goal["sx"], oy + goal["sy"])

    # The server got the goal (REST view) and streams the planned path back.
    page.wait_for_function("(window.homebot.state.path.goal && window.homebot.state.path.path.length >= 2)"
                           " || window.homebot.state.lastError", timeout=PLAN_TIMEOUT_MS)
    assert state(page, "window.homebot.state.lastError") is None
    served = homebot_server.api("GET", "path").json()
    assert served["goal"]["x"] == pytest.approx(goal["x"], abs=0.01)
    assert served["goal"]["y"] == pytest.approx(goal["y"], abs=0.01)

    # The path is on the canvas: its colour under the middle of each of its segments.
    drawn = page.evaluate("""(rgb) => {
        const hb = window.homebot; hb.renderer.draw();
        const path = hb.state.path.path, dpr = hb.renderer.dpr, ctx = hb.canvas.getContext('2d');
        let hits = 0, segments = 0;
        for (let i = 1; i < path.length; i++) {
            const [ax, ay] = hb.view.worldToScreen(...path[i - 1]);
            const [bx, by] = hb.view.worldToScreen(...path[i]);
            if (Math.hypot(bx - ax, by - ay) < 6) continue;
            segments++;
            const [mx, my] = [Math.round((ax + bx) / 2 * dpr), Math.round((ay + by) / 2 * dpr)];
            const d = ctx.getImageData(mx - 1, my - 1, 3, 3).data;
            for (let k = 0; k < d.length; k += 4)
                if (d[k] === rgb[0] && d[k + 1] === rgb[1] && d[k + 2] === rgb[2]) { hits++; break; }
        }
        return [hits, segments];
    }""", PATH_RGB)
    assert drawn[1] > 0 and drawn[0] >= 0.8 * drawn[1], f"path drawn under {drawn[0]} of {drawn[1]} segments"

    # The robot drives: its pose and its marker on the canvas get closer to the goal.
    d0 = math.hypot(goal["x"] - start["x"], goal["y"] - start["y"])
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        now = pose(page)
        if math.hypot(goal["x"] - now["x"], goal["y"] - now["y"]) < d0 - 0.5:
            break
        page.wait_for_timeout(250)
    now = pose(page)
    assert math.hypot(goal["x"] - now["x"], goal["y"] - now["y"]) < d0 - 0.5, f"robot {now} vs goal {goal}"
    marker_after = page.evaluate(MARKER_JS, ROBOT_RGB)
    screen_before = math.hypot(goal["sx"] - marker_before[0], goal["sy"] - marker_before[1])
    screen_after = math.hypot(goal["sx"] - marker_after[0], goal["sy"] - marker_after[1])
    assert state(page, "window.homebot.view.scale") == scale, "the view did not move under the test"
    assert screen_after < screen_before - 0.4 * scale, "the marker on the canvas moved toward the goal"

    # The simulated robot mapped as it drove: more of the canvas shows known cells.
    page.wait_for_timeout(1500)  # at least one more map frame (>= 1 Hz)
    known_after = page.evaluate(KNOWN_PIXELS_JS)
    assert known_after > known_before * 1.02 + 200, f"map pixels {known_before} -> {known_after}"
    page.check("[data-layer=scan]")
    page.check("[data-layer=particles]")


def test_cancel_then_keyboard_and_pad_teleop_move_the_robot(dashboard, homebot_server):
    page = dashboard
    page.click("#cancel-goal")
    page.wait_for_function("window.homebot.state.path.goal === null", timeout=STREAM_TIMEOUT_MS)
    assert homebot_server.api("GET", "path").json()["goal"] is None

    page.wait_for_timeout(500)  # the robot comes to rest
    before = pose(page)
    page.locator("#map").focus()
    page.keyboard.down("ArrowDown")  # reverse along the way it came (known free space)
    try:
        page.wait_for_function("""(p) => { const q = window.homebot.state.pose;
                                           return Math.hypot(q.x - p.x, q.y - p.y) > 0.15; }""",
                               arg=before, timeout=TELEOP_TIMEOUT_MS)
    finally:
        page.keyboard.up("ArrowDown")
    after = pose(page)
    assert math.hypot(after["x"] - before["x"], after["y"] - before["y"]) > 0.15
    heading = (math.cos(before["yaw"]), math.sin(before["yaw"]))
    assert (after["x"] - before["x"]) * heading[0] + (after["y"] - before["y"]) * heading[1] < 0, "backwards"

    pad_left = page.locator("[data-drive=left]").bounding_box()
    page.mouse.move(pad_left["x"] + pad_left["width"] / 2, pad_left["y"] + pad_left["height"] / 2)
    page.mouse.down()
    try:
        page.wait_for_function("""(p) => { const d = window.homebot.state.pose.yaw - p.yaw;
                                           return Math.atan2(Math.sin(d), Math.cos(d)) > 0.3; }""",
                               arg=after, timeout=TELEOP_TIMEOUT_MS)
    finally:
        page.mouse.up()
    turned = pose(page)
    dyaw = math.atan2(math.sin(turned["yaw"] - after["yaw"]), math.cos(turned["yaw"] - after["yaw"]))
    assert dyaw > 0.3, f"the on-screen 'turn left' turned the robot {dyaw:.2f} rad (CCW is positive)"
    page.wait_for_function("window.homebot.teleop.timer === null")  # released: one stop was sent


def test_places_and_a_screenshot_of_the_dashboard_driving(dashboard, homebot_server, artifacts):
    """A named place added from the sidebar, then a goal on the whole (fitted) map: the screenshot
    shows the map, the robot, its path, the scan, the place and the status bar."""
    page = dashboard
    page.fill("#place-name", "dock")
    page.click("#place-form button[type=submit]")
    page.wait_for_selector("li.place[data-name=dock]")
    served = {p["name"]: p for p in homebot_server.api("GET", "places").json()}
    robot = pose(page)
    assert served["dock"]["x"] == pytest.approx(robot["x"], abs=0.3)

    page.click("#fit")
    page.wait_for_timeout(300)
    goal = page.evaluate(PICK_GOAL_JS, [GOAL_MIN_M, 4.0, CLEARANCE_M])
    assert goal is not None
    ox, oy = canvas_origin(page)
    page.mouse.click(ox + goal["sx"], oy + goal["sy"])
    page.wait_for_function("window.homebot.state.path.path.length >= 2 || window.homebot.state.lastError",
                           timeout=PLAN_TIMEOUT_MS)
    page.wait_for_timeout(1500)
    path = artifacts / "dashboard.png"
    page.screenshot(path=str(path))
    assert path.stat().st_size > 20_000
    page.click("#cancel-goal")
    assert page.js_errors == []


def test_phone_sized_screen_via_the_printed_link(browser, homebot_server, artifacts):
    """The link the server prints (?token=...) signs in; the layout fits a phone, its menu sheet leaves
    most of the map in view; the token leaves the URL."""
    context = browser.new_context(viewport={"width": 390, "height": 844}, device_scale_factor=2,
                                  is_mobile=True, has_touch=True)
    page = context.new_page()
    try:
        page.goto(f"{homebot_server.url}?token={homebot_server.token}")
        page.wait_for_function("window.homebot.state.online && window.homebot.state.map.ready",
                               timeout=STREAM_TIMEOUT_MS)
        assert "token" not in page.url
        canvas = page.locator("#map").bounding_box()
        assert canvas["width"] == pytest.approx(390, abs=1) and canvas["height"] > 600
        assert not page.locator("#sidebar").is_visible() or page.evaluate(
            "document.getElementById('sidebar').getBoundingClientRect().top >= window.innerHeight")
        page.click("#menu-toggle")
        page.wait_for_timeout(400)
        sheet = page.evaluate("""() => { const r = document.getElementById('sidebar').getBoundingClientRect();
                                         const s = document.getElementById('sidebar');
                                         return { top: r.top, bottom: r.bottom,
                                                  scrolls: s.scrollHeight > s.clientHeight }; }""")
        assert sheet["bottom"] == pytest.approx(844, abs=1) and sheet["top"] < 844 * 0.7, "the sheet is open"
        assert sheet["scrolls"], "the rest of the controls is a scroll away"
        visible = (sheet["top"] - canvas["y"]) / canvas["height"]
        assert visible >= 0.5, f"the open sheet leaves only {visible:.0%} of the map in view"
        page.click("#menu-toggle")
        page.wait_for_timeout(400)
        page.screenshot(path=str(artifacts / "dashboard-phone.png"))
    finally:
        context.close()


def test_works_behind_a_reverse_proxy_under_a_sub_path(browser, homebot_server, subpath_proxy):
    """Served as http://host/robot/ by a proxy that strips /robot: login, REST and the websocket all
    work, and the page never asks for anything outside /robot/."""
    context = browser.new_context(viewport={"width": 1000, "height": 700})
    page = context.new_page()
    try:
        page.goto(f"{subpath_proxy.url}?token={homebot_server.token}")
        page.wait_for_function("window.homebot.state.online && window.homebot.state.map.ready"
                               " && window.homebot.state.status", timeout=STREAM_TIMEOUT_MS)
        page.wait_for_selector("li.place[data-name=dock]")  # GET api/places through the proxy
    finally:
        context.close()
    assert subpath_proxy.refused == []
    asked = set(subpath_proxy.paths)
    assert {"/robot/", "/robot/js/main.js", "/robot/api/login", "/robot/api/places"} <= asked
    assert "/robot/ws" in asked


def test_offline_banner_and_reconnect_after_a_server_restart(dashboard, homebot_server):
    page = dashboard
    homebot_server.stop()
    page.wait_for_selector("#offline-banner", state="visible", timeout=15_000)
    assert page.locator("#st-conn").inner_text().strip() == "offline"
    homebot_server.start()  # same port, same data dir: same token, the cookie still works
    page.wait_for_selector("#offline-banner", state="hidden", timeout=30_000)
    page.wait_for_function("window.homebot.state.online && window.homebot.state.status.worker.alive",
                           timeout=STREAM_TIMEOUT_MS)
    assert page.locator("#st-conn").inner_text().strip() == "online"


def test_a_new_map_is_started_only_once_the_person_confirms(dashboard):
    """Mode switches keep the map; the one way to drop it asks first (the server side is tested in
    tests/test_recovery.py)."""
    page = dashboard
    sent = []
    page.on("request", lambda r: sent.append(r.post_data_json) if r.url.endswith("/api/mode") else None)
    asked = []
    page.once("dialog", lambda dialog: (asked.append(dialog.message), dialog.dismiss()))
    page.click("#new-map")
    page.wait_for_timeout(1000)
    assert asked and "new, empty map" in asked[0]
    assert sent == []  # dismissed: nothing sent, the map stays
    page.once("dialog", lambda dialog: dialog.accept())
    with page.expect_response(lambda r: r.url.endswith("/api/mode")) as answer:
        page.click("#new-map")
    assert answer.value.status == 200
    assert sent == [{"mode": "mapping", "new_map": True}]
    assert page.js_errors == []


def test_the_restart_tour_button_starts_the_scripted_tour_again(dashboard, homebot_server):
    """The server runs without the tour (HOMEBOT_SIM_TOUR=0): the button starts it, Cancel ends it."""
    page = dashboard
    assert homebot_server.api("GET", "status").json()["nav"]["touring"] is False
    with page.expect_response(lambda r: r.url.endswith("/api/tour")) as answer:
        page.click("#tour-restart")
    assert answer.value.status == 200
    page.wait_for_function("window.homebot.state.status.nav.touring === true", timeout=STREAM_TIMEOUT_MS)
    assert page.locator("#st-nav").inner_text().startswith("tour:")
    assert homebot_server.api("GET", "status").json()["nav"]["touring"] is True
    page.click("#cancel-goal")
    page.wait_for_function("window.homebot.state.status.nav.touring === false", timeout=STREAM_TIMEOUT_MS)
    assert page.js_errors == []
