"""Real-browser fixtures: Debian's chromium driven by Playwright, and a server for static/.

Playwright's own browser download cannot be used here, so the browser is the distribution's
``chromium`` found on PATH; the session installs it with apt when it is missing.
"""

from __future__ import annotations

import functools
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import httpx
import pytest
from playwright.sync_api import sync_playwright

from tests.debian import system_tool

REPO = Path(__file__).resolve().parents[2]
STATIC = REPO / "static"
ARTIFACTS = REPO / "test-artifacts"
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


@pytest.fixture(scope="session")
def chromium_path() -> str:
    """The system chromium (Debian's ``chromium`` package)."""
    return system_tool("chromium", "chromium")


@pytest.fixture(scope="module")
def browser(chromium_path):
    """Chromium for one test module. Playwright's sync API keeps an asyncio loop running in this
    thread while it is open, so it must not outlive the module (other tests call asyncio.run)."""
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium_path, args=CHROMIUM_ARGS)
        yield browser
        browser.close()


@pytest.fixture
def page(browser):
    context = browser.new_context(viewport={"width": 1280, "height": 800})
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.js_errors = errors
    yield page
    context.close()


class _QuietHandler(SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture(scope="session")
def static_url():
    """static/ served as plain files (for the module-level checks, which need no robot)."""
    handler = functools.partial(_QuietHandler, directory=str(STATIC))
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()


@pytest.fixture(scope="session")
def artifacts() -> Path:
    ARTIFACTS.mkdir(exist_ok=True)
    return ARTIFACTS


SERVER_READY_TIMEOUT_S = 180  # a cold numba cache compiles the simulator and estimator kernels first
SERVER_STOP_TIMEOUT_S = 30


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class HomebotServer:
    """``python -m app.cli serve`` in simulation mode as a subprocess, on a free port."""

    def __init__(self, data: Path, log: Path):
        self.data = data
        self.log_path = log
        self.port = _free_port()
        self.url = f"http://127.0.0.1:{self.port}/"
        self.process: subprocess.Popen | None = None
        self.token: str | None = None

    def start(self) -> None:
        command = [sys.executable, "-m", "app.cli", "serve", "--port", str(self.port),
                   "--data", str(self.data)]
        # No scripted tour: the tests decide where the robot goes (the tour has its own server test).
        env = {**os.environ, "HOMEBOT_SIM_TOUR": "0"}
        with open(self.log_path, "ab") as log:
            self.process = subprocess.Popen(command, cwd=REPO, env=env, stdout=log, stderr=subprocess.STDOUT)
        self.wait_ready()

    def log_tail(self) -> str:
        return self.log_path.read_text(errors="replace")[-3000:]

    def api(self, method: str, path: str, **kwargs) -> httpx.Response:
        headers = {"Authorization": f"Bearer {self.token}"}
        # longer than the server's own wait for a mode switch (then 202) on a busy machine
        return httpx.request(method, self.url + "api/" + path, headers=headers, timeout=30, **kwargs)

    def wait_ready(self) -> None:
        """Until the token exists, the API answers and the worker has published a pose and a map."""
        deadline = time.monotonic() + SERVER_READY_TIMEOUT_S
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"homebot serve exited with {self.process.returncode}:\n{self.log_tail()}")
            token_file = self.data / "token"
            if token_file.exists():
                self.token = token_file.read_text().strip()
                try:
                    status = self.api("GET", "status").json()
                    if status.get("pose") and status.get("map") and status["worker"]["steps"] > 0:
                        return
                except httpx.HTTPError:
                    pass
            time.sleep(0.5)
        raise RuntimeError(f"homebot serve not ready after {SERVER_READY_TIMEOUT_S} s:\n{self.log_tail()}")

    def stop(self) -> None:
        if self.process and self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout=SERVER_STOP_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


@pytest.fixture(scope="module")
def homebot_server(tmp_path_factory, artifacts):
    """A real homebot server with its simulated robot, for one module of live dashboard tests (it
    stops when the module is done, so it does not load the machine during the rest of the suite)."""
    data = tmp_path_factory.mktemp("homebot-data")
    server = HomebotServer(data, artifacts / "homebot-serve.log")
    server.log_path.write_text("")
    server.start()
    yield server
    server.stop()


class SubPathProxy:
    """A minimal reverse proxy that serves the server under ``/robot/`` (it strips the prefix), for
    HTTP and websocket upgrades alike, and records every path the browser asked for. A request
    outside the prefix (an absolute URL in the dashboard) gets a 404 and is listed in ``refused``."""

    PREFIX = b"/robot"

    def __init__(self, target_port: int):
        self.target_port = target_port
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.url = f"http://127.0.0.1:{self.listener.getsockname()[1]}{self.PREFIX.decode()}/"
        self.paths: list[str] = []
        self.refused: list[str] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def close(self) -> None:
        self.listener.close()

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self.listener.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(client,), daemon=True).start()

    def _serve(self, client: socket.socket) -> None:
        data = b""
        while b"\r\n\r\n" not in data:
            chunk = client.recv(65536)
            if not chunk:
                client.close()
                return
            data += chunk
        head, body = data.split(b"\r\n\r\n", 1)
        request_line, *headers = head.split(b"\r\n")
        method, path, version = request_line.split(b" ", 2)
        if not path.startswith(self.PREFIX + b"/"):
            self.refused.append(path.decode())
            client.sendall(b"HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n")
            client.close()
            return
        self.paths.append(path.decode().split("?")[0])
        if not any(h.lower().startswith(b"upgrade:") for h in headers):  # one request per connection
            headers = [h for h in headers if not h.lower().startswith(b"connection:")]
            headers.append(b"Connection: close")
        upstream = socket.create_connection(("127.0.0.1", self.target_port))
        line = b" ".join([method, path[len(self.PREFIX):], version])
        upstream.sendall(b"\r\n".join([line, *headers]) + b"\r\n\r\n" + body)
        back = threading.Thread(target=self._pipe, args=(upstream, client), daemon=True)
        back.start()
        self._pipe(client, upstream)
        back.join()
        client.close()
        upstream.close()

    @staticmethod
    def _pipe(source: socket.socket, sink: socket.socket) -> None:
        try:
            while chunk := source.recv(65536):
                sink.sendall(chunk)
            sink.shutdown(socket.SHUT_WR)
        except OSError:
            pass


@pytest.fixture
def subpath_proxy(homebot_server):
    proxy = SubPathProxy(homebot_server.port)
    yield proxy
    proxy.close()
