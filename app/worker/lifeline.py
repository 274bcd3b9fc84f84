"""Child processes end with the server: a parent-death signal and a watcher thread.

A child started by the server (the SLAM worker, the simulator) calls :func:`bind_to_parent`
first thing. On Linux the kernel then sends it SIGTERM the moment its parent dies
(``prctl(PR_SET_PDEATHSIG)``), which the child handles as an ordinary stop. Because that
signal is tied to the thread that started the child, and a child busy compiling kernels may
not reach its stop check soon, a daemon thread also watches the parent's pid: once the
child has been orphaned it asks the child to stop and, if it is still running
:data:`GRACE_S` later, exits the process outright. Either way no child outlives the
server by more than about two seconds.
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
from collections.abc import Callable

log = logging.getLogger(__name__)

#: ``PR_SET_PDEATHSIG`` from ``<linux/prctl.h>``.
PR_SET_PDEATHSIG = 1
#: How often the watcher looks at the parent (s).
POLL_S = 0.2
#: How long an orphaned child may take to stop by itself before it is ended (s).
GRACE_S = 1.0
#: Exit status of a child ended because its parent died.
EXIT_ORPHANED = 3


def set_parent_death_signal(signum: int = signal.SIGTERM) -> bool:
    """Ask the kernel to send ``signum`` to this process when its parent dies (Linux only)."""
    if not sys.platform.startswith("linux"):
        return False
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    if libc.prctl(PR_SET_PDEATHSIG, int(signum), 0, 0, 0) != 0:
        log.warning("prctl(PR_SET_PDEATHSIG) failed: %s", os.strerror(ctypes.get_errno()))
        return False
    return True


def bind_to_parent(parent_pid: int, on_orphaned: Callable[[], None]) -> None:
    """End this process soon after ``parent_pid`` dies (see the module docstring).

    ``on_orphaned`` is called once from the watcher thread to request a clean stop; the
    process is ended with :data:`EXIT_ORPHANED` if it has not exited :data:`GRACE_S` later.
    The parent may already be gone when this runs: then the same happens at once.
    """
    set_parent_death_signal(signal.SIGTERM)
    threading.Thread(target=_watch, args=(parent_pid, on_orphaned), name="lifeline", daemon=True).start()


def _watch(parent_pid: int, on_orphaned: Callable[[], None]) -> None:
    while os.getppid() == parent_pid:
        time.sleep(POLL_S)
    log.warning("the server (pid %d) is gone; stopping", parent_pid)
    try:
        on_orphaned()
    finally:
        time.sleep(GRACE_S)
        os._exit(EXIT_ORPHANED)
