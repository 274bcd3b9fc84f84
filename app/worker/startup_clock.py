"""Where a worker's start-up time goes: wall and CPU seconds per stage, from the process's birth.

The first stage ("spawn and imports") runs from the moment the kernel created the process
(``/proc/self/stat``) to the first :meth:`StartupClock.mark`, so it covers the interpreter's
start and every import that unpickling the worker's entry point pulled in.
"""

from __future__ import annotations

import os
import time
from pathlib import Path


def process_age_s() -> float:
    """Seconds since this process was created (0 where ``/proc`` is not there)."""
    try:
        fields = Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    started = int(fields[19]) / os.sysconf("SC_CLK_TCK")
    return max(0.0, time.clock_gettime(time.CLOCK_BOOTTIME) - started)


class StartupClock:
    """Stages marked in order; :meth:`stages` gives ``{stage: [wall s, CPU s]}``."""

    def __init__(self) -> None:
        self._wall = time.monotonic() - process_age_s()
        self._cpu = 0.0
        self._stages: dict[str, list[float]] = {}

    def mark(self, stage: str) -> None:
        """End ``stage`` now (it began where the previous one ended)."""
        wall, cpu = time.monotonic(), time.process_time()
        self._stages[stage] = [round(wall - self._wall, 3), round(cpu - self._cpu, 3)]
        self._wall, self._cpu = wall, cpu

    def stages(self) -> dict[str, list[float]]:
        return dict(self._stages)
