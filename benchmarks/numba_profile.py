"""Per-kernel numba cost of a start: compile time on an empty cache, load time on a filled one.

Each stage runs in a fresh process on one ``NUMBA_CACHE_DIR``: first empty ("cold", every kernel
compiled), then again on the cache the first run filled ("warm", every kernel loaded). Times are
CPU seconds of the thread that compiles (``time.thread_time``), exclusive of the kernels compiled
inside a kernel's own compilation, so the rows add up to the stage's total.

    python benchmarks/numba_profile.py [--stage mapping|localization|ekf|slam] [--top 25]

Stages: ``mapping``, ``localization``, ``ekf`` are the worker's
:func:`app.worker.estimators.warm_up` for that mode; ``slam`` is ``homebot slam`` (filter and
loop-closing back end) on the first 150 lines of mit-csail, as ``benchmarks/slam_datasets.py``
times it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SLICE_LINES = 150


def profiled(stage: str) -> dict:
    """Run ``stage`` in this process with ``Dispatcher.compile`` timed; the costs per kernel."""
    from numba.core import dispatcher

    costs: dict[str, float] = defaultdict(float)
    stack: list[float] = []  # CPU time spent in nested compilations, per open frame
    original = dispatcher.Dispatcher.compile

    def timed(self, sig):
        if tuple(sig.args if hasattr(sig, "args") else sig) in self.overloads:
            return original(self, sig)
        stack.append(0.0)
        t0 = time.thread_time()
        try:
            return original(self, sig)
        finally:
            spent = time.thread_time() - t0
            nested = stack.pop()
            name = f"{self.py_func.__module__}.{self.py_func.__qualname__}"
            costs[name] += spent - nested
            if stack:
                stack[-1] += spent

    dispatcher.Dispatcher.compile = timed
    t_import = time.process_time()
    from app.core.config import Settings
    from app.worker import estimators
    t_import = time.process_time() - t_import
    t0 = time.process_time()
    wall = time.perf_counter()
    settings = Settings(_env_file=None)
    if stage == "slam":
        slam_slice()
    else:
        estimators.warm_up(settings, mode=stage)
    return {"import_cpu": t_import, "stage_cpu": time.process_time() - t0,
            "stage_wall": time.perf_counter() - wall, "costs": dict(costs)}


def slam_slice() -> None:
    """``homebot slam`` on the first :data:`SLICE_LINES` lines of mit-csail, in this process."""
    from app.cli import main
    from slam_core.datasets import BUNDLED
    from slam_core.io.carmen import open_log

    with tempfile.TemporaryDirectory(prefix="numba-profile-slam-") as tmp:
        tiny = Path(tmp) / "tiny.clf"
        with open_log(BUNDLED["mit-csail"][0]) as src, open(tiny, "wb") as dst:
            for _, line in zip(range(SLICE_LINES), src, strict=False):
                dst.write(line)
        assert main(["slam", str(tiny), "--out", str(Path(tmp) / "out")]) == 0


def run(stage: str, cache: str) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, __file__, "--child", stage], env=env, cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--stage", choices=("mapping", "localization", "ekf", "slam"), default="mapping")
    parser.add_argument("--top", type=int, default=25)
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(profiled(args.child)))
        return 0
    with tempfile.TemporaryDirectory(prefix="numba-profile-") as cache:
        cold = run(args.stage, cache)
        warm = run(args.stage, cache)
    print(f"{args.stage}: load average {os.getloadavg()[0]:.1f}")
    for name, r in (("cold", cold), ("warm", warm)):
        print(f"  {name}: imports {r['import_cpu']:.2f} s CPU; stage {r['stage_cpu']:.2f} s CPU "
              f"({r['stage_wall']:.2f} s wall); kernels {sum(r['costs'].values()):.2f} s CPU")
    print(f"  {'kernel':60s} {'compile s':>9s} {'load s':>7s}")
    rows = sorted(cold["costs"].items(), key=lambda kv: -kv[1])
    for name, seconds in rows[:args.top]:
        print(f"  {name:60s} {seconds:9.3f} {warm['costs'].get(name, 0.0):7.3f}")
    rest = rows[args.top:]
    if rest:
        print(f"  {f'({len(rest)} more)':60s} {sum(s for _, s in rest):9.3f} "
              f"{sum(warm['costs'].get(n, 0.0) for n, _ in rest):7.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
