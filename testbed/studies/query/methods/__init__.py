"""Method families of the query study: one module per family, each with

    ORDER: int                                   place in the study's tables (lower first)
    build(poses, scenes, options) -> list[ContactMethod]

Adding a method family = adding one module here (discovered on first use, like the
effects). Families import their optional packages only inside `build` and the methods.
"""

from __future__ import annotations

import importlib
import pkgutil

from testbed.studies.query.methods.base import ContactMethod, MethodOptions, Scenes

_FAMILIES: list | None = None


def families() -> list:
    """The family modules, in ORDER."""
    global _FAMILIES
    if _FAMILIES is None:
        found = [importlib.import_module(f"{__name__}.{m.name}") for m in pkgutil.iter_modules(__path__)
                 if m.name != "base"]
        _FAMILIES = sorted(found, key=lambda module: (module.ORDER, module.__name__))
    return _FAMILIES


def build_methods(poses, scenes: Scenes, options: MethodOptions) -> list[ContactMethod]:
    """Every family's methods bound to the poses of one set."""
    return [m for family in families() for m in family.build(poses, scenes, options)]


__all__ = ["ContactMethod", "MethodOptions", "Scenes", "build_methods", "families"]
