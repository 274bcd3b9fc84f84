"""``homebot serve``: the web server with the robot pipeline (simulated robot by default)."""

from __future__ import annotations

import argparse
from pathlib import Path

from app.core.config import WORLDS


def register(sub) -> None:
    p = sub.add_parser("serve", help="run the web server (simulated robot unless --real)",
                       description="Serve the dashboard, REST API and live stream. On first start a token is "
                                   "generated, stored in the data dir and printed once with the URL.")
    p.add_argument("--host", default=None, help="address to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=None, help="TCP port (default 8000)")
    p.add_argument("--data", type=Path, default=None, help="data dir: token, database, maps (default ./data)")
    p.add_argument("--world", choices=WORLDS, default=None, help="simulated world (default flat)")
    p.add_argument("--real", action="store_true",
                   help="drive a real robot: HOMEBOT_SERIAL_PORT and HOMEBOT_SENSOR_SOURCE")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import uvicorn

    from app.cli.announce import announce_when_serving
    from app.core.config import Settings
    from app.core.security import load_or_create_token
    from app.main import create_app

    overrides = {k: v for k, v in (("host", args.host), ("port", args.port), ("data_dir", args.data),
                                   ("world", args.world)) if v is not None}
    if args.real:
        overrides["simulation"] = False
    settings = Settings(**overrides)
    if not settings.simulation and not settings.sensor_source:
        raise ValueError("a real robot needs HOMEBOT_SENSOR_SOURCE=module:callable giving scans")
    token, created = load_or_create_token(settings.data_dir, settings.token)
    url = f"http://{settings.host}:{settings.port}/"
    if created:
        lines = [f"homebot: first start; open {url}?token={token}",
                 f"homebot: token stored in {settings.data_dir / 'token'} (shown only this once)"]
    else:
        lines = [f"homebot: serving {url} (token in {settings.data_dir / 'token'})"]
    print("homebot: starting ...", flush=True)
    announce_when_serving(settings.host, settings.port, lines)  # once the page answers
    uvicorn.run(create_app(settings), host=settings.host, port=settings.port, log_level="warning",
                proxy_headers=True, forwarded_allow_ips="127.0.0.1", ws_max_size=64 * 1024)
    return 0
