"""A log's laser records, read and parsed by a process of its own.

Parsing a CARMEN line is Python and holds the GIL: read in the filter's process, intel's lines
take about 2.5 s of the filter's thread while the second core idles. Here a child process
(``python -m slam_core.io.log_process LOG``, which imports numpy and the reader only) reads the
log with :class:`~slam_core.io.carmen.CarmenReader` and sends its laser records over a pipe in
batches; the filter's process only unpickles them. The records, their order and the errors are the
reader's own: a :class:`~slam_core.io.carmen.LogFormatError` (or ``TruncatedLogError``, or the
``OSError`` of a file that cannot be read) is raised after every record before it.
"""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from slam_core.io.carmen import CarmenReader, LaserRecord

#: Laser records sent at a time.
BATCH = 256


@dataclass(frozen=True)
class RecordBatch:
    """Laser records in file order, and the share of the file read when the last was parsed."""

    records: list[LaserRecord]
    fraction: float


@dataclass(frozen=True)
class ReadFailed:
    """The reader's error, raised again in the filter's process (after the records sent before it)."""

    error: BaseException


@dataclass(frozen=True)
class ReadFinished:
    """Every record was sent."""


def laser_records_in_process(path, progress=None) -> Iterator[LaserRecord]:
    """:func:`slam_core.io.carmen.laser_records`, parsed by a child process; ``progress`` is called
    with the share of the file read. The child is stopped when the iteration ends or is abandoned."""
    child = subprocess.Popen([sys.executable, "-m", __name__, os.fspath(path)], stdin=subprocess.DEVNULL,
                             stdout=subprocess.PIPE, env=_child_environment())
    try:
        while True:
            try:
                message = pickle.load(child.stdout)
            except EOFError:
                raise RuntimeError(f"{path}: the log reader's process ended without finishing "
                                   f"(exit code {child.wait()})") from None
            if isinstance(message, RecordBatch):
                yield from message.records
                if progress is not None:
                    progress(message.fraction)
            elif isinstance(message, ReadFailed):
                raise message.error
            else:
                return
    finally:
        child.kill()
        child.wait()
        child.stdout.close()


def _child_environment() -> dict[str, str]:
    """The environment with this ``slam_core``'s folder first on the path, so that the child runs
    the same code (a source tree not installed, or one of several)."""
    root = str(Path(__file__).resolve().parents[2])
    path = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": root if not path else os.pathsep.join([root, path])}


def _send_records(path: str, out) -> None:
    """The child's side: every laser record of ``path`` in batches, then how the reading ended."""
    read = [0.0]
    batch: list[LaserRecord] = []
    reader = CarmenReader(path, progress=lambda fraction: read.__setitem__(0, fraction))
    try:
        for record in reader:
            if isinstance(record, LaserRecord):
                batch.append(record)
                if len(batch) == BATCH:
                    pickle.dump(RecordBatch(batch, read[0]), out, pickle.HIGHEST_PROTOCOL)
                    batch = []
    except Exception as exc:  # the parent raises it, after the records before it
        pickle.dump(RecordBatch(batch, read[0]), out, pickle.HIGHEST_PROTOCOL)
        out.write(_failure(exc))
        return
    pickle.dump(RecordBatch(batch, 1.0), out, pickle.HIGHEST_PROTOCOL)
    pickle.dump(ReadFinished(), out, pickle.HIGHEST_PROTOCOL)


def _failure(exc: Exception) -> bytes:
    """``ReadFailed(exc)`` pickled, or with the error's text alone where the error will not pickle."""
    try:
        return pickle.dumps(ReadFailed(exc), pickle.HIGHEST_PROTOCOL)
    except Exception:
        return pickle.dumps(ReadFailed(RuntimeError(f"{type(exc).__name__}: {exc}")), pickle.HIGHEST_PROTOCOL)


def main() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle; it stops this
    out = sys.stdout.buffer
    try:
        _send_records(sys.argv[1], out)
        out.flush()
    except BrokenPipeError:  # the parent stopped reading
        pass
    os._exit(0)  # no flush at exit into a pipe that may be closed


if __name__ == "__main__":
    from slam_core.io.log_process import main as imported_main  # so that what it sends pickles under

    imported_main()  # this module's name, not ``__main__``
