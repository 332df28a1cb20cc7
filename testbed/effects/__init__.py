"""Registry of effects. Adding an effect = adding one module here that calls `register`.

Every module in this package is imported on first use of the registry (cheap: effect
modules import heavy optional packages such as torch only inside their hooks).
"""


from testbed.effects.base import Effect, ModelPlan
from testbed.plugins import PackageRegistry

_REGISTRY = PackageRegistry(__name__, __path__, "effect")
register = _REGISTRY.register  # class decorator: adds an Effect subclass under `cls.name`


def registry() -> dict[str, type[Effect]]:
    """All effects by name, in build order."""
    return _REGISTRY.entries()


__all__ = ["Effect", "ModelPlan", "register", "registry"]
