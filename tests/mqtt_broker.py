"""A real Debian ``mosquitto`` on a free loopback port, for tests (installed with apt-get when missing)."""

from __future__ import annotations

import getpass
import os
import shutil
import socket
import subprocess
import time
from pathlib import Path

from tests.live_server import free_port

APT_TIMEOUT_S = 900
START_TIMEOUT_S = 10.0
#: Debian installs the broker in /usr/sbin, which is not on every PATH.
SEARCH_PATH = f"{os.environ.get('PATH', '')}:/usr/sbin:/usr/local/sbin"


def _apt(*args: str) -> None:
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    done = subprocess.run(["apt-get", *args], env=env, capture_output=True, text=True, timeout=APT_TIMEOUT_S)
    if done.returncode != 0:
        raise RuntimeError(f"apt-get {' '.join(args)} failed ({done.returncode}):\n{done.stderr[-2000:]}")


def system_tool(command: str, package: str) -> str:
    """The path of ``command``; Debian's ``package`` is installed with apt-get when it is missing."""
    path = shutil.which(command, path=SEARCH_PATH)
    if path is None:
        _apt("update")
        _apt("install", "-y", "--no-install-recommends", package)
        path = shutil.which(command, path=SEARCH_PATH)
    assert path, f"{command} is not installed even after apt-get install -y {package}"
    return path


def mosquitto_path() -> str:
    """The system broker (Debian's ``mosquitto`` package)."""
    return system_tool("mosquitto", "mosquitto")


class Mosquitto:
    """One broker process: anonymous, no persistence, listening on 127.0.0.1 only."""

    def __init__(self, workdir: Path, executable: str | None = None, listener_options: str = "",
                 anonymous: bool = True):
        self.workdir = Path(workdir)
        self.executable = executable or mosquitto_path()
        self.listener_options = listener_options
        self.anonymous = anonymous
        self.port = free_port()
        self.proc: subprocess.Popen | None = None

    def start(self) -> Mosquitto:
        conf = self.workdir / "mosquitto.conf"
        # Started as root, mosquitto would drop to user "mosquitto", who cannot read the test's files.
        conf.write_text(f"user {getpass.getuser()}\nlistener {self.port} 127.0.0.1\n{self.listener_options}"
                        f"allow_anonymous {str(self.anonymous).lower()}\npersistence false\n"
                        f"log_dest file {self.workdir / 'mosquitto.log'}\n")
        self.proc = subprocess.Popen([self.executable, "-c", str(conf)], stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"mosquitto exited: {self.proc.stderr.read()}")
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.5):
                    return self
            except OSError:
                time.sleep(0.05)
        self.stop()
        raise RuntimeError(f"mosquitto did not listen on port {self.port}")

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc = None
