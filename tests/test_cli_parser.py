"""The ``homebot`` parser imports only the subcommand named on the command line (all of them for help)."""

from __future__ import annotations

import json
import subprocess
import sys

from app.cli import COMMANDS

CHECK = ("import json, sys; from app.cli import COMMANDS, build_parser; "
         "build_parser(json.loads(sys.argv[1])); "
         "print(json.dumps(sorted(n for n in COMMANDS if f'app.cli.{n}' in sys.modules)))")


def imported_commands(argv: list[str]) -> list[str]:
    out = subprocess.run([sys.executable, "-c", CHECK, json.dumps(argv)], check=True, capture_output=True,
                         text=True)
    return json.loads(out.stdout)


def test_a_named_subcommand_imports_only_its_module_and_help_imports_every_one():
    assert imported_commands(["--debug", "slam", "intel", "--out", "x"]) == ["slam"]
    assert imported_commands(["--help"]) == sorted(COMMANDS)
    assert imported_commands(["no-such-command"]) == sorted(COMMANDS)
