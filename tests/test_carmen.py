"""The CARMEN log reader: message forms, angle conventions, errors, compressed and bundled logs."""

import bz2
import gzip

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from slam_core.io.carmen import (
    CarmenReader,
    LaserRecord,
    LogFormatError,
    ParamRecord,
    TruncatedLogError,
    flaser_angles,
    laser_records,
)
from tests.bundled import read_bundled


def write_log(path, text):
    data = text.encode("ascii")
    if path.suffix == ".bz2":
        path.write_bytes(bz2.compress(data))
    elif path.suffix == ".gz":
        path.write_bytes(gzip.compress(data))
    else:
        path.write_bytes(data)
    return path


def flaser(ranges, pose=(1.0, 2.0, 0.5), odom=(11.0, 12.0, -0.5), stamp="976052857.337530",
           logger="0.000246", kind="FLASER"):
    tail = f"{stamp} nohost" + (f" {logger}" if logger is not None else "")
    nums = " ".join(str(v) for v in (*ranges, *pose, *odom))
    return f"{kind} {len(ranges)} {nums} {tail}\n"


def robotlaser(ranges, remissions=(), start=-1.5, res=0.5, max_range=30.0, stamp="1134864629.895182"):
    head = f"ROBOTLASER1 0 {start} 3.14 {res} {max_range} 0.01 0"
    body = f"{len(ranges)} {' '.join(map(str, ranges))} {len(remissions)} {' '.join(map(str, remissions))}"
    poses = "1.5 2.5 0.25 1.4 2.4 0.2 0.3 0.1 0.5 0.5 0.0"
    return f"{head} {body} {poses} {stamp} b21 0.5\n".replace("  ", " ")


LOG = (
    "# CARMEN log with comments\n"
    "# message_name [message contents] ipc_timestamp ipc_hostname logger_timestamp\n"
    "PARAM robot_frontlaser_offset 0.0 nohost 0\n"
    "\n"
    "ODOM 0.5 -0.25 0.1 0.3 0.05 0.0 976052857.337284 nohost 0.000000\n"
    + flaser([1.0, 2.0, 81.83, 0.0])
    + "SYNC tag 100.0 nohost 0.1\n"
    + "TRUEPOS 1 2 3 4 5 6 100.0 nohost 0.1\n"
    + "NMEA-GGA 1 2 3 100.0 nohost 0.1\n"
    + flaser([3.0, 4.0], stamp="976052856.000001", logger=None, kind="RLASER")
    + "ODOM 0.6 -0.25 0.1 0.3 0.05 0.0 976052858.5 nohost\n"
    + robotlaser([1.0, 2.0, 30.0], remissions=[0.5, 0.6, 0.7])
    + robotlaser([5.0], remissions=())
)


@pytest.mark.parametrize("suffix", [".clf", ".bz2", ".gz"])
def test_all_message_forms(tmp_path, suffix):
    reader = CarmenReader(write_log(tmp_path / f"log{suffix}", LOG))
    records = list(reader)
    kinds = [r.kind if isinstance(r, LaserRecord) else type(r).__name__ for r in records]
    assert kinds == ["ParamRecord", "OdomRecord", "FLASER", "RLASER", "OdomRecord",
                     "ROBOTLASER1", "ROBOTLASER1"]
    assert reader.skipped == {"SYNC": 1, "TRUEPOS": 1, "NMEA-GGA": 1}

    param = records[0]
    assert (param.name, param.value, param.line) == ("robot_frontlaser_offset", "0.0", 3)

    odom = records[1]
    assert odom.pose.tolist() == [0.5, -0.25, 0.1] and (odom.tv, odom.rv) == (0.3, 0.05)
    assert odom.stamp.ipc_text == "976052857.337284" and odom.stamp.line == 5

    new = records[2]   # new form: with logger_timestamp
    assert new.scan.ranges.tolist() == [1.0, 2.0, 81.83, 0.0]
    assert new.pose.tolist() == [1.0, 2.0, 0.5] and new.odom.tolist() == [11.0, 12.0, -0.5]
    assert new.stamp.ipc_text == "976052857.337530" and new.stamp.ipc_time == 976052857.337530
    assert new.scan.timestamp == new.stamp.ipc_time
    assert new.scan.valid.tolist() == [True, True, False, False]    # 81.83: no return; 0: none

    old = records[3]   # old form: no logger_timestamp; its time steps backwards and is kept
    assert old.kind == "RLASER" and old.scan.ranges.tolist() == [3.0, 4.0]
    assert old.stamp.ipc_text == "976052856.000001" and old.stamp.line == 10
    assert old.stamp.ipc_time < new.stamp.ipc_time
    assert records[4].stamp.ipc_text == "976052858.5"    # old-form ODOM

    rl = records[5]
    assert rl.scan.ranges.tolist() == [1.0, 2.0, 30.0]
    assert np.allclose(rl.scan.angles, [-1.5, -1.0, -0.5])
    assert rl.scan.range_max == 30.0 and rl.scan.valid.tolist() == [True, True, False]
    assert rl.pose.tolist() == [1.5, 2.5, 0.25] and rl.odom.tolist() == [1.4, 2.4, 0.2]
    assert rl.stamp.ipc_text == "1134864629.895182"
    assert records[6].scan.ranges.tolist() == [5.0]


