"""Scene -> Drake diagram, with only the systems the scene's effects declare.

The plant and scene graph are always there; everything else (loggers, shadow
probes, wind, viewers, learned predictors, cranes) is added by effect modules.
"""

from __future__ import annotations

import copy
import dataclasses
import re

import numpy as np
from pydrake.geometry import SceneGraph
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    ExternallyAppliedSpatialForceMultiplexer,
    MultibodyPlant,
)
from pydrake.systems.analysis import SimulatorConfig
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


class _PlantView:
    """The plant as effects see it on a continuous plant: every attribute is the plant's, except
    time_step() [s], the scenario's plant.time_step: the period effects schedule their events at
    (the contact log's records, the crane's locks)."""

    def __init__(self, plant, period: float):
        self._plant, self._period = plant, float(period)

    def time_step(self) -> float:
        return self._period

    def __getattr__(self, name):
        return getattr(self._plant, name)


_BOX_IN_COLLISION = re.compile(r"(<collision\b[^>]*>(?:(?!</collision>).)*?<geometry>)\s*<box>.*?</box>\s*(</geometry>)", re.S)


def with_mesh(sdf_text: str, vtk_path) -> str:
    """SDF text whose collision boxes are the volume mesh at `vtk_path` (an absolute file path),
    keeping the collision's proximity properties (compliance, modulus, dissipation, friction)."""
    uri = f"file://{vtk_path}"
    text, n = _BOX_IN_COLLISION.subn(lambda m: f"{m.group(1)}<mesh><uri>{uri}</uri></mesh>{m.group(2)}", sdf_text)
    if n == 0:
        raise ValueError("no collision <box> in the body's SDF to replace with a mesh")
    return text


def continuous_simulator(accuracy: float, max_step: float) -> SimulatorConfig:
    """The integrator of a continuous-time truth: RungeKutta3 with error control at `accuracy`,
    steps of at most `max_step` [s] (the scene's discrete step: events keep their period).
    No per-step publishing: that is SimulatorConfig's default on drake 1.51, and drake 1.58 removed
    the field, so it is left unset to build on both."""
    return SimulatorConfig(integration_scheme="runge_kutta3", accuracy=float(accuracy), use_error_control=True,
                           max_step_size=float(max_step))


def build_scene(scenario: Scenario, source: object = "<scenario>", *, continuous_accuracy: float | None = None,
                meshes: dict | None = None) -> BuiltScene:
    """Builds the diagram with the effects that were checked (testbed.scenario.checked_effects:
    those load_scenario checked, else checked now). Raises ScenarioError for invalid scenes
    (overlaps included).

    Two truth rungs (docs/truth.md) are built here too, never from a scene file alone:
    continuous_accuracy: a continuous-time plant (time_step 0) with triangle contact surfaces
    (Drake's continuous plant integrates each triangle's moment exactly) and unsampled output
    ports, run by continuous_simulator(continuous_accuracy, plant.time_step); effects see the
    scenario's plant.time_step as the plant's step (_PlantView). meshes: {container size (3,)
    tuple [m]: .vtk path}: that size's collision box replaced by the volume mesh (a refined
    compliant mesh)."""
    if continuous_accuracy is not None:
        scenario = copy.copy(scenario)
        scenario.simulator = continuous_simulator(continuous_accuracy, scenario.plant.time_step)
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
    if continuous_accuracy is not None:
        config.time_step, config.contact_surface_representation, config.use_sampled_output_ports = 0.0, "triangle", False
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
    meshes = meshes or {}
    for spec in scenario.containers:
        text = model_loading.scene_body_sdf(spec, collision=plan.collision, properties=properties)  # container or box
        mesh = meshes.get(tuple(float(v) for v in spec.container_type().size)) if meshes else None
        if mesh is not None and plan.collision:
            text = with_mesh(text, mesh)
        (instance,) = parser.AddModelsFromString(text, "sdf")
        body = plant.GetBodyByName("body", instance)
        bodies[spec.name] = body
        if spec.fixed:
            plant.WeldFrames(plant.world_frame(), body.body_frame(), spec.pose())
        else:
            plant.SetDefaultFloatingBaseBodyPose(body, spec.pose())
    plant.Finalize()

    seen = plant if config.time_step > 0 else _PlantView(plant, scenario.plant.time_step)
    assembly = SceneAssembly(
        scenario=scenario, builder=builder, plant=seen, scene_graph=scene_graph,
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
    if plan.collision and not meshes:  # point-pair penetration needs boxes (a mesh rung's box twin is checked)
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
