"""``homebot serve``: the web server with the robot pipeline (simulated robot by default)."""

from __future__ import annotations

import argparse
import difflib
import json
import os
from pathlib import Path

from app.core.config import ENV_PREFIX, WORLDS


def register(sub) -> None:
    p = sub.add_parser("serve", help="run the web server (simulated robot unless --real or --replay)",
                       description="Serve the dashboard, REST API and live stream. On first start a token is "
                                   "generated, stored in the data dir and printed once with the URL.")
    p.add_argument("--host", default=None, help="address to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=None, help="TCP port (default 8000)")
    p.add_argument("--data", type=Path, default=None, help="data dir: token, database, maps (default ./data)")
    p.add_argument("--world", choices=WORLDS, default=None, help="simulated world (default flat)")
    p.add_argument("--real", action="store_true",
                   help="drive a real robot: HOMEBOT_SERIAL_PORT and HOMEBOT_SENSOR_SOURCE")
    p.add_argument("--replay", metavar="LOG",
                   help="play a CARMEN log (.clf, .gz, .bz2, or a bundled name: intel, mit-csail) through "
                        "the live path instead of a robot; writes DATA/replay/<log>/ like `homebot slam`")
    p.add_argument("--speed", type=_speed, default=None, metavar="X|max",
                   help="replay speed-up over the log's timing (default 1); max: as fast as SLAM steps")
    p.add_argument("--exit-at-end", action="store_true",
                   help="stop the server (exit 0) once the replay's final optimisation is written")
    p.add_argument("--robot", type=Path, default=None, metavar="FILE",
                   help="the robot's description (YAML, see README; HOMEBOT_ROBOT); default: the "
                        "simulated robot")
    p.add_argument("--config", type=Path, default=None,
                   help="SLAM settings: a config.json as `homebot slam --config` takes")
    p.add_argument("--resume", metavar="SESSION", default=None,
                   help="continue the mapping session saved as SESSION (DATA/sessions/SESSION.session.npz, "
                        "see POST api/sessions): the robot is found in its map, then mapping goes on")
    p.set_defaults(run=run)


def _speed(text: str) -> float | str:
    """``max`` or a positive number."""
    if text == "max":
        return text
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"speed must be a positive number or 'max', got {text!r}")
    return value


def _replay_overrides(args: argparse.Namespace) -> dict:
    """Settings of a replay; the log is read through once here (not kept) so that a broken one is
    refused before serving."""
    from app.replay.log_feed import check_laser_log
    from slam_core.datasets import resolve_log

    if args.replay is None:
        if args.speed is not None or args.exit_at_end:
            raise ValueError("--speed and --exit-at-end go with --replay LOG")
        return {}
    check_laser_log(resolve_log(args.replay))
    speed = {None: 1.0, "max": None}.get(args.speed, args.speed)
    return {"replay": args.replay, "replay_speed": speed, "replay_exit_at_end": args.exit_at_end}


def write_effective_config(settings) -> list[Path]:
    """Write the robot (``robot.yaml``, as ``--robot`` reads it) and SLAM settings (``config.json``,
    as ``--config`` and ``homebot slam --config`` read it) this server runs with into the data dir
    and, for a replay, beside its outputs; returns the files written."""
    from app.replay.log_feed import replay_name
    from app.worker.estimators import effective_robot

    folders = [settings.data_dir]
    if settings.replay:
        folders.append(settings.replay_dir / replay_name(settings.replay))
    robot = effective_robot(settings).to_yaml()
    slam = json.dumps(settings.slam().to_dict(), indent=2) + "\n"
    written = []
    for folder in folders:
        folder.mkdir(parents=True, exist_ok=True)
        for name, text in (("robot.yaml", robot), ("config.json", slam)):
            (folder / name).write_text(text)
            written.append(folder / name)
    return written


def _refuse_unknown_variables(fields) -> None:
    """A ``HOMEBOT_*`` variable that names no setting (a typo, or a SLAM setting, which lives in the
    ``--config`` file) is refused rather than silently ignored."""
    unknown = sorted(name for name in os.environ
                     if name.startswith(ENV_PREFIX) and name[len(ENV_PREFIX):].lower() not in fields)
    if unknown:
        known = [ENV_PREFIX + f.upper() for f in fields]
        close = difflib.get_close_matches(unknown[0], known, n=1)
        hint = f"did you mean {close[0]}? " if close else ""
        raise ValueError(f"unknown setting {unknown[0]}: {hint}the SLAM settings (particles, resolution, "
                         "update thresholds) go in the --config file (HOMEBOT_SLAM_CONFIG); the "
                         "HOMEBOT_* variables are the fields of app/core/config.py")


def run(args: argparse.Namespace) -> int:
    import uvicorn
    from pydantic import ValidationError

    from app.api.errors import validation_detail
    from app.cli.announce import announce_when_serving
    from app.core.config import Settings
    from app.core.security import load_or_create_token
    from app.main import create_app
    from slam_core.session import load_session

    _refuse_unknown_variables(Settings.model_fields)
    overrides = {k: v for k, v in (("host", args.host), ("port", args.port), ("data_dir", args.data),
                                   ("world", args.world), ("robot", args.robot),
                                   ("slam_config", args.config), ("resume_session", args.resume))
                 if v is not None}
    if args.real:
        overrides["simulation"] = False
    overrides.update(_replay_overrides(args))
    try:
        settings = Settings(**overrides)
    except ValidationError as exc:
        raise ValueError(f"bad setting (an option or HOMEBOT_* variable): {validation_detail(exc)}") from None
    if not settings.simulation and not settings.replay and not settings.sensor_source:
        raise ValueError("a real robot needs HOMEBOT_SENSOR_SOURCE=module:callable giving scans")
    settings.robot_config()  # a bad robot file is refused here, naming the file and the key
    settings.slam()  # a bad SLAM settings file is refused here, naming the file and the key
    if settings.resume_session is not None:
        if settings.replay:
            raise ValueError("--resume continues a robot's mapping session; a replay starts afresh")
        load_session(settings.session_file(settings.resume_session))  # a bad one is refused here, by name
    write_effective_config(settings)
    token, created = load_or_create_token(settings.data_dir, settings.token)
    url = f"http://{settings.host}:{settings.port}/"
    if created:
        lines = [f"homebot: first start; open {url}?token={token}",
                 f"homebot: token stored in {settings.data_dir / 'token'} (shown only this once)"]
    else:
        lines = [f"homebot: serving {url} (token in {settings.data_dir / 'token'})"]
    print("homebot: starting ...", flush=True)
    announce_when_serving(settings.host, settings.port, lines)  # once the page answers
    app = create_app(settings, stop_server=lambda: setattr(server, "should_exit", True))
    server = uvicorn.Server(server_config(app, settings))
    server.run()
    return 0


def server_config(app, settings):
    """uvicorn's settings: the proxy headers trusted from ``settings.forwarded_allow_ips`` only."""
    import uvicorn

    return uvicorn.Config(app, host=settings.host, port=settings.port, log_level="warning",
                          proxy_headers=True, forwarded_allow_ips=settings.forwarded_allow_ips,
                          ws_max_size=64 * 1024)
