"""`contact`: collision geometry and the contact model that drives the dynamics.

Without this effect the scene has no collision geometry at all (bodies fall freely).
"""


import dataclasses
import math
import typing

from testbed.drake_support import missing_approximation
from testbed.effects import register
from testbed.effects.base import Effect, ModelPlan, Role

CONTACT_MODELS = ("hydroelastic", "point", "hydroelastic_with_fallback")
# Every name a scene may spell; 'tamsi' only where the installed Drake has it (Drake 1.57 removed
# it: testbed.drake_support; a scene asking for it otherwise fails check() naming the version).
APPROXIMATIONS = ("auto", "sap", "tamsi", "similar", "lagged")


def drake_approximation(approximation: str, model: str) -> str:
    """Drake's discrete_contact_approximation for a contact config: 'auto' is 'similar' for
    the hydroelastic models and 'sap' for point contact (sdf/README.md: the defaults sweep
    found SAP failing to converge on the crane scenes at 1e9 Pa, and 'similar' crushing a
    2.2 t box 284 mm under a 32.5 t one with point contact, where SAP holds)."""
    if approximation != "auto":
        return approximation
    return "sap" if model == "point" else "similar"


@dataclasses.dataclass
class ContactConfig:
    model: str = "hydroelastic_with_fallback"  # one of CONTACT_MODELS (Drake's names)
    approximation: str = "auto"  # one of APPROXIMATIONS: Drake's names, or "auto" (drake_approximation)
    # Replaces the containers' drake:hydroelastic_margin [m] when set (SDF: 0; sdf/README.md).
    hydroelastic_margin: typing.Optional[float] = None
    # Replaces drake:hydroelastic_modulus [Pa] on every geometry when set (SDF: 1e9 Pa); the
    # defaults sweep (testbed study defaults) varies it.
    hydroelastic_modulus: typing.Optional[float] = None


@register
class ContactEffect(Effect):
    name = "contact"
    Config = ContactConfig
    role = Role.PHYSICS
    default_on = True
    translated_by = ("mujoco", "bullet")
    order = 0

    def check(self, effects) -> None:
        super().check(effects)
        if self.config.model not in CONTACT_MODELS:
            raise self.fail("model", f"unknown contact model {self.config.model!r}; expected one of: {', '.join(CONTACT_MODELS)}")
        if self.config.approximation not in APPROXIMATIONS:
            raise self.fail("approximation", f"unknown discrete approximation {self.config.approximation!r}; expected one of: {', '.join(APPROXIMATIONS)}")
        missing = missing_approximation(self.config.approximation)
        if missing:
            raise self.fail("approximation", missing)
        margin = self.config.hydroelastic_margin
        if margin is not None and not (math.isfinite(margin) and margin >= 0):
            raise self.fail("hydroelastic_margin", f"expected a non-negative length [m], got {margin}")
        modulus = self.config.hydroelastic_modulus
        if modulus is not None and not (math.isfinite(modulus) and 1e3 <= modulus <= 1e13):
            raise self.fail("hydroelastic_modulus", f"expected a modulus in [1e3, 1e13] Pa, got {modulus}")

    def plan(self, plan: ModelPlan) -> None:
        plan.collision = True
        plan.contact_model = self.config.model
        plan.discrete_contact_approximation = drake_approximation(self.config.approximation, self.config.model)
        if self.config.hydroelastic_margin is not None:
            plan.proximity_overrides["hydroelastic_margin"] = self.config.hydroelastic_margin
        if self.config.hydroelastic_modulus is not None:
            plan.proximity_overrides["hydroelastic_modulus"] = self.config.hydroelastic_modulus


def driving_kind(model: str) -> str:
    """'hydroelastic' or 'point': the kind of answer the driving model gives for two boxes.

    With hydroelastic_with_fallback every container pair is compliant-compliant or
    compliant-rigid, so it is hydroelastic; point contact is used only as fallback.
    """
    return "point" if model == "point" else "hydroelastic"
