"""The rate the dashboard's Hz pill shows is steady when steps come in uneven bursts."""

import pytest

from app.core.rate import SlidingRate


def test_bursty_steps_give_a_steady_rate():
    """Steps alternately 18 ms and 140 ms apart (55 and 7 Hz at a glance): about 12.6 Hz, every time."""
    rate, now, shown = SlidingRate(), 0.0, []
    for k in range(200):
        now += 0.018 if k % 2 else 0.14
        rate.tick(now)
        if now > rate.window_s:
            shown.append(rate.rate(now))
    steady = pytest.approx(2 / 0.158, rel=0.05)
    assert min(shown) == steady and max(shown) == steady


def test_no_steps_for_a_window_is_zero():
    rate = SlidingRate(window_s=3.0)
    for t in (0.0, 0.1, 0.2):
        rate.tick(t)
    assert rate.rate(0.3) == pytest.approx(10.0)
    assert rate.rate(3.5) == 0.0
