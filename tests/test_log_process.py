"""The laser records parsed by a child process: the reader's records, errors and progress, and the
child gone when the iteration ends."""

import bz2
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from slam_core.datasets import BUNDLED
from slam_core.io import log_process
from slam_core.io.carmen import LaserRecord, LogFormatError, TruncatedLogError, laser_records
from slam_core.io.log_process import LaserRecordsInProcess
from tests.test_carmen import LOG, flaser, write_log


def same_record(a: LaserRecord, b: LaserRecord) -> bool:
    return (a.kind == b.kind and a.stamp == b.stamp and np.array_equal(a.pose, b.pose)
            and np.array_equal(a.odom, b.odom) and np.array_equal(a.scan.angles, b.scan.angles)
            and np.array_equal(a.scan.ranges, b.scan.ranges, equal_nan=True)
            and (a.scan.range_min, a.scan.range_max, a.scan.timestamp)
            == (b.scan.range_min, b.scan.range_max, b.scan.timestamp))


def readers_of(path: Path) -> list[int]:
    """Pids of the log reader's processes reading ``path``."""
    pids = []
    for entry in Path("/proc").iterdir():
        try:
            command = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"slam_core.io.log_process" in command and os.fsencode(path) in command:
            pids.append(int(entry.name))
    return pids


@pytest.mark.parametrize("suffix", [".clf", ".bz2", ".gz"])
def test_the_childs_records_are_the_readers(tmp_path, suffix):
    text = LOG + "".join(flaser([0.5 + 0.01 * i, float("nan"), 90.0], stamp=f"{200 + i}.125")
                         for i in range(3 * log_process.BATCH + 7))
    path = write_log(tmp_path / f"a{suffix}", text)
    here, there = list(laser_records(path)), list(LaserRecordsInProcess(path))
    assert len(there) == len(here) == 4 + 3 * log_process.BATCH + 7
    assert all(same_record(a, b) for a, b in zip(here, there, strict=True))


def test_a_bundled_logs_records_are_the_readers_and_the_child_tells_its_memory():
    path = BUNDLED["mit-csail"][0]
    records = LaserRecordsInProcess(path)
    assert records.memory is None
    here, there = list(laser_records(path)), list(records)
    assert len(here) > 1000 and all(same_record(a, b) for a, b in zip(here, there, strict=True))
    memory = records.memory
    assert 10 < memory.peak_rss_mb < 120  # numpy and the reader (not the parent's memory at the start)
    assert memory.own_rss_mb_then > 10
    assert memory.together(1.0) == memory.own_rss_mb_then + memory.peak_rss_mb
    assert memory.together(1e6) == 1e6


def test_a_malformed_line_is_raised_after_every_record_before_it(tmp_path):
    good = "".join(flaser([1.0, float(i)], stamp=f"{i}.5") for i in range(600))
    path = write_log(tmp_path / "bad.clf", good + "FLASER 3 1.0 2.0\n" + good)
    got = []
    with pytest.raises(LogFormatError) as info:
        got.extend(LaserRecordsInProcess(path))
    assert not isinstance(info.value, TruncatedLogError)
    assert [r.stamp.ipc_text for r in got] == [f"{i}.5" for i in range(600)]
    assert info.value.path == str(path) and info.value.line_number == 601
    assert str(info.value).startswith(f"{path}:601: ")


def test_a_cut_stream_is_raised_as_truncated_after_what_it_held(tmp_path):
    # two bz2 streams back to back, the second cut short: the first one's records all arrive
    first = "".join(flaser([1.0, 2.0], stamp=f"{i}.25") for i in range(300))
    second = "".join(flaser([3.0, 4.0], stamp=f"{i}.75") for i in range(300, 400))
    path = tmp_path / "cut.bz2"
    path.write_bytes(bz2.compress(first.encode()) + bz2.compress(second.encode())[:-30])
    got = []
    with pytest.raises(TruncatedLogError, match=r"cut\.bz2"):
        got.extend(LaserRecordsInProcess(path))
    assert [r.stamp.ipc_text for r in got[:300]] == [f"{i}.25" for i in range(300)]
    assert [r.stamp.ipc_text for r in got[300:]] == [f"{i}.75" for i in range(300, len(got))]


def test_a_missing_file_is_the_readers_error(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"nope\.clf"):
        list(LaserRecordsInProcess(tmp_path / "nope.clf"))


def test_progress_rises_to_one(tmp_path):
    path = write_log(tmp_path / "a.bz2", "".join(flaser([1.0, 2.0], stamp=f"{i}.5") for i in range(20_000)))
    seen = []
    list(LaserRecordsInProcess(path, progress=seen.append))
    assert len(seen) > 10 and seen[-1] == 1.0 and seen == sorted(seen) and 0.0 <= seen[0] < 0.5


def test_the_child_is_stopped_when_the_iteration_is_abandoned(tmp_path):
    lines = "".join(flaser([1.0, 2.0], stamp=f"{i}.5") for i in range(300_000))
    path = write_log(tmp_path / "long.clf", lines)
    records = iter(LaserRecordsInProcess(path))
    next(records)
    assert len(readers_of(path)) == 1  # parsing 300,000 lines takes it seconds
    records.close()
    assert readers_of(path) == []


def test_the_child_ends_once_it_has_parsed_the_log_however_slowly_the_records_are_taken(tmp_path):
    lines = "".join(flaser([1.0, float(i)], stamp=f"{i}.5") for i in range(20_000))
    path = write_log(tmp_path / "a.clf", lines)
    reading = LaserRecordsInProcess(path)
    records = iter(reading)
    first = next(records)
    deadline = time.monotonic() + 30.0
    while readers_of(path) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert readers_of(path) == [] and reading.memory is not None  # gone, with one record taken
    rest = list(records)
    assert [r.stamp.ipc_text for r in [first, *rest]] == [f"{i}.5" for i in range(20_000)]


def test_a_child_that_dies_is_an_error_not_an_early_end(tmp_path, monkeypatch):
    path = write_log(tmp_path / "a.clf", flaser([1.0, 2.0]))
    monkeypatch.setattr(sys, "executable", "/bin/false")  # exits at once, sending nothing
    with pytest.raises(RuntimeError, match="ended without finishing"):
        list(LaserRecordsInProcess(path))
