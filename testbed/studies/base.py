"""The Study base class: one study of `testbed study NAME`, a plug-in of testbed.studies.

A study is one package testbed/studies/<name>/ whose `__init__` registers a Study subclass
with testbed.studies.register. The package's `__init__` stays light (the CLI's parser lists
every study and its options on every start): it declares the study's name, help, its config
dataclass and its options; the study's own code is imported when it runs.

The command (testbed/commands/study.py) calls, in order:

  add_arguments(group)   the study's own options, in an argparse group of its own (the options
                         every study shares, COMMON below, are the command's)
  configure(args)        the config dataclass from the parsed options; bad input raises a
                         TestbedError (one line naming the option and what it expects, exit
                         status 2) before anything runs or is written
  run(config, out, map_calls)
                         runs the study; makes the directory `out` once the config has been
                         checked in full; returns its result (JSON-able). map_calls: validate's
                         executor (testbed.validation.executors.map_calls, a layer above the
                         studies, handed in by the command) for a study whose parts may run
                         over processes or a Ray cluster; the others ignore it
  report(result, out)    writes the study's files into `out`; returns their paths
  summary(result)        the lines the command prints
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, ClassVar

from testbed.errors import TestbedError

# The options of the command itself, shared by every study (a study reads them from `args`):
# --out, --quick (a small, fast grid), --quiet (no progress bars), --workers (processes),
# --duration (seconds simulated; each study says what of).
COMMON = ("out", "quick", "quiet", "workers", "duration")


class Study:
    """Base class of the studies (see the module doc). Subclasses set `name`, `help` and
    `Config` (a dataclass of typed fields with defaults, as Drake's YAML-loadable configs),
    and override `add_arguments`, `configure`, `run` and `report`."""

    name: ClassVar[str] = ""
    help: ClassVar[str] = ""  # one line: what the study measures
    order: ClassVar[int] = 100  # registry order; lower first
    Config: ClassVar[type | None] = None

    def add_arguments(self, group: argparse._ArgumentGroup) -> None:
        """Adds the study's own options (beyond COMMON) to `group`."""

    def configure(self, args: argparse.Namespace) -> Any:
        """The study's Config from the parsed options (TestbedError for bad input)."""
        return self.Config() if self.Config is not None else None

    def run(self, config: Any, out: Path, map_calls=None) -> Any:
        raise NotImplementedError

    def report(self, result: Any, out: Path) -> list[Path]:
        """Writes the study's files into `out`; returns their paths."""
        return []

    def summary(self, result: Any) -> list[str]:
        """The lines `testbed study NAME` prints after the report."""
        return []


def floats(text: str | None, option: str, default, minimum: float | None = None) -> tuple[float, ...]:
    """A comma-separated list of numbers (positive, or >= minimum when given); `default` when
    `text` is empty; TestbedError naming `option` otherwise."""
    if not text:
        return tuple(default)
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        raise TestbedError(f"{option}: expected comma-separated numbers, got {text!r}") from None
    bad = [v for v in values if not (v >= minimum if minimum is not None else v > 0)]
    if bad:
        raise TestbedError(f"{option}: expected {'non-negative' if minimum is not None else 'positive'} numbers, got {bad}")
    return values


def choices(text: str | None, option: str, allowed, default) -> tuple[str, ...]:
    """A comma-separated list of names from `allowed`; `default` when `text` is empty."""
    if not text:
        return tuple(default)
    values = tuple(x.strip() for x in text.split(","))
    unknown = [v for v in values if v not in allowed]
    if unknown:
        raise TestbedError(f"{option}: unknown {unknown}; expected some of: {', '.join(allowed)}")
    return values
