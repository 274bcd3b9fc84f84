"""Fill numba's on-disk cache at image build time: run ``homebot serve`` until the SLAM worker has
stepped and a goal was planned (which compiles the simulator, estimator, ray-casting and planner
kernels), then stop it with SIGINT. Standard library only; exits non-zero when the server never
became ready, so a broken image fails its build."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

PORT = 18765
READY_TIMEOUT_S = 300
STEPS_WANTED = 5
GOAL_OFFSET_M = 0.5


def call(method: str, path: str, token: str | None = None, body: dict | None = None):
    request = urllib.request.Request(f"http://127.0.0.1:{PORT}/api/{path}", method=method,
                                     data=None if body is None else json.dumps(body).encode())
    request.add_header("Content-Type", "application/json")
    if token:
        request.add_header("Authorization", f"Bearer {token}")
    with urllib.request.urlopen(request, timeout=5) as response:
        return json.loads(response.read() or b"null")


def main() -> int:
    data = Path(tempfile.mkdtemp(prefix="homebot-warm-"))
    command = [sys.executable, "-m", "app.cli", "serve", "--port", str(PORT), "--data", str(data)]
    server = subprocess.Popen(command)
    deadline = time.monotonic() + READY_TIMEOUT_S
    try:
        while time.monotonic() < deadline:
            if server.poll() is not None:
                print(f"warm-up: the server exited with {server.returncode}", file=sys.stderr)
                return 1
            try:
                token = (data / "token").read_text().strip()
                status = call("GET", "status", token)
            except (OSError, urllib.error.URLError, ValueError):
                time.sleep(1)
                continue
            if status["worker"]["steps"] >= STEPS_WANTED:
                pose = status["pose"]
                try:
                    call("POST", "goal", token, {"x": pose["x"] + GOAL_OFFSET_M, "y": pose["y"]})
                except urllib.error.HTTPError as exc:  # an unreachable goal still compiled the planner
                    print(f"warm-up: goal answered {exc.code}")
                time.sleep(2)
                print(f"warm-up: worker took {status['worker']['steps']} steps; numba cache filled")
                return 0
            time.sleep(1)
        print("warm-up: the server did not become ready in time", file=sys.stderr)
        return 1
    finally:
        if server.poll() is None:
            os.kill(server.pid, signal.SIGINT)
            try:
                server.wait(timeout=60)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
        shutil.rmtree(data, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