def test_scans_with_the_same_beams_share_one_bearings_array(tmp_path):
    """A log's scans are held to its end: those with the same beams (count, and for ROBOTLASER1 the
    start angle and step) refer to one bearings array, and the others have their own."""
    text = (flaser([1.0] * 4) + flaser([2.0] * 4) + flaser([1.0] * 5)
            + robotlaser([1.0, 2.0, 3.0]) + robotlaser([4.0, 5.0, 6.0])
            + robotlaser([1.0, 2.0, 3.0], res=0.25) + robotlaser([1.0, 2.0, 3.0], start=-1.0))
    scans = [r.scan for r in laser_records(write_log(tmp_path / "a.clf", text))]
    assert scans[0].angles is scans[1].angles and scans[3].angles is scans[4].angles
    others = [scans[k].angles for k in (0, 2, 3, 5, 6)]
    assert len({id(a) for a in others}) == 5
    assert np.allclose(scans[5].angles, [-1.5, -1.25, -1.0])
    assert np.allclose(scans[6].angles, [-1.0, -0.5, 0.0])


def test_laser_records_only_lasers(tmp_path):
    recs = list(laser_records(write_log(tmp_path / "log.gz", LOG)))
    assert [r.kind for r in recs] == ["FLASER", "RLASER", "ROBOTLASER1", "ROBOTLASER1"]


@pytest.mark.parametrize("n, first, last, step", [
    (180, -90.0, 89.0, 1.0), (361, -90.0, 90.0, 0.5), (181, -90.0, 90.0, 1.0), (360, -90.0, 89.5, 0.5),
])
def test_flaser_angle_convention(tmp_path, n, first, last, step):
    rec = next(laser_records(write_log(tmp_path / "a.clf", flaser([1.0] * n))))
    deg = np.degrees(rec.scan.angles)
    assert len(deg) == n
    assert deg[0] == pytest.approx(first) and deg[-1] == pytest.approx(last)
    assert np.allclose(np.diff(deg), step)
    assert np.array_equal(flaser_angles(n), rec.scan.angles)


def test_beam_zero_points_right_in_the_robot_frame(tmp_path):
    # 180 beams from -90 deg: beam 90 points straight ahead, beam 0 to the right (-y).
    rec = next(laser_records(write_log(tmp_path / "a.clf", flaser([1.0] * 180))))
    pts = rec.scan.points()
    assert np.allclose(pts[0], [0.0, -1.0], atol=1e-12)
    assert np.allclose(pts[90], [1.0, 0.0], atol=1e-12)


def test_timestamps_stepping_backwards_keep_file_order(tmp_path):
    stamps = ["100.5", "100.25", "99.0", "101.000001", "100.9"]
    text = "".join(flaser([1.0], stamp=s) for s in stamps)
    recs = list(laser_records(write_log(tmp_path / "a.clf", text)))
    assert [r.stamp.ipc_text for r in recs] == stamps
    assert [r.stamp.line for r in recs] == [1, 2, 3, 4, 5]


def test_ipc_timestamp_text_is_kept_exactly(tmp_path):
    stamps = ["976052857.337530", "1134864629.895182000", "7.10", "1e3"]
    text = "".join(flaser([1.0], stamp=s) for s in stamps)
    recs = list(laser_records(write_log(tmp_path / "a.clf", text)))
    assert [r.stamp.ipc_text for r in recs] == stamps
    assert [r.stamp.ipc_time for r in recs] == [float(s) for s in stamps]


GOOD = flaser([1.0, 2.0, 3.0])


