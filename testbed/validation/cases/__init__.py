"""Registry of validation case kinds. Adding a case kind = adding one module here whose
CaseKind subclass is decorated with `@register`: it brings its suite cases, its runner,
its gates and its report sections.

Every module in this package is imported on first use of the registry (cheap: kind
modules import pydrake, the studies and matplotlib only inside their hooks).
"""

from __future__ import annotations

from testbed.plugins import PackageRegistry
from testbed.validation.cases.base import Case, CaseKind

_REGISTRY = PackageRegistry(__name__, __path__, "case kind", instantiate=True)
register = _REGISTRY.register  # class decorator: adds a CaseKind subclass (as an instance)


def registry() -> dict[str, CaseKind]:
    """All case kinds by name, in suite order."""
    return _REGISTRY.entries()


def ok_records(records: list[dict], kind: str) -> list[dict]:
    """The records of one kind that finished without an exception."""
    return [r for r in records if r["kind"] == kind and r["status"] == "ok"]


__all__ = ["Case", "CaseKind", "ok_records", "register", "registry"]
