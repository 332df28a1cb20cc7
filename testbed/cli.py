"""The `testbed` command line: the commands of testbed/commands/ (`testbed --help`
lists them; docs/commands.md shows each), and the exit statuses.

Errors in the user's input (scene files, overrides, options) print one line naming
the file and field and exit with status 2; a simulation that fails (solver
divergence) exits with status 1. Nothing is left half-written.
"""

from __future__ import annotations

import argparse
import re
import sys

from learned_contact.predictors.limits import ModelLimits, set_limits
from testbed import commands
from testbed.errors import SimulationError, TestbedError, one_of

# Control characters (a file name may hold a line break or a terminal escape) are shown escaped,
# so that an error stays one line and cannot forge more output.
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")


def one_line(text: str) -> str:
    """`text` with every control character written as an escape (\\n, \\x1b, ...)."""
    return _CONTROL.sub(lambda m: repr(m.group())[1:-1], str(text))


def _positive(kind):
    def parse(text: str):
        try:
            value = kind(float(text)) if kind is int else kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: expected a positive number") from None
        if not (value > 0 and value != float("inf")):
            raise argparse.ArgumentTypeError(f"{text!r}: expected a positive number")
        return value
    return parse


def add_model_limits(parser: argparse.ArgumentParser) -> None:
    """The bounds on untrusted models (learned_contact.predictors.limits), on every command."""
    d = ModelLimits()
    group = parser.add_argument_group("bounds on a model the testbed did not ship (ONNX, module:attribute)")
    group.add_argument("--model-load-timeout", type=_positive(float), default=d.load_timeout_s, metavar="S",
                       help=f"seconds to load and probe it, in a child process (default {d.load_timeout_s:g})")
    group.add_argument("--model-call-timeout", type=_positive(float), default=d.call_timeout_s, metavar="S",
                       help=f"seconds for one call (default {d.call_timeout_s:g})")
    group.add_argument("--model-memory", type=_positive(float), default=d.memory_bytes / 2**30, metavar="GIB",
                       help=f"GiB of memory while it is loaded and probed, and of model file plus external data "
                            f"(default {d.memory_bytes / 2**30:g})")
    group.add_argument("--model-max-nodes", type=_positive(int), default=d.max_nodes, metavar="N",
                       help=f"nodes of an ONNX graph, subgraphs counted (default {d.max_nodes})")


def _apply_model_limits(args) -> None:
    set_limits(load_timeout_s=args.model_load_timeout, call_timeout_s=args.model_call_timeout,
               memory_bytes=int(args.model_memory * 2**30), max_nodes=args.model_max_nodes)


class Parser(argparse.ArgumentParser):
    """argparse with the testbed's manners: a mistyped choice (an engine, a study, a command) gets "did
    you mean", and a bad option is one line on stderr (the command, the option, what was expected), exit 2."""

    def _check_value(self, action, value):
        if action.choices is not None and value not in action.choices:
            raise argparse.ArgumentError(action, f"invalid choice {value!r}; {one_of(value, action.choices)}")
        super()._check_value(action, value)

    def error(self, message):
        command = self.prog.partition(" ")[2]  # "compare" of "testbed compare"; "" for the top level
        self.exit(2, f"testbed: error: {command + ': ' if command else ''}{one_line(message)}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="testbed", description="Container contact testbed (Drake).")
    sub = parser.add_subparsers(dest="command", required=True)
    for module_name in commands.COMMANDS:
        command = commands.load(module_name)
        p = sub.add_parser(command.NAME, help=command.HELP)
        command.add_arguments(p)
        add_model_limits(p)
        p.set_defaults(func=command.run)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        _apply_model_limits(args)
        return args.func(args)
    except SimulationError as e:
        print(f"testbed: simulation failed: {one_line(e)}", file=sys.stderr)
        return 1
    except TestbedError as e:
        print(f"testbed: error: {one_line(e)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("testbed: interrupted; no output was written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
