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

Every effect declares its `role` (Role: physics, recorder, observer or viewer) and what
the other consumers need to know (`default_on`, `forkable`, `translated_by`,
`untranslated_reason`, `measured_alone`). Variants, studies, engines and the watchdog
read these from the registry; none of them lists effects by name.
"""


import dataclasses
import enum
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


class Role(enum.Enum):
    """What an effect does to a run. Only PHYSICS effects change the dynamics: a variant that
    keeps "only the physics" (a time-step sweep, a twin run, a bare timing) keeps every
    PHYSICS effect and drops the rest, and another engine may ignore the rest."""

    PHYSICS = "physics"  # changes the dynamics (contact, friction, forces, the learned loop)
    RECORDER = "recorder"  # records Drake's own contact (the ground truth) into the run's tables
    OBSERVER = "observer"  # evaluates something else (a predictor) beside the run, records it
    VIEWER = "viewer"  # draws the run (live or as a replay)


class Effect:
    """Base class of effects. Subclasses set `name`, `Config`, `role` and override hooks."""

    name: ClassVar[str] = ""
    Config: ClassVar[type] = object
    role: ClassVar[Role | None] = None  # every registered effect sets one (the registry refuses None)
    order: ClassVar[int] = 100  # build order; lower first
    requires: ClassVar[tuple[str, ...]] = ()  # other effects that must be declared
    default_on: ClassVar[bool] = False  # declared with its defaults in the "defaults" scene
    forkable: ClassVar[bool] = True  # False: must run in this process (watchdog.py: no forked child)
    translated_by: ClassVar[tuple[str, ...]] = ()  # engines besides Drake that reproduce this PHYSICS effect
    untranslated_reason: ClassVar[str] = ""  # why the others cannot (their refusal says it)
    # studies.sim.effect_costs measures it by default: its default config, added to the bare
    # scene (the default_on effects), is a meaningful extra cost
    measured_alone: ClassVar[bool] = True

    @classmethod
    def study_config(cls, *, replay: bool = False) -> Any:
        """The config a study, batch or replay switches this effect on with (its defaults;
        a viewer overrides: never a fixed port; `replay`: record a replay file)."""
        return cls.Config()

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
