"""The container's health check: exit 0 when ``api/health`` answers ``ok``, 1 when it is degraded or
unreachable (the reasons are printed, so ``docker inspect`` shows them). Standard library only.

Usage: ``python docker/healthcheck.py [PORT]`` (default ``$HOMEBOT_PORT``, else 8000).
"""

from __future__ import annotations

import json
import os
import sys
import urllib.error
import urllib.request

TIMEOUT_S = 4


def main(argv: list[str]) -> int:
    port = argv[1] if len(argv) > 1 else os.environ.get("HOMEBOT_PORT", "8000")
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=TIMEOUT_S) as response:
            health = json.load(response)
    except (OSError, urllib.error.URLError, ValueError) as exc:
        print(f"unhealthy: no answer from api/health ({exc})")
        return 1
    if health.get("status") != "ok":
        print(f"unhealthy: {health.get('status')}: {'; '.join(health.get('reasons', []))}")
        return 1
    print("ok")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
