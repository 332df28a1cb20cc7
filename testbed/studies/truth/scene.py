"""Builds a scene for a truth rung that testbed.builder.build_scene cannot: the containers'
compliant box replaced by a refined .vtk mesh, and/or a continuous-time plant.

It follows build_scene step by step (the same SDF text, the same effects, the same force
multiplexing) with two differences, both confined to this study's code path:
- `meshes` maps a container type's size to a .vtk file: the collision element's
  <box> becomes <mesh><uri>file://...</uri></mesh>, keeping its proximity properties
  (drake:compliant_hydroelastic, modulus, dissipation, friction), so only the mesh changes;
- `plant_config` is the plant's config as given, time_step 0 allowed (a continuous plant:
  testbed.scenario refuses that for `testbed run`). The scene's effects still read a time
  step from the plant for their periodic events (the contact log, the crane's locks): they
  see a view of the plant whose time_step() is the scenario's plant.time_step [s], the
  record period here, while the diagram holds the real continuous plant.

The scenario itself stays valid (positive plant.time_step): its effects are checked as in
any run (testbed.scenario.checked_effects), bad input raising ScenarioError.
"""

from __future__ import annotations

import re

from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from testbed.bodies import models as model_loading
from testbed.bodies.models import GROUND_NAME
from testbed.builder import BuiltScene, SceneAssembly, _connect_forces, check_initial_overlap
from testbed.effects import ModelPlan
from testbed.scenario import Scenario, checked_effects

_BOX_IN_COLLISION = re.compile(r"(<collision\b[^>]*>(?:(?!</collision>).)*?<geometry>)\s*<box>.*?</box>\s*(</geometry>)", re.S)


class _PlantView:
    """The plant as effects see it on a continuous plant: every attribute is the plant's,
    except time_step() [s], which is the record period the effects schedule their events at."""

    def __init__(self, plant, period: float):
        self._plant, self._period = plant, float(period)

    def time_step(self) -> float:
        return self._period

    def __getattr__(self, name):
        return getattr(self._plant, name)


def with_mesh(sdf_text: str, vtk_path) -> str:
    """SDF text whose collision boxes are the mesh at `vtk_path` (an absolute file path)."""
    uri = f"file://{vtk_path}"
    text, n = _BOX_IN_COLLISION.subn(lambda m: f"{m.group(1)}<mesh><uri>{uri}</uri></mesh>{m.group(2)}", sdf_text)
    if n == 0:
        raise ValueError("no collision <box> in the body's SDF to replace with a mesh")
    return text


def build_rung_scene(scenario: Scenario, plant_config: MultibodyPlantConfig, *, meshes: dict | None = None,
                     source: object = "<scenario>") -> BuiltScene:
    """The scene with `plant_config` (contact model and approximation from the effects, as
    build_scene does) and the collision meshes `meshes` ({container size (3,) tuple [m]:
    .vtk path}; a size not in it keeps its box). Continuous plant (time_step 0): effects see
    scenario.plant.time_step as the plant's step (see the module doc)."""
    effects = checked_effects(scenario, source)
    plan = ModelPlan()
    for effect in effects.values():
        effect.plan(plan)
    properties = dict(plan.proximity_overrides)
    if not plan.friction:
        properties.update(mu_dynamic=0.0, mu_static=0.0)
    config = type(plant_config)(**{f.name: getattr(plant_config, f.name) for f in plant_config.__fields__})
    config.contact_model = plan.contact_model
    config.discrete_contact_approximation = plan.discrete_contact_approximation
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(config, builder)
    plant.set_name("plant")
    parser = Parser(plant)
    parser.SetStrictParsing()
    bodies = {}
    if scenario.ground:
        text = model_loading.scene_ground_sdf(scenario.ground_surface, collision=plan.collision, properties=properties)
        (ground,) = parser.AddModelsFromString(text, "sdf")
        bodies[GROUND_NAME] = plant.GetBodyByName("slab", ground)
    meshes = meshes or {}
    for spec in scenario.containers:
        text = model_loading.scene_body_sdf(spec, collision=plan.collision, properties=properties)
        mesh = meshes.get(tuple(float(v) for v in spec.container_type().size))
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
    assembly = SceneAssembly(scenario=scenario, builder=builder, plant=seen, scene_graph=scene_graph,
                             body_names=list(bodies), bodies=bodies, plan=plan)
    for name, effect in effects.items():
        effect.systems = list(effect.add_systems(assembly) or [])
        assembly.effects[name] = effect
    _connect_forces(assembly)
    diagram = builder.Build()
    diagram.set_name(f"scene:{scenario.name}")
    scene = BuiltScene(scenario=scenario, diagram=diagram, plant=plant, scene_graph=scene_graph,
                       body_names=assembly.body_names, bodies=bodies, effects=effects,
                       free_names=[c.name for c in scenario.containers if not c.fixed])
    if plan.collision and not meshes:  # point-pair penetration needs the boxes (a mesh run is checked by its box twin)
        check_initial_overlap(scene, source)
    return scene
