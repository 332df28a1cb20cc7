"""`friction`: Coulomb friction from the models (or a scene-wide override).

Without this effect every friction coefficient is 0 (frictionless contact).
"""


import dataclasses
import typing

from testbed.effects import register
from testbed.effects.base import Effect, ModelPlan, Role


@dataclasses.dataclass
class FrictionConfig:
    # None keeps the SDF values (mu_static 0.5, mu_dynamic 0.4, sdf/README.md);
    # a number sets both coefficients of every geometry.
    mu: typing.Optional[float] = None


@register
class FrictionEffect(Effect):
    name = "friction"
    Config = FrictionConfig
    role = Role.PHYSICS
    default_on = True
    translated_by = ("mujoco", "bullet")
    order = 1
    requires = ("contact",)

    def check(self, effects) -> None:
        super().check(effects)
        if self.config.mu is not None and not self.config.mu >= 0:
            raise self.fail("mu", f"expected a non-negative friction coefficient, got {self.config.mu}")

    def plan(self, plan: ModelPlan) -> None:
        plan.friction = True
        if self.config.mu is not None:
            plan.proximity_overrides.update(mu_dynamic=self.config.mu, mu_static=self.config.mu)
