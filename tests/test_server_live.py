"""A real uvicorn server (``homebot serve``, simulated flat) driven by httpx and a websocket client."""

from __future__ import annotations

import asyncio
import json
import math
import time

import httpx
import numpy as np
import pytest
import websockets

from app.streaming.map_frames import MapCanvas, decode
from app.worker.shared_map import UNKNOWN
from tests.live_server import LiveServer

STREAM_KINDS = ("pose", "particles", "scan", "path")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    srv = LiveServer(tmp_path_factory.mktemp("homebot-data")).start()
    yield srv
    srv.stop()


async def _listen(url: str, seconds: float, on_message=None) -> tuple[dict, MapCanvas, list]:
    counts: dict[str, int] = {}
    canvas = MapCanvas()
    messages = []
    async with websockets.connect(url, max_size=None) as ws:
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            try:
                raw = await asyncio.wait_for(ws.recv(), left)
            except TimeoutError:
                break
            if isinstance(raw, bytes):
                frame = decode(raw)
                canvas.apply(frame)
                kind = "map"
            else:
                message = json.loads(raw)
                kind = message["type"]
                messages.append(message)
                if on_message is not None:
                    await on_message(ws, message)
            counts[kind] = counts.get(kind, 0) + 1
    return counts, canvas, messages


def listen(server: LiveServer, seconds: float, on_message=None):
    return asyncio.run(_listen(f"{server.ws_url}?token={server.token}", seconds, on_message))


def known_cells(canvas: MapCanvas) -> int:
    return int((canvas.cells != UNKNOWN).sum())


def test_health_is_the_only_open_route(server):
    with server.client(token=False) as c:
        assert c.get("/api/health").json()["status"] == "ok"
        for method, path in (("GET", "/api/status"), ("GET", "/api/map.png"), ("POST", "/api/goal"),
                             ("GET", "/api/places"), ("GET", "/api/maps"), ("POST", "/api/teleop")):
            assert c.request(method, path).status_code == 401, path
        bad = {"Authorization": "Bearer not-the-token"}
        assert c.get("/api/status", headers=bad).status_code == 401


def test_websocket_refuses_a_missing_or_wrong_token(server):
    async def attempt(url):
        async with websockets.connect(url) as ws:
            with pytest.raises(websockets.ConnectionClosed) as info:
                await asyncio.wait_for(ws.recv(), 5)
            return info.value.rcvd.code

    assert asyncio.run(attempt(server.ws_url)) == 4401
    assert asyncio.run(attempt(f"{server.ws_url}?token=wrong")) == 4401


def test_login_cookie_opens_rest_and_websocket(server):
    with httpx.Client(base_url=server.base) as c:
        assert c.post("/api/login", json={"token": "wrong"}).status_code == 401
        r = c.post("/api/login", json={"token": server.token})
        assert r.status_code == 200
        assert "httponly" in r.headers["set-cookie"].lower()
        assert c.get("/api/status").status_code == 200
        cookie = f"homebot_session={c.cookies['homebot_session']}"
        assert server.token not in cookie

    async def first_message():
        async with websockets.connect(server.ws_url, additional_headers={"Cookie": cookie}) as ws:
            return json.loads(await asyncio.wait_for(ws.recv(), 5))

    assert asyncio.run(first_message())["type"] == "hello"


def test_stream_rates_and_a_late_client_gets_the_full_map(server):
    seconds = 3.0
    counts, canvas, messages = listen(server, seconds)
    for kind in STREAM_KINDS:
        assert counts.get(kind, 0) / seconds >= 10.0, (kind, counts)
    assert counts.get("map", 0) / seconds >= 1.0, counts
    assert canvas.frame is not None and known_cells(canvas) > 500
    poses = [m for m in messages if m["type"] == "pose"]
    assert all(math.isfinite(p["x"]) and math.isfinite(p["yaw"]) for p in poses)
    scans = [m for m in messages if m["type"] == "scan"]
    assert len(scans[-1]["points"]) > 100


