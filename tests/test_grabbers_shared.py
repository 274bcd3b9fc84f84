"""Latest and Backlog: the thread-safe holders shared by grabbers and workers."""

from __future__ import annotations

import threading

from app.grabbers.shared import Backlog, Latest


def test_empty_then_put_then_get():
    box: Latest[str] = Latest()
    assert box.get() == (0, None)
    assert box.put("a") == 1
    assert box.put("b") == 2
    assert box.get() == (2, "b")


def test_wait_newer_times_out_without_a_new_value():
    box: Latest[int] = Latest()
    box.put(1)
    assert box.wait_newer(1, timeout=0.01) is None
    assert box.wait_newer(0, timeout=0.01) == (1, 1)


def test_wait_newer_wakes_on_put_from_another_thread():
    box: Latest[int] = Latest()
    got = []
    reader = threading.Thread(target=lambda: got.append(box.wait_newer(0, timeout=5.0)))
    reader.start()
    box.put(42)
    reader.join(5.0)
    assert got == [(1, 42)]


def test_concurrent_writers_never_lose_a_sequence_number():
    box: Latest[int] = Latest()
    writers = [threading.Thread(target=lambda: [box.put(i) for i in range(500)]) for _ in range(4)]
    for w in writers:
        w.start()
    for w in writers:
        w.join()
    assert box.get()[0] == 2000


def test_a_backlog_gives_what_a_reader_missed_in_order_up_to_its_size():
    box: Backlog[str] = Backlog(3)
    assert box.get() == (0, None) and box.wait_after(0, timeout=0.01) == []
    for value in "abcde":
        box.put(value)
    assert box.get() == (5, "e")
    assert box.wait_after(0, timeout=0.01) == [(3, "c"), (4, "d"), (5, "e")]  # the oldest two fell out
    assert box.wait_after(4, timeout=0.01) == [(5, "e")]
    assert box.wait_after(5, timeout=0.01) == []


def test_a_backlog_reader_waiting_in_another_thread_gets_every_value_of_a_burst():
    box: Backlog[int] = Backlog(64)
    got: list[int] = []

    def read() -> None:
        last = 0
        while len(got) < 50:
            held = box.wait_after(last, timeout=5.0)
            got.extend(value for _, value in held)
            last = held[-1][0] if held else last

    reader = threading.Thread(target=read)
    reader.start()
    for i in range(50):
        box.put(i)
    reader.join(5.0)
    assert got == list(range(50))
