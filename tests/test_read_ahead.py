"""A file's lines read ahead by a thread are the lines ``readline`` gives, errors included."""

from __future__ import annotations

import bz2
import gzip
import io

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.io import read_ahead
from slam_core.io.read_ahead import ReadAhead

OPENERS = {"plain": lambda raw: raw, "bz2": bz2.BZ2File, "gz": lambda raw: gzip.GzipFile(fileobj=raw)}
PACKERS = {"plain": lambda b: b, "bz2": bz2.compress, "gz": gzip.compress}


def by_readline(blob: bytes, kind: str):
    """The lines (and the error, if any) that iterating the stream line by line gives."""
    lines = []
    try:
        lines.extend(OPENERS[kind](io.BufferedReader(io.BytesIO(blob))))
    except (EOFError, OSError) as exc:
        return lines, type(exc)
    return lines, None


def by_read_ahead(blob: bytes, kind: str):
    raw = io.BufferedReader(io.BytesIO(blob))
    lines = []
    try:
        lines.extend(ReadAhead(OPENERS[kind](raw), raw))
    except (EOFError, OSError) as exc:
        return lines, type(exc)
    return lines, None


TEXT = st.lists(st.binary(max_size=40).map(lambda b: b.replace(b"\n", b"")), max_size=60)


@pytest.fixture
def small_chunks(monkeypatch):
    """Chunks of a few bytes, so that lines straddle them and the queue fills."""
    monkeypatch.setattr(read_ahead, "CHUNK", 7)
    monkeypatch.setattr(read_ahead, "CHUNKS_AHEAD", 2)


@pytest.mark.usefixtures("small_chunks")
@settings(max_examples=60, deadline=None)
@given(lines=TEXT, unterminated=st.binary(max_size=20).map(lambda b: b.replace(b"\n", b"")),
       kind=st.sampled_from(sorted(OPENERS)))
def test_the_lines_are_readlines(lines, unterminated, kind):
    blob = PACKERS[kind](b"".join(line + b"\n" for line in lines) + unterminated)
    assert by_read_ahead(blob, kind) == by_readline(blob, kind)


@pytest.mark.usefixtures("small_chunks")
@settings(max_examples=40, deadline=None)
@given(lines=st.lists(st.binary(min_size=5, max_size=60).map(lambda b: b.replace(b"\n", b"")), min_size=30,
                      max_size=200),
       cut=st.floats(0.05, 0.98), kind=st.sampled_from(["bz2", "gz"]))
def test_a_cut_stream_gives_every_line_before_its_error(lines, cut, kind):
    whole = PACKERS[kind](b"".join(line + b"\n" for line in lines))
    blob = whole[:int(len(whole) * cut)]
    got, error = by_read_ahead(blob, kind)
    assert (got, error) == by_readline(blob, kind)
    assert error is not None  # a cut stream is an error, not an early end


def test_an_abandoned_iteration_stops_its_thread(small_chunks):
    blob = gzip.compress(b"".join(b"%d\n" % i for i in range(100_000)))
    raw = io.BufferedReader(io.BytesIO(blob))
    lines = ReadAhead(gzip.GzipFile(fileobj=raw), raw)
    iterator = iter(lines)
    assert [next(iterator) for _ in range(3)] == [b"0\n", b"1\n", b"2\n"]
    iterator.close()
    assert not lines._thread.is_alive()
    assert 0 < lines.position < len(blob) / 2  # it had read only the start of the file
