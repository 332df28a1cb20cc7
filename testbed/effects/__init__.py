"""Registry of effects. Adding an effect = adding one module here that calls `register`.

Every module in this package is imported on first use of the registry (cheap: effect
modules import heavy optional packages such as torch only inside their hooks).
"""


from testbed.effects.base import Effect, ModelPlan, Role
from testbed.plugins import PackageRegistry

_REGISTRY = PackageRegistry(__name__, __path__, "effect")


def register(cls: type[Effect]) -> type[Effect]:
    """Class decorator: adds an Effect subclass under `cls.name`; it must declare its Role."""
    if not isinstance(cls.__dict__.get("role"), Role):
        raise RuntimeError(f"effect {cls.name!r} ({cls.__module__}): expected a declared `role = Role.<...>` "
                           f"(one of {', '.join(r.name for r in Role)})")
    return _REGISTRY.register(cls)


def registry() -> dict[str, type[Effect]]:
    """All effects by name, in build order."""
    return _REGISTRY.entries()


def with_role(*roles: Role) -> list[str]:
    """Names of the registered effects whose role is one of `roles`, in build order."""
    return [name for name, cls in registry().items() if cls.role in roles]


__all__ = ["Effect", "ModelPlan", "Role", "register", "registry", "with_role"]
