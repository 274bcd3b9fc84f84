"""map -> odom in a local ``homebot serve`` (simulated flat, touring): how right and fresh the served pose is.

Prints, with median / 95th percentile / max:

- the served pose (``api/status``: correction ∘ newest odometry) against the simulator's true pose
  while the robot drives (m, rad);
- the age of what it is made of when read: the newest odometry (``frames.odom_t``) and the
  worker's last step (``worker.state_t``), s;
- pose messages per second on the websocket with the worker running, and with the worker frozen
  (SIGSTOP for ``--freeze`` s): then also how far the served and the true pose moved, and the error
  at the end of the freeze.

    python benchmarks/frames_live.py [--drive 30] [--freeze 2]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import os
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path

import websockets

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.live_server import LiveServer, until


def summary(name: str, values: list[float], unit: str) -> None:
    ordered = sorted(values)
    p95 = ordered[min(len(ordered) - 1, int(0.95 * len(ordered)))]
    print(f"{name:44s} median {statistics.median(values):8.4f}  p95 {p95:8.4f}  max {max(values):8.4f} {unit}"
          f"  (n={len(values)})")


def errors(status: dict) -> tuple[float, float]:
    pose, true = status["pose"], status["true_pose"]
    return (math.hypot(pose["x"] - true[0], pose["y"] - true[1]),
            abs(math.remainder(pose["yaw"] - true[2], 2 * math.pi)))


async def pose_rate(server: LiveServer, seconds: float, freeze_pid: int | None) -> tuple[list, dict, dict]:
    """Pose messages over ``seconds`` (the worker frozen if ``freeze_pid``), the status before and after."""
    async with websockets.connect(f"{server.ws_url}?token={server.token}", max_size=None) as ws:
        poses: list[dict] = []

        async def collect():
            async for raw in ws:
                if isinstance(raw, str) and (message := json.loads(raw))["type"] == "pose":
                    poses.append(message)

        reader = asyncio.create_task(collect())
        await asyncio.sleep(1.0)
        before = await asyncio.to_thread(server.status)
        if freeze_pid:
            os.kill(freeze_pid, signal.SIGSTOP)
        try:
            del poses[:]
            await asyncio.sleep(seconds)
            taken = list(poses)
            after = await asyncio.to_thread(server.status)
        finally:
            if freeze_pid:
                os.kill(freeze_pid, signal.SIGCONT)
        reader.cancel()
    return taken, before, after


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drive", type=float, default=30.0, help="seconds of sampling while touring")
    parser.add_argument("--freeze", type=float, default=2.0, help="seconds the worker is frozen")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        server = LiveServer(Path(tmp) / "data", env={"HOMEBOT_SIM_TOUR": "1"}).start()
        try:
            until(lambda: (s := server.status())["localized"] and s["worker"]["steps"] > 20, 120, "localized")
            samples = []
            deadline = time.monotonic() + args.drive
            while time.monotonic() < deadline:
                samples.append(server.status())
                time.sleep(0.2)
            summary("served pose error (position)", [errors(s)[0] for s in samples], "m")
            summary("served pose error (heading)", [errors(s)[1] for s in samples], "rad")
            if samples[0].get("frames"):  # (a server before issue 15 has no frames in its status)
                ages = [s["time"] - s["frames"]["odom_t"] for s in samples]
                summary("age of the newest odometry", ages, "s")
            summary("age of the worker's last step", [s["time"] - s["worker"]["state_t"] for s in samples],
                    "s")
            poses, _, _ = asyncio.run(pose_rate(server, args.freeze, None))
            print(f"pose messages, worker running: {len(poses) / args.freeze:.1f} /s")
            pid = server.status()["worker"]["pid"]
            poses, before, after = asyncio.run(pose_rate(server, args.freeze, pid))
            served = math.dist((poses[0]["x"], poses[0]["y"]), (poses[-1]["x"], poses[-1]["y"]))
            true = math.dist(before["true_pose"][:2], after["true_pose"][:2])
            odometry = (math.dist(before["frames"]["odom"][:2], after["frames"]["odom"][:2])
                        if before.get("frames") else math.nan)
            print(f"pose messages, worker frozen {args.freeze:.1f} s: {len(poses) / args.freeze:.1f} /s, "
                  f"{len({p['seq'] for p in poses})} worker step(s); served pose moved {served:.3f} m "
                  f"(first to last message), odometry {odometry:.3f} m, true pose {true:.3f} m "
                  f"(status before and after); error before {errors(before)[0]:.3f} m, "
                  f"at the end {errors(after)[0]:.3f} m")
        finally:
            server.stop()


if __name__ == "__main__":
    main()
