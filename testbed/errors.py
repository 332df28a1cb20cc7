"""The testbed's exceptions: one base class, specific subclasses.

Every message names where the problem is (file, field) and what was expected, so
the CLI can print it verbatim and exit with status 2.
"""

from __future__ import annotations

from collections.abc import Iterable

LISTED = 12  # names a "one of" list shows before it says how many more there are


def one_of(value: object, choices: Iterable[str]) -> str:
    """"did you mean X? expected one of: a, b, ..." for a name a user typed (difflib's close matches
    first; a long list cut to LISTED names and how many more)."""
    import difflib

    names = [str(c) for c in choices]
    close = difflib.get_close_matches(str(value), names, n=3, cutoff=0.6)
    head = f"did you mean {' or '.join(repr(c) for c in close)}? " if close else ""
    shown = ", ".join(names[:LISTED]) + (f", ... ({len(names) - LISTED} more, {len(names)} in all)"
                                         if len(names) > LISTED else "")
    return f"{head}expected one of: {shown}"


class TestbedError(Exception):
    """Base class of every error the testbed raises on purpose."""

    __test__ = False  # not a pytest test class despite the name


class UnknownChoiceError(TestbedError, ValueError):
    """A name (container type, effect, contact model, ...) that is not one of the valid choices."""

    def __init__(self, what: str, value: object, choices: Iterable[str]):
        self.what = what
        self.value = value
        self.choices = list(choices)
        super().__init__(f"unknown {what} {value!r}; {one_of(value, self.choices)}")


class ScenarioError(TestbedError, ValueError):
    """A scene file that cannot be loaded or is physically invalid.

    path: the scene file (or '<string>'); field: dotted path of the offending field
    (e.g. 'containers[1].mass'), or '' when the whole file is at fault.
    """

    def __init__(self, path: object, field: str, problem: str):
        self.path = str(path)
        self.field = field
        self.problem = problem
        where = f"{self.path}: {field}" if field else self.path
        # one line always: a key or value holding a line break is shown escaped
        super().__init__(f"{where}: {problem}".replace("\r", "\\r").replace("\n", "\\n"))


class ModelError(TestbedError):
    """A model file (SDF) that is missing or cannot be parsed."""


class OptionalDependencyError(TestbedError, ImportError):
    """An optional dependency is missing; the message gives the install command."""

    def __init__(self, package: str, purpose: str, extra: str):
        super().__init__(
            f"{purpose} needs the optional package '{package}', which is not installed; "
            f"install it with: pip install -e '.[{extra}]'"
        )


class SimulationError(TestbedError, RuntimeError):
    """Drake's simulator failed (e.g. the contact solver did not converge).

    Not an input error: the CLI exits with status 1, and no output is written.
    """
