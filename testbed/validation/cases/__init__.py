"""Registry of validation case kinds. Adding a case kind = adding one module here whose
CaseKind subclass is decorated with `@register`: it brings its suite cases, its runner,
its gates and its report sections.

Every module in this package is imported on first use of the registry (cheap: kind
modules import pydrake, the studies and matplotlib only inside their hooks).
"""

from __future__ import annotations

import importlib
import pkgutil

from testbed.validation.cases.base import Case, CaseKind

_REGISTRY: dict[str, CaseKind] = {}
_DISCOVERED = False


def register(cls: type[CaseKind]) -> type[CaseKind]:
    """Class decorator adding a CaseKind subclass to the registry under `cls.name`."""
    if not cls.name or cls.name in _REGISTRY:
        raise RuntimeError(f"case kind {cls.name!r} is empty or already registered")
    _REGISTRY[cls.name] = cls()
    return cls


def registry() -> dict[str, CaseKind]:
    """All case kinds by name, in suite order."""
    global _DISCOVERED
    if not _DISCOVERED:
        for module in pkgutil.iter_modules(__path__):
            if module.name != "base":
                importlib.import_module(f"{__name__}.{module.name}")
        _DISCOVERED = True
    return dict(sorted(_REGISTRY.items(), key=lambda item: (item[1].order, item[0])))


def ok_records(records: list[dict], kind: str) -> list[dict]:
    """The records of one kind that finished without an exception."""
    return [r for r in records if r["kind"] == kind and r["status"] == "ok"]


__all__ = ["Case", "CaseKind", "ok_records", "register", "registry"]
