"""A real Debian ``mosquitto`` on a free loopback port, for tests (installed with apt-get when missing)."""

from __future__ import annotations

import getpass
import socket
import subprocess
import time
from pathlib import Path

from tests.debian import system_tool
from tests.live_server import free_port

START_TIMEOUT_S = 10.0


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
