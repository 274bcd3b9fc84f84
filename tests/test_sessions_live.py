"""Mapping sessions in a real server (simulated flat): save half the home, start afresh elsewhere,
continue the session, map the rest; judged by the simulator's true pose and ground-truth map."""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np

from slam_core.session import SUFFIX
from tests.live_server import ROOT, LiveServer
from tests.recovery_harness import (
    agreement_with_truth,
    fetch_map,
    localized,
    pose_error,
    stop_robot,
    wait_for,
)

KITCHEN = (3.2, 1.8)  # the flat; the robot starts in the hall
BEDROOM, STUDY = (2.8, 5.6), (5.2, 1.8)
DRIVE_TIMEOUT_S = 150.0
POSE_BOUND_M = 0.1


def drive(server: LiveServer, goal) -> dict:
    with server.client() as c:
        r = c.post("/api/goal", json={"x": goal[0], "y": goal[1], "explore": True})
        assert r.status_code == 202, r.text
    status, _ = wait_for(server, lambda s: s["nav"]["state"] in ("arrived", "failed"), DRIVE_TIMEOUT_S)
    assert status["nav"]["state"] == "arrived", status["nav"]
    return status


def test_a_saved_session_is_continued_after_a_fresh_start_into_one_map(tmp_path):
    first = LiveServer(tmp_path / "first").start()
    try:
        drive(first, KITCHEN)
        with first.client() as c:
            assert c.post("/api/sessions", json={"name": "a/b"}).status_code == 422
            r = c.post("/api/sessions", json={"name": "home"})
            assert r.status_code == 201, r.text
            assert [s["name"] for s in c.get("/api/sessions").json()] == ["home"]
        half_map = fetch_map(first, tmp_path / "half")
        half, half_cells = agreement_with_truth(half_map)
    finally:
        first.stop()

    # another day: a fresh data dir (an empty map, the robot back at the start) with the session,
    # continued with `homebot serve --resume home`
    sessions = tmp_path / "second" / "sessions"
    sessions.mkdir(parents=True)
    shutil.copy(tmp_path / "first" / "sessions" / f"home{SUFFIX}", sessions)
    (sessions / f"broken{SUFFIX}").write_bytes(b"not a session")
    second = LiveServer(tmp_path / "second").start("--resume", "home")
    try:
        seen: set[str] = set()  # worker events (the status shows the last five), polled every 50 ms

        def found_in_the_session(status: dict) -> bool:
            seen.update(e["event"] for e in status["events"])
            return {"session_resumed", "relocalized"} <= seen and localized(status)

        status, _ = wait_for(second, found_in_the_session, 60)
        assert pose_error(status) < POSE_BOUND_M, (status["pose"], status["true_pose"])
        with second.client() as c:  # refused resumes leave the continued session as it is
            assert c.post("/api/sessions/nope/resume").status_code == 404
            r = c.post("/api/sessions/broken/resume")
            assert r.status_code == 409 and r.json()["reason"] == "session_refused", r.text
        drive(second, BEDROOM)
        drive(second, STUDY)
        status = stop_robot(second)
        assert status["mode"] == "mapping" and pose_error(status) < POSE_BOUND_M
        assert status["loops"]["solves"] > 0  # the back end runs over the old part and the new
        whole_map = fetch_map(second, tmp_path / "whole")
        whole, whole_cells = agreement_with_truth(whole_map)
        with second.client() as c:
            assert c.delete("/api/sessions/home").status_code == 200
            assert c.post("/api/sessions/home/resume").status_code == 404
    finally:
        second.stop()
    # one home: more of it known, as consistent with the truth as the half was (no second copy)
    # the kitchen, mapped on the first day only, is in the continued map
    iy, ix = np.nonzero(half_map.data != 0)
    cells = whole_map.world_to_cell(half_map.cell_to_world(np.stack([ix, iy], 1)))
    inside = np.all((cells >= 0) & (cells < whole_map.shape[::-1]), axis=1)
    kept = (whole_map.data[cells[inside, 1], cells[inside, 0]] != 0).sum() / len(cells)
    assert kept > 0.97, kept
    assert whole_cells > 1.3 * half_cells, (whole_cells, half_cells)
    assert whole >= half - 0.01 and whole > 0.9, (whole, half)


def test_serve_refuses_a_session_it_cannot_continue_in_one_line(tmp_path):
    (tmp_path / "sessions").mkdir()
    (tmp_path / "sessions" / f"broken{SUFFIX}").write_bytes(b"PK\x03\x04 not a session")
    for name, says in (("nope", "no such session file"), ("broken", "not a complete .npz archive"),
                       ("a.b", "bad session name")):
        command = [sys.executable, "-m", "app.cli", "serve", "--data", str(tmp_path), "--resume", name]
        done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=120)
        assert done.returncode == 2 and says in done.stderr and "Traceback" not in done.stderr, done.stderr
