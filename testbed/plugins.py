"""One mechanism for the project's plug-in registries: the effects (testbed/effects/), the
validation case kinds (testbed/validation/cases/) and the engines (testbed/engines/: one
package each). A plug-in is one module (or package) of the package that decorates its class
with the registry's `register`; every module of the package is imported on the registry's
first use, and entries come back sorted by their class's `order`, then name.
"""

from __future__ import annotations

import importlib
import pkgutil
from typing import Any, Iterable


class PackageRegistry:
    """Name -> entry for the plug-in modules of one package.

    package: the package's dotted name; path: its __path__; what: the plug-in's noun for
    messages ("effect", "case kind"); instantiate: store an instance of each class rather
    than the class; skip: modules that define the base class, not plug-ins.
    """

    def __init__(self, package: str, path: Iterable[str], what: str, *, instantiate: bool = False,
                 skip: tuple[str, ...] = ("base",)):
        self._package, self._path, self._what = package, list(path), what
        self._instantiate, self._skip = instantiate, skip
        self._entries: dict[str, Any] = {}
        self._discovered = False

    def register(self, cls):
        """Class decorator adding `cls` under `cls.name` (unique, non-empty)."""
        if not cls.name or cls.name in self._entries:
            raise RuntimeError(f"{self._what} name {cls.name!r} is empty or already registered")
        self._entries[cls.name] = cls() if self._instantiate else cls
        return cls

    def entries(self) -> dict[str, Any]:
        """All entries by name, sorted by (order, name); imports the package's modules once."""
        if not self._discovered:
            for module in pkgutil.iter_modules(self._path):
                if module.name not in self._skip:
                    importlib.import_module(f"{self._package}.{module.name}")
            self._discovered = True
        return dict(sorted(self._entries.items(), key=lambda item: (item[1].order, item[0])))
