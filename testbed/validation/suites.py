"""Named suites: each case kind says which cases it has in each suite.

'default' fits 10 minutes on 2 cores, 'full' is for bigger machines, 'smoke' is a
tiny deterministic suite for tests of the machinery. 'full' adds the closed-loop scenes the
default leaves out for their cost (testbed.gates.closed_loop.FULL_EXTRA, each with its reason).
"""

from __future__ import annotations

from testbed.errors import TestbedError
from testbed.gates.closed_loop import FULL_EXTRA
from testbed.validation.cases import Case, registry

SUITES = ("default", "full", "smoke")


def suite(name: str) -> list[Case]:
    """The cases of a named suite, kind by kind in the registry's order."""
    if name not in SUITES:
        raise TestbedError(f"--suite: unknown suite {name!r}; expected one of: {', '.join(SUITES)}")
    out = []
    for kind in registry().values():
        cases = kind.cases(name)
        out += cases + (_full_extra_closed_loop(cases) if name == "full" and kind.name == "closed_loop" else [])
    return out


def _full_extra_closed_loop(cases: list[Case]) -> list[Case]:
    """The closed-loop cases of the 'full' suite beyond the default's (testbed.gates.closed_loop.FULL_EXTRA),
    each made like the kind's own cases (`cases`: its predictors, the sensitivity check among them);
    none whose id the kind already gives."""
    template = next((c for c in cases if c.kind == "closed_loop"), None)
    if template is None:
        return []
    ids = {c.id for c in cases}
    return [Case(f"closed-{scene}", "closed_loop", {**template.params, "scene": scene, "duration": duration})
            for scene, duration in FULL_EXTRA if f"closed-{scene}" not in ids]


def with_predictors(cases: list[Case], predictors: list[str]) -> list[Case]:
    """`cases` with more predictors judged (each kind's CaseKind.with_predictors, applied
    to its own cases, in the same order)."""
    kinds = registry()
    out = []
    for name, kind in kinds.items():
        out += kind.with_predictors([c for c in cases if c.kind == name], list(predictors))
    return out + [c for c in cases if c.kind not in kinds]
