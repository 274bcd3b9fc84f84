"""Child processes end with the server: a parent-death signal and a watcher thread.

A child of the server (the SLAM worker, the simulator) calls :func:`bind_to_parent` first
thing. On Linux the kernel then kills it the moment its parent dies
(``prctl(PR_SET_PDEATHSIG, SIGKILL)``). That signal is tied to the *thread* that started the
child, so a daemon thread also watches the parent's pid and the server's, and ends the process
once it has been orphaned or the server is gone. (The worker's parent is the server's fork
server, :mod:`app.worker.supervisor`, which itself ends with the server.) Neither path tries
a clean stop: nobody reads the child's messages any more, so a clean exit could wait forever
on a full pipe, and what matters is already on disk (checkpoints are atomic and at most a
second old).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
import signal
import sys
import threading
import time
from pathlib import Path

log = logging.getLogger(__name__)

#: ``PR_SET_PDEATHSIG`` from ``<linux/prctl.h>``.
PR_SET_PDEATHSIG = 1
#: How often the watcher looks at the parent (s).
POLL_S = 0.2
#: Exit status of a child ended because its parent died.
EXIT_ORPHANED = 3


def set_parent_death_signal(signum: int = signal.SIGKILL) -> bool:
    """Ask the kernel to send ``signum`` to this process when its parent dies (Linux only)."""
    if not sys.platform.startswith("linux"):
        return False
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    if libc.prctl(PR_SET_PDEATHSIG, int(signum), 0, 0, 0) != 0:
        log.warning("prctl(PR_SET_PDEATHSIG) failed: %s", os.strerror(ctypes.get_errno()))
        return False
    return True


def alive(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie, dead but not yet reaped, does not)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False
    except OSError:  # no /proc: existence is all one can tell
        try:
            os.kill(pid, 0)
            return True
        except ProcessLookupError:
            return False
        except PermissionError:
            return True


def bind_to_parent(server_pid: int) -> None:
    """End this process as soon as its parent dies or ``server_pid`` no longer runs (see the
    module docstring). The server may already be gone when this runs: then it ends at once."""
    set_parent_death_signal(signal.SIGKILL)
    parent = os.getppid()
    threading.Thread(target=_watch, args=(parent, server_pid), name="lifeline", daemon=True).start()


def _watch(parent_pid: int, server_pid: int) -> None:
    while os.getppid() == parent_pid and alive(server_pid):
        time.sleep(POLL_S)
    os._exit(EXIT_ORPHANED)
