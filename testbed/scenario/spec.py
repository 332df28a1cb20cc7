"""The scene's dataclasses: `Scenario` (a whole scene), `ContainerSpec` (one container or
generic box), `TruthSpec` (the ground truth a closed loop is judged against) and `Effects`
(one optional field per registered effect), with their defaults; the YAML form is in
testbed/scenario/__init__.py. Units: SI (m, kg, s, rad); poses X_WC of frame C in world W.
"""

import dataclasses
import typing

import numpy as np
from pydrake.common.schema import Transform
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.analysis import SimulatorConfig

from testbed.bodies.boxes import BOX_TYPE, BoxSpec, GroundSpec
from testbed.bodies.containers import CONTAINER_TYPES, ContainerType
from testbed.bodies.yards import YardSpec
from testbed.effects import registry
from testbed.effects.contact import drake_approximation


@dataclasses.dataclass
class ContainerSpec:
    """One container in a scene (see testbed/scenario/__init__.py for the YAML form), or a
    generic box: `type: box` with a `box:` block (size, density or inertia, contact)."""

    name: str = "container"
    type: str = "1CC"
    mass: typing.Optional[float] = None  # [kg] total; None = tare (box: density x volume)
    com_offset: typing.List[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    X_WC: Transform = dataclasses.field(default_factory=Transform)
    V_WC: typing.List[float] = dataclasses.field(default_factory=lambda: [0.0] * 6)
    fixed: bool = False
    box: typing.Optional[BoxSpec] = None  # only with type: box

    def total_mass(self) -> float:
        """[kg]"""
        if self.mass is not None:
            return float(self.mass)
        if self.type == BOX_TYPE:
            if self.box is None or self.box.density is None:
                return float("nan")
            return float(self.box.density * np.prod(self.box.size))
        return CONTAINER_TYPES[self.type].tare_mass

    def container_type(self) -> ContainerType:
        """The type's facts (size, colour, ...); for a box, made from its `box:` block."""
        if self.type != BOX_TYPE:
            return CONTAINER_TYPES[self.type]
        box = self.box or BoxSpec()
        return ContainerType(code=BOX_TYPE, description="generic rigid box", size=tuple(float(v) for v in box.size),
                             tare_mass=self.total_mass(), max_gross_mass=float("inf"), model_url="",
                             rgba=tuple(float(v) for v in box.rgba))

    def pose(self):
        """X_WC as a pydrake RigidTransform."""
        return self.X_WC.GetDeterministicValue()


def _effects_dataclass():
    """`Effects`: one optional field per registered effect, None = not declared."""
    fields = [
        (name, typing.Optional[cls.Config], dataclasses.field(default=None))
        for name, cls in registry().items()
    ]
    cls = dataclasses.make_dataclass("Effects", fields)
    cls.__module__ = __name__
    return cls


Effects = _effects_dataclass()


def _default_plant() -> MultibodyPlantConfig:
    # Drake's defaults except the time step (1 ms, the crane simulators' rate).
    # Sampled output ports stay on: the contact logger pairs each sampled result
    # with the state it came from, and unsampled ports would solve contact twice.
    # contact_model / discrete_contact_approximation mirror the default `contact` effect.
    # stiction_tolerance 1e-6 m/s, not Drake's 1e-4: the 'similar' approximation (the default
    # for hydroelastic contact) regularises friction with it, and at 1e-4 m/s a stack creeps
    # under a steady side load (windy_stack: 2.3 / 4.6 / 6.8 mm/min per tier; 1e-6: 0.08 / 0.22 /
    # 0.28, as SAP's 0.07 / 0.20 / 0.25; same cost; sdf/README.md). SAP does not use it.
    return MultibodyPlantConfig(
        time_step=1e-3, contact_model="hydroelastic_with_fallback", discrete_contact_approximation="similar",
        stiction_tolerance=1e-6,
    )


def _default_effects():
    return Effects(**{name: cls.Config() if cls.default_on else None for name, cls in registry().items()})


def _default_containers() -> list[ContainerSpec]:
    h = CONTAINER_TYPES["1CC"].size[2]
    return [ContainerSpec(name="box", type="1CC", mass=20000.0, X_WC=Transform(translation=[0, 0, h / 2]))]


TRUTH_REFERENCES = ("discrete", "continuous")


@dataclasses.dataclass
class TruthSpec:
    """The ground truth this scene's closed loop is judged against (docs/truth.md).

    reference: "discrete" (the scene's plant as given: Drake's discrete solver, each contact
    polygon's force at its centroid) or "continuous" (the converged rung: a continuous-time plant
    with triangle contact surfaces, whose moments Drake integrates exactly, RungeKutta3 with error
    control at `accuracy`; `testbed study truth` shows where the discrete answer is mesh- or
    step-sensitive and what the continuous one costs). The scene's own runs (`testbed run`) and
    Drake's runs in engine comparisons keep the discrete plant."""

    reference: str = "discrete"
    accuracy: float = 1e-3  # [-] the integrator's error-control accuracy (continuous only)


@dataclasses.dataclass
class Scenario:
    """A whole scene. `Scenario()` is the always-valid "defaults" scene."""

    name: str = "defaults"
    description: str = "One loaded 20 ft container resting on the quay."
    duration: float = 1.0  # [s] simulated
    ground: bool = True  # the quay slab (sdf/ground/quay_ground.sdf), or ground_surface when given
    ground_surface: typing.Optional[GroundSpec] = None  # a slab or half-space at a height; None = the quay slab
    overlap_tolerance: float = 5e-3  # [m] largest allowed penetration at t = 0
    plant: MultibodyPlantConfig = dataclasses.field(default_factory=_default_plant)
    simulator: SimulatorConfig = dataclasses.field(default_factory=SimulatorConfig)
    containers: typing.List[ContainerSpec] = dataclasses.field(default_factory=_default_containers)
    # yard blocks (testbed/bodies/yards.py), expanded into `containers` by validate_scenario
    yards: typing.List[YardSpec] = dataclasses.field(default_factory=list)
    effects: Effects = dataclasses.field(default_factory=_default_effects)
    truth: TruthSpec = dataclasses.field(default_factory=TruthSpec)

    def declared_effects(self) -> list[str]:
        """Names of the declared effects, in build order."""
        return [name for name in registry() if getattr(self.effects, name, None) is not None]

    def __getstate__(self) -> dict:
        """Copies and pickles leave the checked effects behind (they hold loaded predictors)."""
        return {k: v for k, v in self.__dict__.items() if k != _CHECKED}


_CHECKED = "_checked_effects"  # Scenario attribute: (dump_scenario text, {name: checked Effect})


def derive_plant(scenario: Scenario) -> None:
    """The plant's copies of the contact effect's model and (resolved) approximation."""
    contact = scenario.effects.contact
    scenario.plant.contact_model = contact.model
    scenario.plant.discrete_contact_approximation = drake_approximation(contact.approximation, contact.model)