def test_bad_inputs_are_4xx_with_a_reason(server):
    with server.client() as c:
        r = c.post("/api/goal", content=b"{not json", headers={"Content-Type": "application/json"})
        assert r.status_code == 422
        assert c.post("/api/goal", json={"x": 1.0}).status_code == 422
        assert c.post("/api/goal", json={"x": "NaN", "y": 1}).status_code == 422
        r = c.post("/api/goal", json={"x": 500.0, "y": 500.0})
        assert r.status_code == 422 and r.json()["reason"] == "goal_outside_map"
        r = c.post("/api/goal", json={"place": "nowhere"})
        assert r.status_code == 404 and "nowhere" in r.json()["detail"]
        assert c.post("/api/places/nowhere/go").status_code == 404
        assert c.post("/api/maps", json={"name": "../../etc/passwd"}).status_code == 422
        assert c.post("/api/maps", json={"name": ".hidden"}).status_code == 422
        assert c.delete("/api/maps/..%2F..%2Ftoken").status_code in (404, 422)
        assert (server.data_dir / "token").exists()
        assert c.post("/api/places", json={"name": "a/b", "x": 0, "y": 0}).status_code == 422
        assert c.post("/api/teleop", json={"v": 9.0, "w": 0.0}).status_code == 422
        assert c.put("/api/mode", json={"mode": "flying"}).status_code == 422
        big = {"name": "x" * 10, "x": 0, "y": 0, "pad": "y" * 200_000}
        assert c.post("/api/places", json=big).status_code == 413


def test_goal_path_is_streamed_and_the_robot_arrives(server):
    goal = (3.2, 1.8)  # flat world: from the hall (start 1.0, 3.75) into the kitchen
    with server.client() as c:
        r = c.post("/api/goal", json={"x": goal[0], "y": goal[1], "explore": True})
        assert r.status_code == 202, r.text
        assert len(r.json()["path"]) >= 2
    seen_path = []

    async def watch(ws, message):
        if message["type"] == "path" and message["path"]:
            seen_path.append(message["path"])

    listen(server, 1.0, watch)
    assert seen_path and np.allclose(seen_path[-1][-1], r.json()["path"][-1], atol=0.3)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        status = server.status()
        if status["nav"]["state"] in ("arrived", "failed"):
            break
        time.sleep(0.5)
    assert status["nav"]["state"] == "arrived", status["nav"]
    true = status["true_pose"]
    assert math.hypot(true[0] - goal[0], true[1] - goal[1]) < 0.5, (true, goal)


def test_the_map_grows_as_the_robot_moves(server):
    _, before, _ = listen(server, 1.0)
    with server.client() as c:
        r = c.post("/api/goal", json={"x": 8.0, "y": 4.0, "explore": True})  # the living room, via the hall
        assert r.status_code == 202, r.text
    deadline = time.monotonic() + 90  # the drive takes ~20 s on an idle machine, much longer on a busy one
    grown = 0
    while time.monotonic() < deadline and grown <= 2000:
        _, after, _ = listen(server, 1.0)
        grown = known_cells(after) - known_cells(before)
        if server.status()["nav"]["state"] in ("arrived", "failed"):
            _, after, _ = listen(server, 1.0)  # the last scans' tiles
            grown = known_cells(after) - known_cells(before)
            break
    assert grown > 2000, (grown, server.status()["nav"])


def drive(c, goal: tuple[float, float], explore: bool, timeout: float) -> dict:
    """Send a goal and wait until the navigator arrives or gives up: the last status."""
    r = c.post("/api/goal", json={"x": goal[0], "y": goal[1], "explore": explore})
    assert r.status_code == 202, r.text
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status = c.get("/api/status").json()
        if status["nav"]["state"] in ("arrived", "failed"):
            break
        time.sleep(0.5)
    return status


