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
