"""One worker per data dir: an advisory lock file that holds the worker's pid.

The worker takes an exclusive ``flock`` on ``<data dir>/worker.lock`` before it reads or
writes the checkpoint, and keeps it for its whole life; the kernel drops the lock when the
process dies, however it dies, so a stale file never blocks a start. If the lock is held,
the holder is a worker left by an earlier server: it is asked to stop (SIGTERM), then killed,
and the lock taken; if it cannot be ended the new worker refuses to run
(:class:`DataDirBusy`), so two workers never write the same checkpoint.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import signal
import time
from pathlib import Path

LOCK_NAME = "worker.lock"
#: How long a previous holder gets to stop after SIGTERM, then after SIGKILL (s).
TERM_WAIT_S = 3.0
KILL_WAIT_S = 2.0
POLL_S = 0.05


class DataDirBusy(RuntimeError):
    """Another worker holds the data dir and could not be ended."""


class WorkerLock:
    """The held lock; :meth:`release` (or process exit) frees it."""

    def __init__(self, path: Path, fd: int, ended_pid: int | None):
        self.path = path
        self.fd = fd
        #: The pid of the earlier worker that was ended to take the lock, if any.
        self.ended_pid = ended_pid

    def release(self) -> None:
        if self.fd >= 0:
            with contextlib.suppress(OSError):
                fcntl.flock(self.fd, fcntl.LOCK_UN)
            os.close(self.fd)
            self.fd = -1


def acquire_worker_lock(data_dir: Path) -> WorkerLock:
    """Take the data dir's worker lock, ending an earlier holder first (see the module docstring)."""
    path = Path(data_dir) / LOCK_NAME
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        ended = None
        if not _try_lock(fd):
            ended = _holder_pid(fd)
            endable = ended is not None and ended != os.getpid() and _is_spawned_child(ended)
            if not (_end(ended, fd) if endable else _wait_for_lock(fd, KILL_WAIT_S)):
                raise DataDirBusy(f"{path} is held by pid {ended}, which could not be ended; "
                                  "refusing to run a second worker on this data dir")
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        return WorkerLock(path, fd, ended)
    except BaseException:
        os.close(fd)
        raise


def _try_lock(fd: int) -> bool:
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except BlockingIOError:
        return False


def _wait_for_lock(fd: int, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while not _try_lock(fd):
        if time.monotonic() > deadline:
            return False
        time.sleep(POLL_S)
    return True


def _holder_pid(fd: int) -> int | None:
    text = os.pread(fd, 32, 0).decode(errors="replace").strip()
    return int(text) if text.isdigit() else None


def _is_spawned_child(pid: int) -> bool:
    """Whether ``pid`` runs a multiprocessing child (as the worker does), so it is safe to end."""
    try:
        return b"multiprocessing" in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False


def _end(pid: int, fd: int) -> bool:
    """SIGTERM ``pid``, then SIGKILL; True once the lock on ``fd`` is ours."""
    for signum, wait in ((signal.SIGTERM, TERM_WAIT_S), (signal.SIGKILL, KILL_WAIT_S)):
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signum)
        if _wait_for_lock(fd, wait):
            return True
    return False
