"""The ``homebot`` command: one entry point, one module per subcommand."""

from __future__ import annotations

import argparse
import importlib
import sys

#: Subcommand modules under ``app.cli``; each defines ``register(subparsers)``.
COMMANDS = ("map", "eval", "sim", "link", "localize", "serve")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="homebot", description="homebot: a home robot's SLAM backend")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"app.cli.{name.replace('-', '_')}").register(sub)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except (FileNotFoundError, ValueError) as exc:
        print(f"homebot {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"homebot {args.command}: interrupted", file=sys.stderr)
        return 130
