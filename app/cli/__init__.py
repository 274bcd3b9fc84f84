"""The ``homebot`` command: one entry point, one module per subcommand."""

from __future__ import annotations

import argparse
import importlib
import sys
import zlib

#: Subcommand modules under ``app.cli``; each defines ``register(subparsers)``.
COMMANDS = ("map", "slam", "eval", "sim", "link", "localize", "ekf", "serve")


#: What a bad input file raises: reported in one line (exit 2), the traceback only with --debug.
INPUT_ERRORS = (OSError, EOFError, ValueError, zlib.error)


def build_parser(argv=None) -> argparse.ArgumentParser:
    """The parser of every subcommand, or only of the one ``argv`` names (the others' modules not
    imported: they bring in libraries that one command does not need, some 20 MB for ``slam``)."""
    parser = argparse.ArgumentParser(prog="homebot", description="homebot: a home robot's SLAM backend")
    parser.add_argument("--debug", action="store_true", help="show the full traceback of an error")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    named = [a for a in (sys.argv[1:] if argv is None else argv) if not a.startswith("-")][:1]
    for name in named if named and named[0] in COMMANDS else COMMANDS:
        importlib.import_module(f"app.cli.{name.replace('-', '_')}").register(sub)
    return parser


def describe(exc: BaseException) -> str:
    """One line for an error: an OS error as ``FILE: what``, anything else as its message."""
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror or exc}"
    return str(exc).replace("\n", " ") or type(exc).__name__


def main(argv=None) -> int:
    args = build_parser(argv).parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except KeyboardInterrupt:
        print(f"homebot {args.command}: interrupted", file=sys.stderr)
        return 130
    except INPUT_ERRORS as exc:
        if args.debug:
            raise
        print(f"homebot {args.command}: error: {describe(exc)}", file=sys.stderr)
        return 2
    except Exception as exc:
        if args.debug:
            raise
        print(f"homebot {args.command}: internal error: {type(exc).__name__}: {describe(exc)} "
              "(run with --debug for the traceback)", file=sys.stderr)
        return 1
