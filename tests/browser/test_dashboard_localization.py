"""Localization mode from the dashboard, in Debian's chromium against a real server (simulated flat).

The robot maps the hall and the kitchen, the person saves the map and loads it from the Maps
panel, then the robot drives back through the flat while the page is watched: the mode and
"localized" pills, and the pose the page draws against the simulator's true pose.
"""

from __future__ import annotations

import math
import time

from tests.live_server import until

DRIVE_TIMEOUT_S = 120.0
STREAM_TIMEOUT_MS = 30_000
KITCHEN, HALL = (3.2, 1.8), (1.0, 3.75)  # the flat world: the hall is where the robot starts
#: The page's pose against the simulator's, sampled while driving (the page's pose is up to one
#: stream period older than the true pose, 0.4 m/s x 1/15 s). The page is read just before and just
#: after each status request, so that a request slow to be answered (a busy machine) does not count
#: the robot's motion meanwhile: the status's true pose lies in time between the two reads.
POSE_BOUND_M = 0.3


def drive(server, goal) -> dict:
    r = server.api("POST", "goal", json={"x": goal[0], "y": goal[1], "explore": True})
    assert r.status_code == 202, r.text
    return until(lambda: (s := server.api("GET", "status").json())["nav"]["state"] != "driving" and s,
                 DRIVE_TIMEOUT_S, f"the drive to {goal}")


def open_dashboard(page, server) -> None:
    """Signed in with the printed link, the map and the stream there."""
    page.goto(f"{server.url}?token={server.token}")
    page.wait_for_function("window.homebot?.state.online && window.homebot.state.map.ready",
                           timeout=STREAM_TIMEOUT_MS)


def test_a_saved_map_loaded_from_the_dashboard_keeps_the_robot_localized(page, homebot_server, artifacts):
    server = homebot_server
    assert drive(server, KITCHEN)["nav"]["state"] == "arrived"
    open_dashboard(page, server)

    page.fill("#map-name", "home")
    page.click("#map-form button[type=submit]")
    page.wait_for_selector("#maps li[data-name=home]")
    page.click("#maps li[data-name=home] button.primary")  # Load: localize on this map
    page.wait_for_function("document.getElementById('st-mode').textContent.startsWith('Localization')",
                           timeout=STREAM_TIMEOUT_MS)
    page.wait_for_function("document.getElementById('st-loc').textContent === 'localized'",
                           timeout=STREAM_TIMEOUT_MS)

    r = server.api("POST", "goal", json={"x": HALL[0], "y": HALL[1]})
    assert r.status_code == 202, r.text
    gaps, errors, pills = [], [], []
    deadline = time.monotonic() + DRIVE_TIMEOUT_S
    while time.monotonic() < deadline:
        before = page.evaluate("() => window.homebot.state.pose")
        status = server.api("GET", "status").json()
        after = page.evaluate("() => window.homebot.state.pose")
        true = status["true_pose"]
        gaps.append(min(math.hypot(shown["x"] - true[0], shown["y"] - true[1]) for shown in (before, after)))
        errors.append(math.hypot(status["pose"]["x"] - true[0], status["pose"]["y"] - true[1]))  # diagnosis
        pills.append(page.locator("#st-loc").inner_text())
        if status["nav"]["state"] != "driving":
            break
        time.sleep(0.25)
    assert status["mode"] == "localization" and status["nav"]["state"] == "arrived", status["nav"]
    # the pill says what the worker says: localized nearly all the way (a doorway may cost a scan's fit)
    assert set(pills) <= {"localized", "not localized"}
    assert pills.count("localized") >= 0.9 * len(pills) and pills[-1] == "localized", pills
    worst = gaps.index(max(gaps))  # and the server's own pose then (the worker's last state: it may lag)
    assert len(gaps) > 10 and gaps[worst] < POSE_BOUND_M, (gaps[worst], errors[worst], status["events"])
    assert math.hypot(true[0] - HALL[0], true[1] - HALL[1]) < 0.5
    page.screenshot(path=str(artifacts / "dashboard-localization.png"))
    assert page.js_errors == []


def test_a_mapping_session_is_saved_and_continued_from_the_dashboard(page, homebot_server):
    server = homebot_server
    # a new map: its loop-closing back end holds every update (a loaded map has no back end)
    r = server.api("PUT", "mode", json={"mode": "mapping", "new_map": True})
    assert r.status_code in (200, 202), r.text  # 202: still switching; the worker takes commands in order
    status = drive(server, KITCHEN)
    assert status["nav"]["state"] == "arrived", status["nav"]
    open_dashboard(page, server)
    page.fill("#session-name", "flat")
    page.click("#session-form button[type=submit]")
    page.wait_for_selector("#sessions li[data-name=flat]")
    assert (server.data / "sessions" / "flat.session.npz").stat().st_size > 0
    page.click("#sessions li[data-name=flat] button.primary")  # Continue
    page.wait_for_function("window.homebot.state.status?.events?.some(e => e.event === 'session_resumed')",
                           timeout=STREAM_TIMEOUT_MS)
    page.wait_for_function("document.getElementById('st-loc').textContent === 'localized'",
                           timeout=STREAM_TIMEOUT_MS)
    status = server.api("GET", "status").json()
    assert status["mode"] == "mapping" and not status["worker"]["relocalizing"]
    true = status["true_pose"]
    # the events say which search found the robot, and how well the scan fit there
    assert math.hypot(status["pose"]["x"] - true[0], status["pose"]["y"] - true[1]) < POSE_BOUND_M, \
        (status["pose"], true, status["events"])
    assert page.js_errors == []
