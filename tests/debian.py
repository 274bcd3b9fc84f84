"""Debian packages the tests need (``chromium``, ``mosquitto``), installed with apt-get when missing.

Test processes that run side by side take turns (a lock file), as apt-get allows one at a time.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

APT_TIMEOUT_S = 900
#: Debian installs some tools (the broker) in /usr/sbin, which is not on every PATH.
SEARCH_PATH = f"{os.environ.get('PATH', '')}:/usr/sbin:/usr/local/sbin"
LOCK = Path(tempfile.gettempdir()) / "homebot-tests-apt.lock"


def _apt(*args: str) -> None:
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    done = subprocess.run(["apt-get", *args], env=env, capture_output=True, text=True, timeout=APT_TIMEOUT_S)
    if done.returncode != 0:
        raise RuntimeError(f"apt-get {' '.join(args)} failed ({done.returncode}):\n{done.stderr[-2000:]}")


def system_tool(command: str, package: str) -> str:
    """The path of ``command``; Debian's ``package`` is installed first when it is missing."""
    path = shutil.which(command, path=SEARCH_PATH)
    if path is None:
        with open(LOCK, "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            path = shutil.which(command, path=SEARCH_PATH)  # another test process may have installed it
            if path is None:
                _apt("update")
                _apt("install", "-y", "--no-install-recommends", package)
                path = shutil.which(command, path=SEARCH_PATH)
    assert path, f"{command} is not installed even after apt-get install -y {package}"
    return path
