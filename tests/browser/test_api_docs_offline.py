"""``/docs`` (the dashboard's "API" link) renders in a browser that can reach nothing but homebot:
Swagger UI's assets are served by homebot itself, and every operation appears."""

from __future__ import annotations

from urllib.parse import urlsplit

from app.db.names import NAME_REGEX
from tests.test_server_parts import BAD_NAMES, GOOD_NAMES


def test_swagger_ui_renders_with_the_internet_cut_off(page, homebot_server):
    outside: list[str] = []

    def only_homebot(route):
        if urlsplit(route.request.url).netloc == f"127.0.0.1:{homebot_server.port}":
            route.continue_()
        else:
            outside.append(route.request.url)
            route.abort()

    page.route("**/*", only_homebot)
    page.goto(homebot_server.url + "docs")
    page.wait_for_selector(".opblock", timeout=30_000)
    paths = set(page.locator(".opblock-summary-path").all_inner_texts())
    schema = homebot_server.api("GET", "../openapi.json").json()
    assert {p.replace("\u200b", "") for p in paths} == set(schema["paths"]), paths
    assert outside == [] and page.js_errors == [], (outside, page.js_errors)


def test_the_published_name_pattern_means_in_a_browser_what_it_means_to_the_server(page, homebot_server):
    """JSON Schema patterns are ECMAScript's: Swagger UI checks "Try it out" input with ``RegExp``.
    The names the server takes and refuses are taken and refused there too."""
    schema = homebot_server.api("GET", "../openapi.json").json()
    patterns = {p["pattern"] for p in _properties(schema)
                if "pattern" in p and "1-64" in p.get("description", "")}
    assert patterns == {NAME_REGEX}, patterns
    page.goto(homebot_server.url + "docs")
    verdicts = page.evaluate("([pattern, names]) => names.map((n) => new RegExp(pattern).test(n))",
                             [NAME_REGEX, GOOD_NAMES + BAD_NAMES])
    assert verdicts == [True] * len(GOOD_NAMES) + [False] * len(BAD_NAMES), verdicts


def _properties(node):
    """Every schema object below ``node`` (the OpenAPI document)."""
    if isinstance(node, dict):
        yield node
        for value in node.values():
            yield from _properties(value)
    elif isinstance(node, list):
        for value in node:
            yield from _properties(value)
