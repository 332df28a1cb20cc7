"""Named suites: each case kind says which cases it has in each suite.

'default' fits 10 minutes on 2 cores, 'full' is for bigger machines, 'smoke' is a
tiny deterministic suite for tests of the machinery.
"""

from __future__ import annotations

from testbed.errors import TestbedError
from testbed.validation.cases import Case, registry

SUITES = ("default", "full", "smoke")


def suite(name: str) -> list[Case]:
    """The cases of a named suite, kind by kind in the registry's order."""
    if name not in SUITES:
        raise TestbedError(f"--suite: unknown suite {name!r}; expected one of: {', '.join(SUITES)}")
    return [case for kind in registry().values() for case in kind.cases(name)]


def with_predictors(cases: list[Case], predictors: list[str]) -> list[Case]:
    """`cases` with more predictors judged (each kind's CaseKind.with_predictors, applied
    to its own cases, in the same order)."""
    kinds = registry()
    out = []
    for name, kind in kinds.items():
        out += kind.with_predictors([c for c in cases if c.kind == name], list(predictors))
    return out + [c for c in cases if c.kind not in kinds]
