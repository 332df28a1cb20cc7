"""Generic boxes and flat grounds in a scene.

Tolerances (and why):
- 1% on the time-averaged contact force against the weight: at rest the contact force
  balances gravity to solver tolerance; point contact hops between corners from step
  to step, so both models are averaged over the last 0.5 s of a 1 s rest.
- Rest height within 2 mm of the ground height + half the box: the static
  interpenetration is weight / stiffness = 3.8 kN / 1e7 N/m ~ 0.4 mm for point contact,
  and ~0.1 mm for hydroelastic (E = 1e7 Pa over a 0.25 m foundation), so 2 mm is several
  times either and still far below the box's 0.25 m half height.
"""

import functools

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion

from testbed.builder import build_scene
from testbed.errors import ScenarioError
from testbed.physics import GRAVITY
from testbed.scenario import load_scenario
from testbed.simulation import run_scenario

SIZE = (1.2, 0.8, 0.5)  # [m]
DENSITY = 800.0  # [kg/m^3] -> 384 kg

SCENE = """
name: box_on_ground
duration: 1.0
ground_surface: {{shape: {shape}, height: {height}}}
containers:
- name: crate
  type: box
  X_WC: {{translation: [0, 0, {z}]}}
  box:
    size: [1.2, 0.8, 0.5]
    density: 800.0
    contact: {{point_contact_stiffness: 1.0e7, hydroelastic_modulus: 1.0e7, mu_dynamic: 0.5}}
- name: can
  type: 1CC
  X_WC: {{translation: [10, 0, {zc}]}}
effects: {{contact: {{model: {model}}}, friction: {{}}, contact_log: {{}}}}
"""


def scene_text(shape="halfspace", height=0.0, model="hydroelastic_with_fallback"):
    return SCENE.format(shape=shape, height=height, z=height + SIZE[2] / 2, zc=height + 2.591 / 2, model=model)


@functools.lru_cache(maxsize=None)
def _rest(shape, height, model):
    return run_scenario(load_scenario(text=scene_text(shape, height, model)))


def test_box_scene_loads_and_builds_like_a_container():
    scenario = load_scenario(text=scene_text())
    crate = scenario.containers[0]
    assert crate.total_mass() == pytest.approx(DENSITY * np.prod(SIZE))
    assert crate.container_type().size == SIZE
    scene = build_scene(scenario)
    assert scene.body_names == ["quay_ground", "crate", "can"]
    body = scene.bodies["crate"]
    context = scene.plant.CreateDefaultContext()
    assert body.get_mass(context) == pytest.approx(384.0)
    # uniform solid box: I_xx = m (ly^2 + lz^2) / 12
    I = body.CalcSpatialInertiaInBodyFrame(context).CalcRotationalInertia().get_moments()
    assert I[0] == pytest.approx(384.0 * (0.8**2 + 0.5**2) / 12)


def test_box_inertia_given_explicitly_reaches_the_plant():
    text = scene_text().replace("density: 800.0", "inertia: [30.0, 50.0, 60.0]").replace("type: box\n", "type: box\n  mass: 384.0\n")
    scene = build_scene(load_scenario(text=text))
    context = scene.plant.CreateDefaultContext()
    moments = scene.bodies["crate"].CalcSpatialInertiaInBodyFrame(context).CalcRotationalInertia().get_moments()
    assert np.allclose(moments, [30.0, 50.0, 60.0])


