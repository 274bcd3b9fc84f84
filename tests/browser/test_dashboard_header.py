"""The header in Debian's chromium (the page's own modules, no server): one line however long the
failure, the failure's reason shown once, and a sign that the scripted tour is running."""

from __future__ import annotations

import pytest

LONG_REASON = ("goal_unreachable: goal (7.50, 2.25) is blocked: no passable route from the start "
               "(1.00, 3.75) reaches it, and the map around it is still being built")


@pytest.fixture
def dashboard(page, static_url):
    # The lists the dashboard fetches at its start never answer: one failing at any moment would
    # put its own error in the error pill these tests read.
    page.route("**/api/{places,maps,sessions,rooms,zones}*", lambda route: None)
    page.goto(static_url)
    page.wait_for_selector("#offline-banner", state="visible", timeout=10_000)
    page.evaluate("""() => {
        document.getElementById('login').hidden = true;
        document.getElementById('app').hidden = false;
    }""")
    return page


def _show(page, nav: dict) -> None:
    page.evaluate("""(nav) => {
        const hb = window.homebot;
        hb.state.handle({ type: 'status', mode: 'mapping', mapping: true, localized: true, nav,
                          worker: { alive: true, rate_hz: 9.5, steps: 10, restarts: 0 } });
        hb.state.handle({ type: 'path', goal: null, path: [], state: nav.state, reason: nav.reason });
        hb.stateChanged('path');
        hb.statusBar.render();
    }""", nav)


@pytest.mark.parametrize("width", [1280, 390])
def test_a_long_failure_is_shown_once_and_the_header_stays_on_one_line(dashboard, width):
    page = dashboard
    page.set_viewport_size({"width": width, "height": 800})
    _show(page, {"state": "idle", "reason": None, "touring": False})
    one_line = page.evaluate("document.querySelector('.topbar').getBoundingClientRect().height")
    _show(page, {"state": "failed", "reason": LONG_REASON, "touring": False})
    header = page.evaluate("document.querySelector('.topbar').getBoundingClientRect().height")
    assert header == pytest.approx(one_line, abs=1)
    texts = page.locator("#statusbar").inner_text()
    assert texts.count("goal_unreachable") == 1  # in the error pill, not again in the navigation pill
    assert page.locator("#st-nav").inner_text() == "failed"
    assert LONG_REASON in page.locator("#st-error").get_attribute("title")
    assert page.js_errors == []


def test_the_scripted_tour_shows_in_the_navigation_pill(dashboard):
    page = dashboard
    _show(page, {"state": "driving", "reason": None, "touring": True})
    assert page.locator("#st-nav").inner_text() == "tour: driving"
    assert "tour is running" in page.locator("#st-nav").get_attribute("title")
    _show(page, {"state": "driving", "reason": None, "touring": False})
    assert page.locator("#st-nav").inner_text() == "driving"
