"""Typed messages between server and worker: unknown or garbled ones are logged and dropped, never a crash."""

from __future__ import annotations

import logging
import multiprocessing as mp
import time

import numpy as np
import pytest

from app.core.config import Settings
from app.robot.odometry_ring import OdometryRing
from app.worker.messages import (
    SetMapping,
    SetMode,
    SetPose,
    Shutdown,
    WorkerEvent,
    WorkerState,
    waiting_commands,
)
from app.worker.supervisor import WorkerSupervisor


def _explode():
    raise RuntimeError("garbled on the wire")


class Garbled:
    """Pickles fine, cannot be unpickled: what a torn or foreign message looks like to the reader."""

    def __reduce__(self):
        return _explode, ()


def _queue_with(*items):
    q = mp.get_context("spawn").Queue()
    for item in items:
        q.put(item)
    time.sleep(0.2)  # the feeder thread has written them all
    return q


def test_the_worker_takes_its_commands_and_drops_the_rest(caplog):
    good = [SetMode("localization", "/maps/a.yaml", "a"), SetPose(1.0, 2.0, 0.5), SetMapping(False),
            Shutdown()]
    q = _queue_with(good[0], ("mode", "mapping", None, None, False), Garbled(), good[1],
                    {"kind": "velocity"}, good[2], good[3])
    with caplog.at_level(logging.WARNING):
        taken = list(waiting_commands(q))
    assert taken == good
    assert sum("dropped" in r.message for r in caplog.records) == 3
    q.close()


def test_the_supervisor_relays_worker_messages_and_drops_the_rest(tmp_path, caplog):
    delivered = []
    supervisor = WorkerSupervisor(Settings(data_dir=tmp_path, map_capacity_cells=64 * 64),
                                  OdometryRing.create(), None, delivered.append)
    try:
        state = WorkerState(t=1.0, seq=3, pose=np.array([1.0, 2.0, 0.1]), localized=True,
                            map_to_odom=np.array([0.5, 0.0, 0.1]), odom_stamp=0.9, mode="mapping",
                            mapping=True, steps=3, rate_hz=10.0)
        error = WorkerEvent("error", 2.0, {"detail": "SetMode: no such map"})
        supervisor._states = _queue_with({"kind": "state", "pose": [0, 0, 0]}, Garbled(), state,
                                         ("event", "error"), error)
        with caplog.at_level(logging.WARNING):
            for _ in range(8):
                message = supervisor._receive()
                if message is not None:
                    supervisor._deliver(message)
        assert [type(m) for m in delivered] == [WorkerState, WorkerEvent]
        assert np.array_equal(delivered[0].pose, state.pose) and delivered[1] == error
        assert supervisor.health.last_error == "SetMode: no such map"
        assert sum("dropped" in r.message for r in caplog.records) == 3
        supervisor._close_queues()
    finally:
        supervisor.shared_map.close()
        supervisor.shared_map.unlink()


def test_an_event_reads_as_the_status_shows_it():
    assert WorkerEvent("loop_closed", 5.0, {"closures": 2}).dict() == {"event": "loop_closed", "t": 5.0,
                                                                      "closures": 2}


def test_messages_are_frozen():
    with pytest.raises(AttributeError):
        SetPose(1.0, 2.0).x = 3.0
