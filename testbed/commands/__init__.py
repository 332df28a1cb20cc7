"""The `testbed` commands: one module per command, listed in COMMANDS.

A command module defines
  NAME                      the word on the command line ("run-all")
  HELP                      one line for `testbed --help`
  add_arguments(parser)     its options (an argparse sub-parser)
  run(args) -> int          does the work; the exit status (0 = success)
and raises TestbedError (bad input: exit 2) or SimulationError (exit 1); testbed/cli.py
turns those into one line on stderr. Adding a command = one new module here and its
name in COMMANDS. Modules are imported only to build the parser; their heavy imports
(pydrake, torch, matplotlib) stay inside `run`.
"""

from __future__ import annotations

import datetime
import importlib

COMMANDS = ("scenes", "run", "run_all", "view", "validate", "study", "train", "compare", "campaign", "calibrate",
            "bench", "export_onnx")


def load(module_name: str):
    """The command module testbed.commands.<module_name>."""
    return importlib.import_module(f"{__name__}.{module_name}")


def timestamp() -> str:
    """Local time as used in default output directories: YYYYmmdd-HHMMSS."""
    return datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
