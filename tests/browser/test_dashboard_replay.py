"""The dashboard watching a replay: a slice of mit-csail played at max speed through a real server.

At the end the map the browser holds (its decoded tiles) is compared cell by cell with the map
``homebot slam``'s pipeline builds offline from the same slice, config and seed.
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import replace

import httpx
import numpy as np
import pytest

from app.worker.shared_map import UNKNOWN, grid_cells
from slam_core.pipelines.log_slam import slam_from_log
from slam_core.rbpf import RBPFConfig
from tests.bundled import log_slice
from tests.live_server import launch_replay, until

SCANS = 250
TOKEN = "browser-replay-token-0123456789-abcdef"
REPLAY_TIMEOUT_S = 600.0
#: A cell is drawn occupied at or above this percentage (the map's ramp is centred there).
OCCUPIED_PERCENT = 50

# The browser's cell values at the centres of a grid's cells (0..100, 255 unknown), row by row.
CELLS_JS = """([x0, y0, res, width, height]) => {
    const map = window.homebot.state.map, out = new Array(width * height);
    for (let iy = 0; iy < height; iy++)
        for (let ix = 0; ix < width; ix++)
            out[iy * width + ix] = map.cellAt(x0 + (ix + 0.5) * res, y0 + (iy + 0.5) * res);
    return out;
}"""


@pytest.fixture(scope="module")
def replay_server(tmp_path_factory):
    root = tmp_path_factory.mktemp("browser-replay")
    log = log_slice("mit-csail", root / "mit-slice.clf", SCANS)
    config = replace(RBPFConfig(), particles=8)
    config_file = root / "slam.json"
    config_file.write_text(json.dumps(config.to_dict()))
    output = open(root / "serve.log", "w")  # noqa: SIM115 - closed below, after the server stops
    proc, port = launch_replay(root / "data", log, config_file, TOKEN, stdout=output)
    try:
        yield {"url": f"http://127.0.0.1:{port}/", "log": log, "config": config, "proc": proc}
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        output.close()


def _replay_phase(url: str) -> str | None:
    try:
        status = httpx.get(url + "api/status", headers={"Authorization": f"Bearer {TOKEN}"}, timeout=5).json()
    except (httpx.HTTPError, ValueError):
        return None
    return (status.get("replay") or {}).get("phase")


def test_the_dashboard_shows_the_replayed_map_as_homebot_slam_builds_it(replay_server, page, artifacts):
    url, proc = replay_server["url"], replay_server["proc"]
    until(lambda: proc.poll() is not None or _replay_phase(url) is not None, 180, "the replay to start")
    assert proc.poll() is None, "homebot serve --replay exited early"
    page.goto(f"{url}?token={TOKEN}")
    page.wait_for_selector("#app", state="visible")
    until(lambda: _replay_phase(url) == "finished", REPLAY_TIMEOUT_S, "the replay's final optimisation")
    # the final map reaches the browser with the next map frames
    page.wait_for_function("window.homebot.state.map.ready && window.homebot.state.status?.replay?.phase"
                           " === 'finished'", timeout=30_000)
    page.wait_for_timeout(2_000)
    page.screenshot(path=str(artifacts / "dashboard-replay.png"))
    assert page.js_errors == []

    offline = slam_from_log(replay_server["log"], replay_server["config"], seed=0).grid
    expected = grid_cells(offline)  # rows = y, like the browser's tiles
    height, width = expected.shape
    shown = np.array(page.evaluate(CELLS_JS, [float(offline.origin[0]), float(offline.origin[1]),
                                              float(offline.resolution), width, height]), np.int64)
    shown = shown.reshape(height, width)
    known = expected != UNKNOWN
    assert known.sum() > 20_000, known.sum()  # a real building, not a few cells
    agree = (shown != UNKNOWN) & ((shown >= OCCUPIED_PERCENT) == (expected >= OCCUPIED_PERCENT))
    share = agree[known].mean()
    assert share >= 0.95, f"the dashboard agrees with homebot slam on {share:.1%} of its known cells"
    # and the page says what it shows: a replay of that log
    assert "mit-slice" in page.locator("body").inner_text()
