"""The Effect base class: what a scene may switch on, and the hooks a builder calls.

An effect is one file in testbed/effects/ holding a config dataclass (its YAML
schema under `effects.<name>`) and an Effect subclass registered with
`@register`. The builder calls, in order of `Effect.order`:

1. `check(scene)`        validate the config against the whole scenario;
2. `plan(plan)`          switch model features (collision, friction, plant config)
                         before any model is parsed;
3. `add_systems(scene)`  add and connect the effect's own systems after the plant
                         is finalised; return them so tests can see what was added;
4. `collect(tables)`     after simulation, move recorded data into the run's tables;
5. `summarize(tables)`   add a few headline figures to the run summary;
6. `files()`             extra files for the run directory (e.g. a Meshcat replay).
"""


import dataclasses
from typing import Any, ClassVar

from testbed.errors import ScenarioError


@dataclasses.dataclass
class ModelPlan:
    """Model-level switches decided by effects before parsing (defaults: nothing on)."""

    collision: bool = False  # keep collision geometry (the `contact` effect)
    friction: bool = False  # keep friction; False makes every coefficient 0
    contact_model: str = "hydroelastic_with_fallback"
    discrete_contact_approximation: str = "similar"
    # drake:proximity_properties values replacing the SDF's on every geometry
    proximity_overrides: dict = dataclasses.field(default_factory=dict)


class Effect:
    """Base class of effects. Subclasses set `name`, `Config` and override hooks."""

    name: ClassVar[str] = ""
    Config: ClassVar[type] = object
    order: ClassVar[int] = 100  # build order; lower first
    requires: ClassVar[tuple[str, ...]] = ()  # other effects that must be declared

    def __init__(self, config: Any, scenario: Any, source: object = "<scenario>"):
        self.config = config
        self.scenario = scenario
        self.source = source
        self.systems: list = []

    def fail(self, field: str, problem: str) -> ScenarioError:
        """A ScenarioError about `effects.<name>.<field>` of this scene's file."""
        path = f"effects.{self.name}" + (f".{field}" if field else "")
        return ScenarioError(self.source, path, problem)

    def check(self, effects: dict[str, "Effect"]) -> None:
        for other in self.requires:
            if other not in effects:
                raise self.fail("", f"needs the '{other}' effect too; add 'effects: {{{other}: {{}}}}'")

    def plan(self, plan: ModelPlan) -> None:
        pass

    def add_systems(self, scene: Any) -> list:
        return []

    def collect(self, tables: dict[str, dict]) -> None:
        pass

    def summarize(self, tables: dict[str, dict]) -> dict:
        return {}

    def files(self) -> dict:
        """Extra run files this effect made (file name -> str or bytes), written next to the records."""
        return {}