@pytest.mark.parametrize("bad, problem", [
    ("FLASER 3 1.0 2.x 3.0 1 2 3 4 5 6 100.0 nohost 0.1\n", "2.x"),
    ("FLASER 4 1.0 2.0 3.0 1 2 3 4 5 6 100.0 nohost 0.1\n", "too few ranges"),
    ("FLASER 9 1.0 2.0 3.0 1 2 3 4 5 6 100.0 nohost 0.1\n", "has 3 (too few ranges)"),
    ("FLASER 2 1.0 2.0 3.0 1 2 3 4 5 6 100.0 nohost 0.1\n", "too many ranges"),
    ("FLASER 3 1.0 2.0 3.0 1 2 3 4 5 6\n", "missing timestamp"),
    ("FLASER 3 1.0 2.0 3.0 1 2 3 4 5 6 nohost 0.1\n", "missing timestamp"),
    ("FLASER x 1.0\n", "beam count"),
    ("ODOM 1 2 3 4 5 6\n", "ipc_timestamp"),
    ("ODOM 1 2 3 4 5 x 100.0 nohost 0.1\n", "'x'"),
    ("ODOM 1 2 3 4 5 6 abc nohost 0.1\n", "timestamp"),
    ("ODOM 1 2 3 4 5 6 nan nohost 0.1\n", "not finite"),
    ("ROBOTLASER1 0 -1.5 3.14 0.5 30 0.01 0 3 1 2 0 1 2 3 4 5 6 7 8 9 10 11 100.0 h 0\n", "ROBOTLASER1"),
    ("PARAM lonely\n", "PARAM"),
    ("FLASER 3 1.0 nan 3.0 1 nan 3 4 5 6 100.0 nohost 0.1\n", "poses: not finite (1 nan 3 4 5 6)"),
    ("ODOM 1 inf 3 4 5 6 100.0 nohost 0.1\n", "not finite"),
    ("flaser 3 1 2 3\n", "unknown message"),
    ("FLASER 3 1.0 2.0 3.0 1 2 3 4 5 6 100.0 nohost 0.1 junk\n", "ipc_timestamp"),
])
def test_malformed_line_names_file_line_and_problem(tmp_path, bad, problem):
    path = write_log(tmp_path / "bad.clf", GOOD + "# fine\n" + bad + GOOD)
    reader = iter(CarmenReader(path))
    assert isinstance(next(reader), LaserRecord)
    with pytest.raises(LogFormatError) as info:
        next(reader)
    err = info.value
    assert not isinstance(err, TruncatedLogError)
    assert err.line_number == 3 and err.path == str(path)
    assert str(err).startswith(f"{path}:3: ")
    assert problem in err.problem


def test_non_ascii_bytes_are_reported(tmp_path):
    path = tmp_path / "bin.clf"
    path.write_bytes(GOOD.encode() + b"FLASER \xff\xfe\n")
    with pytest.raises(LogFormatError, match=r"bin.clf:2: non-ASCII"):
        list(CarmenReader(path))


@pytest.mark.parametrize("suffix", [".clf", ".gz", ".bz2"])
def test_truncated_last_line_is_reported_after_every_earlier_record(tmp_path, suffix):
    lines = [flaser([float(i), 2.0], stamp=f"{100 + i}.5") for i in range(5)]
    text = "".join(lines) + lines[0][:40]           # cut in the middle of the ranges, no newline
    got = []
    with pytest.raises(TruncatedLogError) as info:
        got.extend(CarmenReader(write_log(tmp_path / f"cut{suffix}", text)))
    assert [r.stamp.ipc_text for r in got] == [f"{100 + i}.5" for i in range(5)]
    assert info.value.line_number == 6
    assert "cut short" in str(info.value) and f"cut{suffix}:6" in str(info.value)


def test_a_complete_last_line_without_newline_is_fine(tmp_path):
    recs = list(CarmenReader(write_log(tmp_path / "a.clf", GOOD + GOOD.rstrip("\n"))))
    assert len(recs) == 2


def test_truncated_bz2_stream(tmp_path):
    # Two bz2 streams back to back (as bzip2 -c a >> log would make); the second is cut short.
    first = "".join(flaser([1.0, 2.0], stamp=f"{i}.25") for i in range(50))
    second = "".join(flaser([3.0, 4.0], stamp=f"{i}.75") for i in range(50, 100))
    blob = bz2.compress(first.encode()) + bz2.compress(second.encode())[:-30]
    path = tmp_path / "cut.bz2"
    path.write_bytes(blob)
    got = []
    with pytest.raises(TruncatedLogError) as info:
        got.extend(CarmenReader(path))
    assert [r.stamp.ipc_text for r in got[:50]] == [f"{i}.25" for i in range(50)]
    assert all(r.stamp.ipc_text == f"{50 + k}.75" for k, r in enumerate(got[50:]))
    assert "ends early" in str(info.value) and "cut.bz2" in str(info.value)


