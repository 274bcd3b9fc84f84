"""``homebot serve --replay``: a slice of mit-csail through a real server, watched by a real websocket client.

The oracle is ``homebot slam``'s pipeline on the same slice with the same config and seed,
and the log's ground-truth relations.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import subprocess
from dataclasses import dataclass, replace
from pathlib import Path

import httpx
import numpy as np
import pytest
import websockets
import yaml

from slam_core.datasets import BUNDLED
from slam_core.evaluation import load_relations, relation_error
from slam_core.io.carmen import laser_records
from slam_core.io.ros_map import load_map
from slam_core.io.trajectory import Trajectory
from slam_core.pipelines.log_slam import slam_from_log
from slam_core.rbpf import RBPFConfig
from tests.bundled import log_slice
from tests.live_server import connect_stream, launch_replay

SCANS = 250
TOKEN = "replay-test-token-0123456789-abcdef"
RUN_TIMEOUT_S = 600.0


@dataclass
class Replay:
    log: Path
    config: RBPFConfig
    out: Path
    exit_code: int
    output: str
    messages: list[dict]
    refused: dict[str, httpx.Response]


async def _watch(port: int, proc: subprocess.Popen) -> tuple[list[dict], dict[str, httpx.Response]]:
    """Every text message of the stream until the server closes it; goal and teleop tried once
    while the log plays."""
    ws = await connect_stream(port, TOKEN, proc)
    messages, refused = [], {}
    headers = {"Authorization": f"Bearer {TOKEN}"}
    async with ws, httpx.AsyncClient(base_url=f"http://127.0.0.1:{port}", headers=headers) as http:
        with contextlib.suppress(websockets.ConnectionClosed):
            async for raw in ws:
                if isinstance(raw, bytes):
                    continue
                message = json.loads(raw)
                messages.append(message)
                if message["type"] == "pose" and not refused:
                    refused["goal"] = await http.post("/api/goal", json={"x": 1.0, "y": 0.0})
                    refused["teleop"] = await http.post("/api/teleop", json={"v": 0.1, "w": 0.0})
                    refused["tour"] = await http.post("/api/tour")
                    refused["map load"] = await http.post("/api/maps/home/load")
    return messages, refused


@pytest.fixture(scope="module")
def replay(tmp_path_factory) -> Replay:
    root = tmp_path_factory.mktemp("replay")
    log = log_slice("mit-csail", root / "mit-slice.clf", SCANS)
    config = replace(RBPFConfig(), particles=8)
    config_file = root / "slam.json"
    config_file.write_text(json.dumps(config.to_dict()))
    proc, port = launch_replay(root / "data", log, config_file, TOKEN, "--exit-at-end")
    try:
        messages, refused = asyncio.run(_watch(port, proc))
        output, _ = proc.communicate(timeout=RUN_TIMEOUT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return Replay(log, config, root / "data" / "replay" / "mit-slice", proc.returncode, output, messages,
                  refused)


def test_the_server_exits_cleanly_after_the_final_optimisation(replay):
    assert replay.exit_code == 0, replay.output
    for name in ("map.pgm", "map.png", "trajectory.txt", "particle_trajectory.txt"):
        assert (replay.out / name).stat().st_size > 0, name
    assert yaml.safe_load((replay.out / "map.yaml").read_text())["image"] == "map.pgm"
    assert RBPFConfig.from_dict(json.loads((replay.out / "config.json").read_text())) == replay.config
    stats = json.loads((replay.out / "stats.json").read_text())
    assert stats["records"] == stats["stepped"] == SCANS and stats["dropped"] == 0  # max speed drops none
    assert stats["speed"] == "max" and "loop_edges" in stats


@pytest.fixture(scope="module")
def offline(replay):
    """``homebot slam`` on the same slice, config and seed."""
    return slam_from_log(replay.log, replay.config, seed=0)


def test_the_written_trajectory_scores_like_homebot_slam(replay, offline):
    live = Trajectory.load(replay.out / "trajectory.txt")
    assert live.stamps == [r.stamp.ipc_text for r in laser_records(replay.log)]
    relations = load_relations(BUNDLED["mit-csail"][1])
    live_error = relation_error(live.times, live.poses, relations)
    offline = offline.trajectory
    offline_error = relation_error(offline.times, offline.poses, relations)
    assert live_error.count == offline_error.count > 100
    # the bound: within 10 % of `homebot slam` on the same log, config and seed
    assert live_error.trans.mean() <= 1.1 * offline_error.trans.mean() + 1e-3, live_error.report()
    assert live_error.trans.mean() < 0.05, live_error.report()


def test_the_written_map_is_homebot_slams(replay, offline):
    """At max speed the live run's final map is rendered as ``homebot slam``'s (each cell clamped
    after the sum of its observations) from the same poses: the same cells, the same labels."""
    live = load_map(replay.out / "map.yaml")
    assert live.shape == offline.grid.shape and np.allclose(live.origin, offline.grid.origin)
    labels = offline.grid.trinary()
    assert np.sum(labels >= 0) > 20000
    assert np.array_equal(live.trinary(), labels)


def test_the_stream_carries_the_replayed_poses_and_the_status_says_replay(replay):
    poses = [m for m in replay.messages if m["type"] == "pose"]
    assert len(poses) >= 20
    trajectory = Trajectory.load(replay.out / "trajectory.txt")
    final, record = trajectory.poses, {stamp: i for i, stamp in enumerate(trajectory.times)}
    # a pose is the worker's correction composed with the newest odometry, the log's at record
    # ``odom_t``; the filter's live pose is the optimised one up to the back end's correction
    # (centimetres here: no loop in this slice)
    gaps = [np.hypot(m["x"] - final[record[m["odom_t"]], 0], m["y"] - final[record[m["odom_t"]], 1])
            for m in poses]
    assert len(gaps) >= 20 and max(gaps) < 0.3
    travelled = np.hypot(*np.diff(final[:, :2], axis=0).T).sum()
    assert travelled > 5.0  # a real building, not the simulated flat's start pose
    statuses = [m for m in replay.messages if m["type"] == "status"]
    replays = [s["replay"] for s in statuses if s.get("replay")]
    assert replays and all(r["log"] == "mit-slice" and r["records"] == SCANS for r in replays)
    assert any(r["phase"] == "playing" and 0 < r["played"] <= SCANS for r in replays)
    assert not any(s["sim"] for s in statuses)


def test_goals_teleop_the_tour_and_loading_a_map_are_refused_with_a_reason(replay):
    for name in ("goal", "teleop", "tour", "map load"):
        response = replay.refused[name]
        assert response.status_code == 409, (name, response.text)
        assert "replaying the log" in response.json()["detail"]
