"""Supervision: children die with the server, one worker per data dir, restarts back off, health tells."""

from __future__ import annotations

import multiprocessing as mp
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

from app.worker.lockfile import DataDirBusy, acquire_worker_lock
from app.worker.supervisor import RESTART_DELAY_CAP_S, restart_delay, without_data_dir
from tests.live_server import LiveServer
from tests.recovery_harness import descendants

ROOT = Path(__file__).resolve().parent.parent
#: Semaphores of one worker generation (two queues of three each): all a killed server may leave.
SEMAPHORES_PER_GENERATION = 6


def running(pid: int) -> bool:
    """Alive and not a zombie waiting to be reaped."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def healthcheck(port: int) -> subprocess.CompletedProcess:
    """The Docker health check, run against ``port``."""
    return subprocess.run([sys.executable, str(ROOT / "docker" / "healthcheck.py"), str(port)],
                          capture_output=True, text=True, timeout=30)


def test_restart_delay_doubles_up_to_the_cap():
    delays = [restart_delay(0.5, n) for n in range(1, 12)]
    assert delays[:4] == [0.5, 1.0, 2.0, 4.0]
    assert max(delays) == RESTART_DELAY_CAP_S and delays == sorted(delays)


def _hold_lock(data_dir: str, ready) -> None:
    acquire_worker_lock(Path(data_dir))
    ready.set()
    time.sleep(60)


def test_worker_messages_name_the_data_dir_as_data(tmp_path, monkeypatch):
    absolute = tmp_path / "data"
    text = f"SaveSession: {absolute}/sessions/a.session.npz: No space left"
    assert without_data_dir(text, absolute) == "SaveSession: DATA/sessions/a.session.npz: No space left"
    monkeypatch.chdir(tmp_path)
    relative = Path("data")
    text = f"{absolute}/maps/x.yaml, data/maps/y.yaml and metadata/z: bad"
    assert without_data_dir(text, relative) == "DATA/maps/x.yaml, DATA/maps/y.yaml and metadata/z: bad"


def test_a_worker_left_by_an_earlier_server_is_ended_before_a_new_one_runs(tmp_path):
    ctx = mp.get_context("spawn")
    ready = ctx.Event()
    orphan = ctx.Process(target=_hold_lock, args=(str(tmp_path), ready))
    orphan.start()
    try:
        assert ready.wait(30)
        lock = acquire_worker_lock(tmp_path)
        assert lock.ended_pid == orphan.pid
        orphan.join(5)
        assert orphan.exitcode == -signal.SIGTERM
        assert (tmp_path / "worker.lock").read_text().strip() == str(os.getpid())
        lock.release()
    finally:
        if orphan.is_alive():
            orphan.kill()


def test_a_holder_that_is_no_worker_is_never_ended_and_the_start_is_refused(tmp_path):
    held = acquire_worker_lock(tmp_path)  # this test process: not a worker, never signalled
    try:
        with pytest.raises(DataDirBusy, match="refusing to run a second worker"):
            acquire_worker_lock(tmp_path)
    finally:
        held.release()
    acquire_worker_lock(tmp_path).release()  # free again once released


def test_no_child_outlives_a_killed_server(tmp_path):
    server = LiveServer(tmp_path / "data").start()
    assert healthcheck(server.port).returncode == 0  # mapping and localized: healthy
    children = descendants(server.proc.pid)
    assert len(children) >= 2, children  # the worker and the simulator (and the resource tracker)
    server.proc.kill()
    server.proc.wait()
    time.sleep(3.0)
    assert [pid for pid in children if running(pid)] == []
    server.stop()


def test_a_stop_signal_to_every_process_of_the_service_saves_the_map_and_ends_them_all(tmp_path):
    """As systemd stops a service: SIGTERM to the server, its worker, the worker's fork server and
    the simulator at once. The worker saves its map, nothing is restarted, nothing is left."""
    server = LiveServer(tmp_path / "data", env={"HOMEBOT_SIM_TOUR": "1"}, own_group=True).start()
    children = descendants(server.proc.pid)
    signalled = time.time()
    os.killpg(server.proc.pid, signal.SIGTERM)
    server.proc.wait(20)
    output = server.proc.stdout.read()
    assert "Traceback" not in output and "leaked" not in output, output
    assert "odometry grabber: lost" not in output, output  # the simulated robot outlived the link
    assert "restarting" not in output, output  # the worker's clean exit is the service's stop, not a crash
    assert (tmp_path / "data" / "last_map.pgm").stat().st_mtime >= signalled, output
    time.sleep(1.0)
    assert [pid for pid in children if running(pid)] == []
    server.stop()


def test_a_crash_looping_worker_backs_off_degrades_health_and_leaks_nothing(tmp_path):
    """A real-robot server whose scan source cannot load: the worker dies at every start."""
    env = {"HOMEBOT_SENSOR_SOURCE": "no_such_module:scans", "HOMEBOT_SERIAL_PORT": str(tmp_path / "no-tty"),
           "HOMEBOT_WORKER_RESTART_DELAY_S": "0.2"}
    server = LiveServer(tmp_path / "data", env=env).launch("--real")
    try:
        deadline = time.monotonic() + 60
        health, worker = {}, {}
        while time.monotonic() < deadline and worker.get("restarts", 0) < 4:
            time.sleep(0.5)
            try:
                health = httpx.get(f"{server.base}/api/health", timeout=5).json()
                worker = server.status()["worker"]
            except (httpx.HTTPError, OSError, ValueError):
                continue
        assert worker["restarts"] >= 4 and worker["crash_looping"], worker
        assert health["status"] == "degraded", health
        assert any("crash-looping" in r and "no_such_module" in r for r in health["reasons"]), health
        checked = healthcheck(server.port)
        assert checked.returncode == 1 and "crash-looping" in checked.stdout, checked
        # Backed off: restarts after the first few come ever more slowly (0.2, 0.4, 0.8, 1.6 s ...).
        started = time.monotonic()
        first = server.status()["worker"]["restarts"]
        time.sleep(3.0)
        assert server.status()["worker"]["restarts"] - first <= 2
        assert time.monotonic() - started < 10
    finally:
        server.proc.kill()  # a killed server leaves only its last generation's semaphores
        server.proc.wait()
        time.sleep(2.0)  # the resource tracker reports when the last child is gone
        server.stop()
    leaked = re.findall(r"There appear to be (\d+) leaked semaphore", server.output)
    assert sum(map(int, leaked)) <= SEMAPHORES_PER_GENERATION, server.output[-2000:]