def test_switch_to_localization_on_a_saved_map_and_back(server):
    with server.client() as c:
        # the hall mapped from the start (1.0, 3.75) to here, so that the way back lies in the saved map
        assert drive(c, (5.4, 3.75), explore=True, timeout=90)["nav"]["state"] == "arrived"
        assert c.post("/api/maps", json={"name": "flat"}).status_code == 201
        assert c.put("/api/mode", json={"mode": "localization", "map": "nope"}).status_code == 404
        r = c.post("/api/maps/flat/load")
        assert r.status_code == 200, r.text
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline:
            status = c.get("/api/status").json()
            if status["mode"] == "localization" and status["worker"]["steps"] > 0:
                break
            time.sleep(0.5)
        assert status["mode"] == "localization", status["events"]
        status = drive(c, (1.0, 3.75), explore=False, timeout=60)
        assert status["mode"] == "localization" and status["nav"]["state"] == "arrived", status["nav"]
        pose, true = status["pose"], status["true_pose"]
        assert math.hypot(pose["x"] - true[0], pose["y"] - true[1]) < 0.5, (pose, true)
        r = c.put("/api/mode", json={"mode": "ekf"})
        assert r.status_code == 200 and r.json()["mode"] == "ekf"
        landmarks = []

        async def watch(ws, message):
            if message["type"] == "landmarks":
                landmarks.append(message)

        listen(server, 3.0, watch)
        assert landmarks and len(landmarks[-1]["landmarks"]) == len(landmarks[-1]["covariances"])
        assert c.post("/api/mapping/start").json()["mode"] == "mapping"


def test_killed_worker_restarts_and_the_map_is_still_there(server):
    before = server.status()
    _, canvas_before, _ = listen(server, 1.0)
    pid = before["worker"]["pid"]
    import os
    import signal

    os.kill(pid, signal.SIGKILL)
    deadline = time.monotonic() + 90  # the new worker imports and warms up its kernels first
    while time.monotonic() < deadline:
        status = server.status()
        w = status["worker"]
        if w["restarts"] >= 1 and w["alive"] and w["pid"] != pid and w["steps"] > 5:
            break
        time.sleep(0.3)
    assert w["restarts"] == before["worker"]["restarts"] + 1 and w["pid"] != pid, w
    assert "code -9" in (w["last_error"] or "")
    _, canvas_after, _ = listen(server, 1.5)
    assert known_cells(canvas_after) >= 0.9 * known_cells(canvas_before)
    # the robot stands where it arrived: the restarted worker finds it there, against the truth
    pose_before, pose_after, true = before["pose"], status["pose"], status["true_pose"]
    assert math.hypot(pose_after["x"] - pose_before["x"], pose_after["y"] - pose_before["y"]) < 0.1
    assert math.hypot(pose_after["x"] - true[0], pose_after["y"] - true[1]) < 0.1, (pose_after, true)
    with server.client() as c:
        assert c.get("/api/map.png").content[:8] == b"\x89PNG\r\n\x1a\n"


def test_an_idle_simulated_robot_tours_until_a_person_takes_over(tmp_path):
    """The default: the robot drives the world's tour by itself; teleop ends it; api/tour restarts it."""
    touring = LiveServer(tmp_path / "tour", env={"HOMEBOT_SIM_TOUR": "1"}).start()
    try:
        with touring.client() as c:
            start = np.array(c.get("/api/status").json()["true_pose"][:2])
            deadline = time.monotonic() + 60
            moved = 0.0
            while time.monotonic() < deadline and moved < 1.0:
                time.sleep(1.0)
                status = c.get("/api/status").json()
                moved = float(np.hypot(*(np.array(status["true_pose"][:2]) - start)))
            assert moved >= 1.0, status
            assert status["nav"]["touring"] and status["goal"]["place"] == "tour"
            assert c.post("/api/teleop", json={"v": 0.0, "w": 0.0}).status_code == 200
            status = c.get("/api/status").json()
            assert not status["nav"]["touring"] and status["goal"] is None
            assert c.post("/api/tour").json() == {"ok": True}  # the tour starts again from its start
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline and (status["goal"] or {}).get("place") != "tour":
                time.sleep(0.5)
                status = c.get("/api/status").json()
            assert status["nav"]["touring"] and status["goal"]["place"] == "tour", status
    finally:
        touring.stop()
