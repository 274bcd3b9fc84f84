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
import queue
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from slam_core.io.carmen import CarmenReader, LaserRecord

#: Laser records sent at a time.
BATCH = 256
#: Protocol 5 would keep each array as a view of a buffer of its own from the stream: intel's records
#: took 20 MB more, and 70 % more time to load, than with 4.
PROTOCOL = 4


@dataclass(frozen=True)
class RecordBatch:
    """Laser records in file order, and the share of the file read when the last was parsed."""

    records: list[LaserRecord]
    fraction: float


@dataclass(frozen=True)
class ReadFailed:
    """The reader's error, raised again in the filter's process (after the records sent before it),
    and the child's peak RSS (MB; ``None`` where the system does not tell)."""

    error: BaseException
    peak_rss_mb: float | None


@dataclass(frozen=True)
class ReadFinished:
    """Every record was sent; the child's peak RSS (MB; ``None`` where the system does not tell)."""

    peak_rss_mb: float | None


@dataclass(frozen=True)
class ReaderMemory:
    """The reader's peak RSS (MB), and the peak RSS of the process it read for until it finished."""

    peak_rss_mb: float
    own_rss_mb_then: float

    def together(self, own_peak_rss_mb: float) -> float:
        """An upper bound of both processes' RSS together at any moment, given the reading process's
        whole peak: while both ran, neither exceeded its peak until then."""
        return max(own_peak_rss_mb, self.own_rss_mb_then + self.peak_rss_mb)


class LaserRecordsInProcess:
    """:func:`slam_core.io.carmen.laser_records`, parsed by a child process: iterate over it once.
    ``progress`` is called with the share of the file read.

    A thread of this process loads the child's messages as they come, so that the child ends, and
    frees its memory, as soon as it has parsed the log (intel: in 2.5 s), however slowly the records
    are taken; they are all kept until then (a run that keeps its scans keeps most of that anyway).
    The child is stopped when the iteration ends or is abandoned. :attr:`memory` is what it took,
    once it has told (``None`` before, or where the system does not tell)."""

    def __init__(self, path, progress=None):
        self.path = path
        self.progress = progress
        self.memory: ReaderMemory | None = None

    def __iter__(self) -> Iterator[LaserRecord]:
        child = subprocess.Popen([sys.executable, "-m", __name__, os.fspath(self.path)],
                                 stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, env=_child_environment())
        arrived: queue.SimpleQueue = queue.SimpleQueue()
        loader = threading.Thread(target=self._load, args=(child, arrived), name="log-reader", daemon=True)
        loader.start()
        try:
            while True:
                message = arrived.get()
                if isinstance(message, RecordBatch):
                    yield from message.records
                    if self.progress is not None:
                        self.progress(message.fraction)
                    continue
                if isinstance(message, ReadFinished):
                    return
                raise message.error if isinstance(message, ReadFailed) else message
        finally:
            child.kill()
            loader.join()
            child.stdout.close()

    def _load(self, child: subprocess.Popen, arrived: queue.SimpleQueue) -> None:
        """Hand on the child's messages until its last (or an error in place of it), then reap it."""
        try:
            while True:
                message = pickle.load(child.stdout)
                if not isinstance(message, RecordBatch):
                    own = _peak_rss_mb()
                    if message.peak_rss_mb is not None and own is not None:
                        self.memory = ReaderMemory(message.peak_rss_mb, own)
                arrived.put(message)
                if not isinstance(message, RecordBatch):
                    return
        except EOFError:  # the child was stopped, or died without a word
            arrived.put(RuntimeError(f"{self.path}: the log reader's process ended without finishing "
                                     f"(exit code {child.wait()})"))
        except Exception as exc:  # the stream was closed under it (an abandoned iteration)
            arrived.put(exc)
        finally:
            child.wait()


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
                    pickle.dump(RecordBatch(batch, read[0]), out, PROTOCOL)
                    batch = []
    except Exception as exc:  # the parent raises it, after the records before it
        pickle.dump(RecordBatch(batch, read[0]), out, PROTOCOL)
        out.write(_failure(exc))
        return
    pickle.dump(RecordBatch(batch, 1.0), out, PROTOCOL)
    pickle.dump(ReadFinished(_peak_rss_mb()), out, PROTOCOL)


def _failure(exc: Exception) -> bytes:
    """``ReadFailed(exc)`` pickled, or with the error's text alone where the error will not pickle."""
    try:
        return pickle.dumps(ReadFailed(exc, _peak_rss_mb()), PROTOCOL)
    except Exception:
        error = RuntimeError(f"{type(exc).__name__}: {exc}")
        return pickle.dumps(ReadFailed(error, _peak_rss_mb()), PROTOCOL)


def _peak_rss_mb() -> float | None:
    """This process's peak RSS since it started its program (Linux's ``VmHWM``). Not ``getrusage``:
    Linux keeps there the parent's RSS that a new process shares before it starts a program."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1e3
    except OSError:
        pass
    return None


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
