"""A CARMEN log in the robot's place, for the worker: the feed, the pairing and the recording.

The feed (:class:`~app.replay.log_feed.LogReplay`) puts each record's odometry into the
worker's history and into the odometry ring (so the server composes its pose as for a robot)
and its scan into the worker's scan input; the worker pairs them as a robot's
(:class:`~app.worker.pairing.StampedPairing`) and tells :meth:`ReplayDriver.stepped` what it
did with each, which the recording (:class:`~app.replay.recording.ReplayRecording`) keeps for
the outputs written at the end.
"""

from __future__ import annotations

from dataclasses import asdict

from app.core.config import Settings
from app.grabbers.odometry_history import OdometryHistory
from app.grabbers.shared import Backlog, Fanout
from app.replay.log_feed import LoggedOdometry, LogReplay, read_laser_records, replay_name
from app.replay.recording import ReplayRecording
from app.robot.odometry_ring import OdometryRing
from app.worker.pairing import StampedPairing
from slam_core.datasets import resolve_log


class ReplayDriver:
    """``settings.replay`` played into ``scans`` and ``ring``; see the module docstring."""

    def __init__(self, settings: Settings, scans: Backlog, ring: OdometryRing):
        path = resolve_log(settings.replay)
        self.records, warnings = read_laser_records(path)
        name = replay_name(settings.replay)
        history = OdometryHistory()
        self.feed = LogReplay(self.records, settings.replay_speed, Fanout(history, ring), scans)
        self.recording = ReplayRecording(path, name, self.records, settings.replay_dir / name,
                                         settings.replay_speed, settings.seed, warnings)
        self.pairing = StampedPairing(history, scans)

    @property
    def start_odometry(self):
        """The first record's odometry: the start pose (the log's odometry frame is the map frame)."""
        return self.records[0].odom

    def last_odometry(self) -> LoggedOdometry:
        last = self.records[-1]
        return LoggedOdometry(last.odom, last.stamp.ipc_time)

    def progress(self) -> dict:
        return asdict(self.recording.progress(self.feed.played))

    def stepped(self, scan_seq: int, updated: bool, update_index: int) -> None:
        """The worker stepped the record whose scan has sequence number ``scan_seq``."""
        self.recording.stepped(scan_seq - 1, updated, update_index)

    def taken(self, scan_seq: int) -> None:
        """The worker took that record (stepped or skipped): a ``--speed max`` feed plays the next."""
        self.feed.mark_stepped(scan_seq - 1)

    def played_all(self) -> bool:
        """Whether the whole log was played and every scan taken, with the back end still to run."""
        return (self.recording.phase == "playing" and self.feed.ended.is_set()
                and self.pairing.last_scan == len(self.records))
