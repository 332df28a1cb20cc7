"""The `testbed` command line: the commands of testbed/commands/ (`testbed --help`
lists them; README.md shows each), and the exit statuses.

Errors in the user's input (scene files, overrides, options) print one line naming
the file and field and exit with status 2; a simulation that fails (solver
divergence) exits with status 1. Nothing is left half-written.
"""

from __future__ import annotations

import argparse
import sys

from testbed import commands
from testbed.errors import SimulationError, TestbedError


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="testbed", description="Container contact testbed (Drake).")
    sub = parser.add_subparsers(dest="command", required=True)
    for module_name in commands.COMMANDS:
        command = commands.load(module_name)
        p = sub.add_parser(command.NAME, help=command.HELP)
        command.add_arguments(p)
        p.set_defaults(func=command.run)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except SimulationError as e:
        print(f"testbed: simulation failed: {e}", file=sys.stderr)
        return 1
    except TestbedError as e:
        print(f"testbed: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("testbed: interrupted; no output was written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
