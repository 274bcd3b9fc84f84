"""The Dockerfile and docker-compose.yml carry what the issue asks for (no Docker engine here, so
their pieces are checked as text; the steps they run are the README's, tested elsewhere)."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]


def dockerfile_instructions() -> list[tuple[str, str]]:
    """(INSTRUCTION, arguments) pairs, with line continuations joined and comments dropped."""
    text = (REPO / "Dockerfile").read_text()
    logical = re.sub(r"\\\n", " ", text)
    out = []
    for line in logical.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            word, _, rest = line.partition(" ")
            out.append((word.upper(), rest.strip()))
    return out


def test_dockerfile_has_the_required_pieces():
    steps = dockerfile_instructions()
    kinds = [k for k, _ in steps]
    args = dict(steps)  # the last of each kind
    assert re.fullmatch(r"python:3\.11-slim(-\w+)?", steps[0][1]), "a slim Python 3.11 base"

    copies = [(i, a) for i, (k, a) in enumerate(steps) if k == "COPY"]
    first_install = next(i for i, (k, a) in enumerate(steps) if k == "RUN" and "pip install" in a)
    source_copy = next(i for i, a in copies if re.search(r"(^|\s)\.\s+\.$", a))
    assert any(i < first_install and "pyproject.toml" in a for i, a in copies), "pyproject copied first"
    assert first_install < source_copy, "dependencies are installed in a layer before the sources"
    assert re.search(r"pip install (-e )?\.", steps[first_install][1]), "the README's pip install"

    users = [a for k, a in steps if k == "USER"]
    assert users and users[-1] not in {"root", "0"}, "runs as a non-root user"
    assert any(k == "RUN" and "useradd" in a for k, a in steps)

    warm = [a for k, a in steps if k == "RUN" and "warm_numba_cache" in a]
    assert warm and kinds.index("USER") < next(i for i, (k, a) in enumerate(steps) if a == warm[0])
    assert (REPO / "docker" / "warm_numba_cache.py").is_file()
    assert "NUMBA_CACHE_DIR" in args["ENV"]

    assert "docker/healthcheck.py" in args["HEALTHCHECK"]
    assert "/api/health" in (REPO / "docker" / "healthcheck.py").read_text()
    assert "/data" in args["VOLUME"] and "HOMEBOT_DATA_DIR=/data" in args["ENV"]
    cmd = yaml.safe_load(args["CMD"])  # the exec form is a JSON (so YAML) list
    assert cmd[:2] == ["homebot", "serve"] and cmd[cmd.index("--host") + 1] == "0.0.0.0"


def test_compose_runs_the_simulation_on_port_8000_with_a_named_volume():
    compose = yaml.safe_load((REPO / "docker-compose.yml").read_text())
    service = compose["services"]["homebot"]
    assert service["build"] == "."
    assert service["ports"] == ["127.0.0.1:8000:8000"], "published on the loopback only"
    assert "TLS reverse proxy" in (REPO / "docker-compose.yml").read_text(), "how to reach it from elsewhere"
    command = service["command"] if isinstance(service["command"], list) else shlex.split(service["command"])
    assert command[:2] == ["homebot", "serve"] and "--real" not in command
    assert command[command.index("--port") + 1] == "8000"
    assert str(service["environment"]["HOMEBOT_SIMULATION"]).lower() == "true"
    volume, _, target = service["volumes"][0].partition(":")
    assert target == "/data" and volume in compose["volumes"], "a named volume holds /data"


def test_readme_shows_docker_compose_up():
    assert "docker compose up" in (REPO / "README.md").read_text()