@pytest.mark.parametrize("shape,height,model", [
    ("halfspace", 0.0, "hydroelastic_with_fallback"),
    ("slab", 0.75, "hydroelastic_with_fallback"),
    ("halfspace", -0.3, "point"),
    ("slab", 0.75, "point"),
])
def test_box_rests_on_flat_ground_with_force_balance(shape, height, model):
    result = _rest(shape, height, model)
    c = result.tables["contacts"]
    crate = result.body_names.index("crate")
    late = (c["time"] >= 0.5) & ((c["a"] == crate) | (c["b"] == crate))
    steps = np.unique(c["step"][c["time"] >= 0.5]).size
    weight = DENSITY * np.prod(SIZE) * GRAVITY
    assert abs(c["fn"][late].sum() / steps / weight - 1.0) < 0.01
    q = result.final_positions[:7]  # the crate: [qw qx qy qz x y z]
    assert abs(q[6] - (height + SIZE[2] / 2)) < 2e-3
    R_WC = Quaternion(q[:4] / np.linalg.norm(q[:4])).rotation()
    assert R_WC[2, 2] > 1 - 1e-6  # still flat on its bottom face (no roll or pitch)


BAD = [
    ("size: [1.2, 0.8, 0.5]", "size: [1.2, 0.8]", "containers[0].box.size"),
    ("size: [1.2, 0.8, 0.5]", "size: [1.2, -0.8, 0.5]", "containers[0].box.size"),
    ("density: 800.0", "density: -1.0", "containers[0].box.density"),
    ("density: 800.0", "density: 800.0\n    inertia: [1.0, 1.0, 5.0]", "containers[0].box.inertia"),
    ("density: 800.0", "density: 800.0\n    inertia: [1.0, 1.0]", "containers[0].box.inertia"),
    ("density: 800.0", "density: 800.0\n    colour: red", "containers[0].box.colour"),
    ("density: 800.0", "density: 800.0\n    corner_spheres: 0.3", "containers[0].box.corner_spheres"),
    ("    density: 800.0\n", "", "containers[0].mass"),
    ("  type: box\n", "  type: box\n  mass: 10.0\n", "containers[0].box.density"),
    ("mu_dynamic: 0.5", "mu_dynamic: -0.5", "containers[0].box.contact.mu_dynamic"),
    ("point_contact_stiffness: 1.0e7", "point_contact_stiffness: 0.0", "containers[0].box.contact.point_contact_stiffness"),
    ("  type: 1CC\n", "  type: 1CC\n  box: {size: [1, 1, 1]}\n", "containers[1].box"),
    ("shape: halfspace", "shape: dome", "ground_surface.shape"),
    ("height: 0.0", "height: 0.0, size: [10, 10]", "ground_surface.size"),
    ("height: 0.0", "height: 0.0, contact: {hydroelastic_modulus: 1.0e9}", "ground_surface.contact"),
]


@pytest.mark.parametrize("old,new,field", BAD)
def test_bad_box_fields_name_the_field(old, new, field):
    text = scene_text()
    assert old in text
    with pytest.raises(ScenarioError) as info:
        load_scenario(text=text.replace(old, new, 1))
    assert info.value.field == field, str(info.value)


def test_type_box_without_box_block_names_it():
    text = scene_text()
    start = text.index("  box:\n")
    end = text.index("- name: can")
    with pytest.raises(ScenarioError) as info:
        load_scenario(text=text[:start] + "  mass: 10.0\n" + text[end:])
    assert info.value.field == "containers[0].box"


def test_learned_predictor_refuses_a_box_at_build_time():
    text = scene_text().replace("contact_log: {}", "contact_log: {}, learned_contact: {}")
    scenario = load_scenario(text=text)
    with pytest.raises(ScenarioError) as info:
        build_scene(scenario)
    assert info.value.field == "effects.learned_contact"
    assert "containers[0]" in str(info.value) and "(1.2, 0.8, 0.5)" in str(info.value)


def test_box_scene_round_trips_through_the_dumped_scenario_and_set_overrides():
    """Run records hold the dumped scenario; it must reload to the same box and ground."""
    from testbed.scenario import dump_scenario

    scenario = load_scenario(text=scene_text("slab", 0.5, "point"), overrides=["containers[0].box.contact.mu_dynamic=0.3"])
    assert scenario.containers[0].box.contact.mu_dynamic == 0.3
    again = load_scenario(text=dump_scenario(scenario))
    assert again.containers[0].box == scenario.containers[0].box
    assert again.ground_surface == scenario.ground_surface
