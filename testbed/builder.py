"""Scene -> Drake diagram, with only the systems the scene's effects declare.

The plant and scene graph are always there; everything else (loggers, shadow
probes, wind, viewers, learned predictors, cranes) is added by effect modules.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydrake.geometry import SceneGraph
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    ExternallyAppliedSpatialForceMultiplexer,
    MultibodyPlant,
)
from pydrake.systems.framework import Diagram, DiagramBuilder

from testbed.bodies import models as model_loading
from testbed.bodies.models import GROUND_NAME
from testbed.contact.body_index import geometry_body_index
from testbed.effects import Effect, ModelPlan
from testbed.errors import ScenarioError
from testbed.scenario import Scenario, checked_effects


@dataclasses.dataclass
class SceneAssembly:
    """What effects see while the diagram is being assembled (plant finalised, not built)."""

    scenario: Scenario
    builder: DiagramBuilder
    plant: MultibodyPlant
    scene_graph: SceneGraph
    body_names: list[str]  # plant-order names: ground (if any) first, then containers
    bodies: dict  # name -> RigidBody
    plan: ModelPlan
    effects: dict = dataclasses.field(default_factory=dict)  # name -> Effect, those added so far
    force_ports: list = dataclasses.field(default_factory=list)  # ExternallyAppliedSpatialForce outputs

    def add_spatial_forces(self, output_port) -> None:
        """Queues an output port of external spatial forces for the plant's applied-force input."""
        self.force_ports.append(output_port)


@dataclasses.dataclass
class BuiltScene:
    """A built scene: the diagram, handles into it, and the effects that shaped it."""

    scenario: Scenario
    diagram: Diagram
    plant: MultibodyPlant
    scene_graph: SceneGraph
    body_names: list[str]
    bodies: dict
    effects: dict[str, Effect]
    free_names: list[str]  # containers that move (not fixed), scene order

    def create_context(self):
        """A root context with the scene's initial velocities applied (poses are defaults)."""
        context = self.diagram.CreateDefaultContext()
        plant_context = self.plant.GetMyMutableContextFromRoot(context)
        for spec in self.scenario.containers:
            if not spec.fixed:
                V = np.asarray(spec.V_WC, dtype=float)
                self.plant.SetFreeBodySpatialVelocity(
                    plant_context, self.bodies[spec.name], SpatialVelocity(w=V[:3], v=V[3:])
                )
        return context

    def system_names(self) -> list[str]:
        return [s.get_name() for s in self.diagram.GetSystems()]


def build_scene(scenario: Scenario, source: object = "<scenario>") -> BuiltScene:
    """Builds the diagram with the effects that were checked (testbed.scenario.checked_effects:
    those load_scenario checked, else checked now). Raises ScenarioError for invalid scenes
    (overlaps included)."""
    effects = checked_effects(scenario, source)
    plan = ModelPlan()
    for effect in effects.values():
        effect.plan(plan)
    properties = dict(plan.proximity_overrides)
    if not plan.friction:
        properties.update(mu_dynamic=0.0, mu_static=0.0)

    config = scenario.plant
    config = type(config)(**{f.name: getattr(config, f.name) for f in config.__fields__})
    config.contact_model = plan.contact_model
    config.discrete_contact_approximation = plan.discrete_contact_approximation
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(config, builder)
    plant.set_name("plant")
    parser = Parser(plant)
    parser.SetStrictParsing()
    bodies = {}
    if scenario.ground:
        ground_text = model_loading.scene_ground_sdf(scenario.ground_surface, collision=plan.collision, properties=properties)
        (ground,) = parser.AddModelsFromString(ground_text, "sdf")
        bodies[GROUND_NAME] = plant.GetBodyByName("slab", ground)
    for spec in scenario.containers:
        text = model_loading.scene_body_sdf(spec, collision=plan.collision, properties=properties)  # container or box
        (instance,) = parser.AddModelsFromString(text, "sdf")
        body = plant.GetBodyByName("body", instance)
        bodies[spec.name] = body
        if spec.fixed:
            plant.WeldFrames(plant.world_frame(), body.body_frame(), spec.pose())
        else:
            plant.SetDefaultFloatingBaseBodyPose(body, spec.pose())
    plant.Finalize()

    assembly = SceneAssembly(
        scenario=scenario, builder=builder, plant=plant, scene_graph=scene_graph,
        body_names=list(bodies), bodies=bodies, plan=plan,
    )
    for name, effect in effects.items():
        effect.systems = list(effect.add_systems(assembly) or [])
        assembly.effects[name] = effect
    _connect_forces(assembly)
    diagram = builder.Build()
    diagram.set_name(f"scene:{scenario.name}")
    scene = BuiltScene(
        scenario=scenario, diagram=diagram, plant=plant, scene_graph=scene_graph,
        body_names=assembly.body_names, bodies=bodies, effects=effects,
        free_names=[c.name for c in scenario.containers if not c.fixed],
    )
    if plan.collision:
        check_initial_overlap(scene, source)
    return scene


def _connect_forces(assembly: SceneAssembly) -> None:
    ports = assembly.force_ports
    if not ports:
        return
    target = assembly.plant.get_applied_spatial_force_input_port()
    if len(ports) == 1:
        assembly.builder.Connect(ports[0], target)
        return
    mux = assembly.builder.AddSystem(ExternallyAppliedSpatialForceMultiplexer(len(ports)))
    mux.set_name("applied_force_mux")
    for i, port in enumerate(ports):
        assembly.builder.Connect(port, mux.get_input_port(i))
    assembly.builder.Connect(mux.get_output_port(), target)


def check_initial_overlap(scene: BuiltScene, source: object) -> None:
    """Raises ScenarioError if two bodies interpenetrate by more than scenario.overlap_tolerance."""
    context = scene.diagram.CreateDefaultContext()
    query = scene.plant.get_geometry_query_input_port().Eval(scene.plant.GetMyContextFromRoot(context))
    owner = geometry_body_index(scene, query)
    tolerance = scene.scenario.overlap_tolerance
    for pair in query.ComputePointPairPenetration():
        if pair.depth > tolerance:
            a, b = sorted((owner[pair.id_A], owner[pair.id_B]))
            name_a, name_b = scene.body_names[a], scene.body_names[b]
            field = "X_WC"
            index = next(i for i, c in enumerate(scene.scenario.containers) if c.name == name_b)
            raise ScenarioError(
                source, f"containers[{index}].{field}",
                f"'{name_b}' overlaps '{name_a}' by {pair.depth * 1e3:.1f} mm at t = 0; "
                f"expected at most overlap_tolerance = {tolerance * 1e3:.1f} mm",
            )
