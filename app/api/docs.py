"""``/docs`` (Swagger UI) and ``/redoc`` served with assets that ship in the ``fastapi-offline``
package: the pages work without the internet. Both, like ``/openapi.json``, are open (no token):
they describe the API, and every route they describe still needs the token."""

from __future__ import annotations

from importlib.resources import files

from fastapi import FastAPI
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles

#: Where the Swagger UI and ReDoc bundles are served (paths relative to the pages, for reverse proxies).
ASSETS = "docs-assets"


def install(app: FastAPI) -> None:
    """Mount the assets and add the two pages (create the app with ``docs_url=redoc_url=None``)."""
    app.mount(f"/{ASSETS}", StaticFiles(directory=str(files("fastapi_offline") / "static")), name=ASSETS)

    @app.get("/docs", include_in_schema=False)
    def read_docs() -> HTMLResponse:
        return get_swagger_ui_html(openapi_url="openapi.json", title=f"{app.title} API",
                                   swagger_js_url=f"{ASSETS}/swagger-ui-bundle.js",
                                   swagger_css_url=f"{ASSETS}/swagger-ui.css",
                                   swagger_favicon_url=f"{ASSETS}/favicon.png", oauth2_redirect_url=None)

    @app.get("/redoc", include_in_schema=False)
    def read_redoc() -> HTMLResponse:
        return get_redoc_html(openapi_url="openapi.json", title=f"{app.title} API",
                              redoc_js_url=f"{ASSETS}/redoc.standalone.js",
                              redoc_favicon_url=f"{ASSETS}/favicon.png", with_google_fonts=False)