def test_truncated_gz_stream_keeps_what_it_could_decode(tmp_path):
    text = "".join(flaser([1.0, 2.0], stamp=f"{i}.5") for i in range(400))
    full = gzip.compress(text.encode())
    path = tmp_path / "cut.gz"
    path.write_bytes(full[: len(full) * 2 // 3])
    got = []
    with pytest.raises(TruncatedLogError):
        got.extend(CarmenReader(path))
    assert 0 < len(got) < 400
    assert [r.stamp.ipc_text for r in got] == [f"{i}.5" for i in range(len(got))]


@pytest.mark.parametrize("suffix", [".bz2", ".gz"])
def test_uncompressed_data_under_a_compressed_name_is_not_called_truncated(tmp_path, suffix):
    path = tmp_path / f"plain{suffix}"
    path.write_text(GOOD)
    with pytest.raises(LogFormatError, match="cannot decompress") as info:
        list(CarmenReader(path))
    assert not isinstance(info.value, TruncatedLogError) and info.value.line_number == 1


def test_missing_file_raises_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError):
        list(CarmenReader(tmp_path / "nope.clf"))


def test_progress_reaches_one(tmp_path):
    seen = []
    list(CarmenReader(write_log(tmp_path / "a.bz2", GOOD * 5000), progress=seen.append))
    assert seen[-1] == 1.0 and all(0.0 <= f <= 1.0 for f in seen) and seen == sorted(seen)


number_text = st.floats(0.0, 81.91, allow_nan=False).map(lambda v: f"{v:.2f}")
pose_text = st.floats(-1e4, 1e4, allow_nan=False).map(lambda v: f"{v:.6f}")
stamp_text = st.tuples(st.integers(0, 2_000_000_000), st.integers(0, 999_999)).map(
    lambda t: f"{t[0]}.{t[1]:06d}")


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(number_text, min_size=1, max_size=400), st.lists(pose_text, min_size=6, max_size=6),
       stamp_text, st.booleans(), st.sampled_from(["FLASER", "RLASER"]))
def test_random_flaser_lines_round_trip(tmp_path, ranges, poses, stamp, new_form, kind):
    tail = f"{stamp} somehost" + (" 12.345678" if new_form else "")
    line = f"{kind} {len(ranges)} {' '.join(ranges)} {' '.join(poses)} {tail}\n"
    path = write_log(tmp_path / "r.clf", "# x\n" + line + line)
    recs = list(CarmenReader(path))
    assert len(recs) == 2
    rec = recs[1]
    assert rec.kind == kind and rec.stamp.line == 3
    assert rec.scan.ranges.tolist() == [float(v) for v in ranges]
    assert rec.pose.tolist() == [float(v) for v in poses[:3]]
    assert rec.odom.tolist() == [float(v) for v in poses[3:]]
    assert rec.stamp.ipc_text == stamp
    assert len(rec.scan.angles) == len(ranges)


# --- the bundled logs ------------------------------------------------------------------------

def test_bundled_intel_log():
    log = read_bundled("intel")
    assert (len(log.lasers), len(log.odometry)) == (13631, 26915)
    assert {len(r.scan) for r in log.lasers} == {180} and {r.kind for r in log.lasers} == {"FLASER"}
    assert all(isinstance(r, ParamRecord) for r in log.others) and not log.skipped
    times = np.array([r.stamp.ipc_time for r in log.lasers])
    assert (np.diff(times) < 0).sum() == 631     # stepping back in time, kept in file order
    lines = [r.stamp.line for r in log.lasers]
    assert lines == sorted(lines)


def test_bundled_mit_csail_log():
    log = read_bundled("mit-csail")
    assert (len(log.lasers), len(log.odometry)) == (1988, 0)
    assert {len(r.scan) for r in log.lasers} == {361}
    first = log.lasers[0]
    assert first.stamp.ipc_text == "1134864629.895182"
    assert first.odom.tolist() == [576.536523, 0.106594, -2.255213]
    assert first.scan.range_max == 80.0
    assert any((r.scan.ranges >= 81.9).any() for r in log.lasers[:50])
