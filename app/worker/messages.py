"""The messages between the server and the worker process: frozen dataclasses, never tuples or dicts.

Server -> worker (the command queue): :class:`SetMode`, :class:`SetPose`, :class:`SetMapping`,
:class:`SaveSession`, :class:`ResumeSession`, :class:`Shutdown` (velocity goes to
:class:`~app.robot_link.link.RobotLink`, never through the worker). Worker -> server (the state
queue): :class:`WorkerState` after every step and :class:`WorkerEvent` for everything else (the
supervisor sends a few events of its own). A message of any other type (a garbled or stale one) is
logged and dropped, never a crash.
"""

from __future__ import annotations

import logging
import queue
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SetMode:
    """Switch the estimator: ``yaml_path`` a saved map to load (``None``: keep the current one),
    ``new_map`` start mapping afresh on an empty map."""

    mode: str
    yaml_path: str | None = None
    map_name: str | None = None
    new_map: bool = False


@dataclass(frozen=True)
class SetPose:
    """The robot's pose in the map frame (m, m, rad), given by a person."""

    x: float
    y: float
    yaw: float = 0.0


@dataclass(frozen=True)
class SetMapping:
    """Mapping on (the map grows) or off (localization on the map as it is)."""

    enabled: bool


@dataclass(frozen=True)
class SaveSession:
    """Save the mapping session so far (every update's pose, odometry and scan) to ``path``."""

    path: str


@dataclass(frozen=True)
class ResumeSession:
    """Map on in the session saved at ``path``, after finding the robot in its map."""

    path: str


@dataclass(frozen=True)
class Shutdown:
    """Save and exit."""


Command = SetMode | SetPose | SetMapping | SaveSession | ResumeSession | Shutdown


@dataclass(frozen=True)
class WorkerState:
    """The estimate after one worker step (arrays in the map frame unless said).

    ``map_to_odom`` is the REP-105 correction ``pose ∘ odometry⁻¹`` against the odometry the
    step used, stamped ``odom_stamp`` (see :mod:`app.worker.frames`).
    """

    t: float
    seq: int
    pose: np.ndarray
    localized: bool
    map_to_odom: np.ndarray
    odom_stamp: float
    mode: str
    mapping: bool
    steps: int
    rate_hz: float
    relocalizing: bool = False
    particles: np.ndarray | None = None
    weights: np.ndarray | None = None
    points: np.ndarray | None = None
    landmarks: np.ndarray | None = None
    landmark_covariances: np.ndarray | None = None
    replay: dict | None = None
    loops: dict | None = None
    odometry: dict | None = None  # the estimator's odometry calibration (OdometryCalibration.summary)


@dataclass(frozen=True)
class WorkerEvent:
    """Something that happened (``name``: ``started``, ``changed``, ``error``, ``loop_closed``, ...)
    at ``t``, with the fields that event carries."""

    name: str
    t: float
    fields: dict[str, Any] = field(default_factory=dict)

    def dict(self) -> dict:
        """The event as the status and the stream show it: ``{"event", "t", **fields}``."""
        return {"event": self.name, "t": self.t, **self.fields}


WorkerMessage = WorkerState | WorkerEvent


def accepted(message: object, types: type | tuple[type, ...], side: str) -> bool:
    """Whether ``message`` is one of ``types``; anything else is logged (as seen by ``side``) and dropped."""
    if isinstance(message, types):
        return True
    log.warning("%s: dropped a message of unknown type %s: %.200r", side, type(message).__name__, message)
    return False


def waiting_commands(commands) -> Iterator[Command]:
    """Every command waiting on the ``commands`` queue, without blocking; unreadable (unpickling
    failed) and unknown ones are logged and dropped."""
    while True:
        try:
            command = commands.get_nowait()
        except queue.Empty:
            return
        except Exception:
            log.warning("worker: dropped an unreadable command", exc_info=True)
            continue
        if accepted(command, Command, "worker"):
            yield command
