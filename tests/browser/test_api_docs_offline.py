"""``/docs`` (the dashboard's "API" link) renders in a browser that can reach nothing but homebot:
Swagger UI's assets are served by homebot itself, and every operation appears."""

from __future__ import annotations

from urllib.parse import urlsplit


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
