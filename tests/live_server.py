"""A real ``homebot serve`` in a subprocess on 127.0.0.1 (random free port), for tests."""

from __future__ import annotations

import asyncio
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import websockets

ROOT = Path(__file__).resolve().parent.parent
START_TIMEOUT_S = 180.0  # a fresh clone compiles the numba kernels once


def until(condition, timeout: float, what: str):
    """Poll ``condition()`` until it returns something truthy (returned), or fail naming ``what``."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := condition():
            return value
        time.sleep(0.3)
    raise AssertionError(f"timed out waiting for {what}")


def ready(status: dict) -> bool:
    """A map and a pose, the warm-up over, and the filter stepping or re-localizing."""
    worker = status["worker"]
    return (status.get("map") is not None and status.get("pose") is not None and status["preparing"] is None
            and bool(worker["steps"] or worker["relocalizing"]))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LiveServer:
    def __init__(self, data_dir: Path, world: str = "flat", env: dict | None = None, own_group: bool = False):
        self.data_dir = Path(data_dir)
        self.own_group = own_group  # its own process group, as a service manager starts it
        self.world = world
        self.env = env or {}
        self.port = 0
        self.proc: subprocess.Popen | None = None
        self.output = ""

    @property
    def base(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def ws_url(self) -> str:
        return f"ws://127.0.0.1:{self.port}/ws"

    @property
    def token(self) -> str:
        return (self.data_dir / "token").read_text().strip()

    def client(self, token: bool = True) -> httpx.Client:
        headers = {"Authorization": f"Bearer {self.token}"} if token else {}
        return httpx.Client(base_url=self.base, headers=headers, timeout=30.0)

    def launch(self, *args: str) -> LiveServer:
        """Start the process (``args`` are extra ``homebot serve`` options) without waiting for it."""
        self.port = free_port()
        env = {**os.environ, "HOMEBOT_SIM_TOUR": "0", **self.env, "PYTHONPATH": str(ROOT)}
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "app.cli", "serve", "--port", str(self.port), "--data", str(self.data_dir),
             "--world", self.world, *args],
            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            start_new_session=self.own_group)
        return self

    def start(self, *args: str) -> LiveServer:
        """Launch (``args``: extra ``homebot serve`` options) and wait until the worker publishes a
        map and a pose from its kernels: a filter step, or the search for the robot in a restored
        map (the preview that a fresh install shows while numba compiles does not count)."""
        self.launch(*args)
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"server exited: {self.proc.stdout.read()}")
            try:
                with self.client() as c:
                    status = c.get("/api/status").json()
                if ready(status):
                    return self
            except (httpx.HTTPError, ValueError, OSError):
                pass
            time.sleep(0.3)
        self.stop()
        raise RuntimeError("server did not become ready")

    def status(self) -> dict:
        with self.client() as c:
            return c.get("/api/status").json()

    def stop(self) -> int | None:
        if self.proc is None:
            return None
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.output = self.proc.stdout.read()
        code, self.proc = self.proc.returncode, None
        return code


def launch_replay(data_dir: Path, log: Path, slam_config: Path, token: str, *options: str,
                  stdout=subprocess.PIPE) -> tuple[subprocess.Popen, int]:
    """``homebot serve --replay LOG --speed max --config SLAM_CONFIG [options]`` on a free port;
    returns the process (text output on ``stdout``) and its port."""
    port = free_port()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "HOMEBOT_TOKEN": token}
    proc = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--port", str(port), "--data", str(data_dir),
         "--replay", str(log), "--speed", "max", "--config", str(slam_config), *options],
        cwd=ROOT, env=env, stdout=stdout, stderr=subprocess.STDOUT, text=True)
    return proc, port


async def connect_stream(port: int, token: str, proc: subprocess.Popen):
    """The server's websocket stream, connected as soon as the server accepts (``proc`` must not
    exit first)."""
    deadline = time.monotonic() + START_TIMEOUT_S
    while True:
        try:
            return await websockets.connect(f"ws://127.0.0.1:{port}/ws?token={token}", max_size=None)
        except OSError:
            if proc.poll() is not None:
                raise RuntimeError(f"homebot serve exited: {proc.stdout.read()}") from None
            if time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.2)
