"""Registry of effects. Adding an effect = adding one module here that calls `register`.

Every module in this package is imported on first use of the registry (cheap: effect
modules import heavy optional packages such as torch only inside their hooks).
"""


import importlib
import pkgutil

from testbed.effects.base import Effect, ModelPlan

_REGISTRY: dict[str, type[Effect]] = {}
_DISCOVERED = False


def register(cls: type[Effect]) -> type[Effect]:
    """Class decorator adding an Effect subclass to the registry under `cls.name`."""
    if not cls.name or cls.name in _REGISTRY:
        raise RuntimeError(f"effect name {cls.name!r} is empty or already registered")
    _REGISTRY[cls.name] = cls
    return cls


def registry() -> dict[str, type[Effect]]:
    """All effects by name, in build order."""
    global _DISCOVERED
    if not _DISCOVERED:
        for module in pkgutil.iter_modules(__path__):
            if module.name != "base":
                importlib.import_module(f"{__name__}.{module.name}")
        _DISCOVERED = True
    return dict(sorted(_REGISTRY.items(), key=lambda item: (item[1].order, item[0])))


__all__ = ["Effect", "ModelPlan", "register", "registry"]
