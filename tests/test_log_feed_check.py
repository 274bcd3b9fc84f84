"""``check_laser_log`` (what ``serve --replay`` reads through before serving) says what
``read_laser_records`` says of a log, without keeping its records."""

import bz2

import pytest

from app.replay.log_feed import check_laser_log, read_laser_records
from slam_core.datasets import resolve_log


def _cut_log(tmp_path, count: int):
    """The first ``count`` laser and odometry lines of mit-csail, bz2-compressed in 100 kB blocks and
    cut short (a block is decompressed whole, so the lines of the blocks before the cut are read)."""
    with bz2.open(resolve_log("mit-csail"), "rt") as log:
        lines = [line for line in log if line.startswith(("FLASER", "ODOM"))]
    blob = bz2.compress("".join(lines[:count]).encode(), compresslevel=1)
    cut = tmp_path / "cut.clf.bz2"
    cut.write_bytes(blob[: len(blob) * 9 // 10])
    return cut


def test_a_cut_log_warns_alike(tmp_path):
    log = _cut_log(tmp_path, 1000)
    records, warnings = read_laser_records(log)
    assert 0 < len(records) < 1000 and len(warnings) == 1 and "cut.clf.bz2" in warnings[0]
    assert check_laser_log(log) == warnings


def test_no_records_is_an_error_alike(tmp_path):
    log = tmp_path / "empty.clf"
    log.write_text("# a comment\nODOM 0 0 0 0 0 0 1.0 host 1.0\n")
    for read in (read_laser_records, check_laser_log):
        with pytest.raises(ValueError, match=r"empty\.clf: no laser records"):
            read(log)


def test_a_whole_log_has_no_warning():
    assert check_laser_log(resolve_log("mit-csail")) == []
