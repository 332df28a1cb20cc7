"""Effects declare their role (testbed.effects.Role) and every consumer reads it; one
effect lifecycle (the effects that were checked are the ones that build).

A dummy observer and a dummy physics effect are registered for one test each (and
removed after it): the variants, the sweep, the batch, the replays and the MuJoCo
engine must treat them by their role, not by a list of names.
"""

import copy
import dataclasses

import pytest

import testbed.effects as effects_pkg
import testbed.effects.learned_dynamics.effect as learned_dynamics
from testbed import batch, build_scene, load_scenario
from testbed.compare.runs import variant
from testbed.effects import Effect, Role, registry
from testbed.engines.base import UnsupportedSceneError
from testbed.engines.mujoco.model import check_supported
from testbed.errors import ScenarioError
from testbed.studies.sim import configure
from testbed.validation.replays import with_recording


@dataclasses.dataclass
class DummyConfig:
    every_steps: int = 1


class DummyObserver(Effect):
    name = "dummy_observer"
    Config = DummyConfig
    role = Role.OBSERVER


class DummyPhysics(Effect):
    name = "dummy_physics"
    Config = DummyConfig
    role = Role.PHYSICS


@pytest.fixture
def registered(monkeypatch):
    """Registers an effect class for one test (the registry's own table, restored after)."""
    registry()  # discover the package's effects first

    def add(cls):
        monkeypatch.setitem(effects_pkg._REGISTRY._entries, cls.name, cls)
        return cls

    return add


def test_every_registered_effect_declares_a_role():
    for name, cls in registry().items():
        assert isinstance(cls.__dict__.get("role"), Role), name
    # the shipped split: only these change the dynamics
    assert {n for n, c in registry().items() if c.role is Role.PHYSICS} == {
        "contact", "friction", "wind", "crane", "deck_motion", "learned_dynamics"}


def test_register_refuses_an_effect_without_a_role():
    class NoRole(Effect):
        name = "no_role"
        Config = DummyConfig

    with pytest.raises(RuntimeError, match="'no_role'.*role"):
        effects_pkg.register(NoRole)
    assert "no_role" not in registry()


def test_a_new_observer_is_dropped_by_variants_and_ignored_by_mujoco(registered):
    scenario = load_scenario("five_stack")  # before: Scenario's Effects fields are the package's effects
    registered(DummyObserver)
    scenario.effects.dummy_observer = DummyConfig()
    assert "dummy_observer" in scenario.declared_effects()
    check_supported(scenario)  # no dynamics: MuJoCo ignores it (raised UnsupportedSceneError before)
    assert "dummy_observer" not in variant(scenario, "truth").declared_effects()
    swept = configure(scenario, model="point", approximation="auto", time_step=1e-3, duration=0.1)
    assert "dummy_observer" not in swept.declared_effects()
    bare = batch._variant(scenario, model="point", recorded=False)
    assert "dummy_observer" not in bare.declared_effects()
    recorded = batch._variant(scenario, model="point", recorded=True)  # RECORDERs only, not observers
    assert {"contact_log", "shadow_contact"} <= set(recorded.declared_effects())
    assert "dummy_observer" not in recorded.declared_effects()
    replay = with_recording(copy.deepcopy(scenario))
    assert {"dummy_observer", "contact_log", "shadow_contact", "learned_contact", "meshcat"} <= set(
        replay.declared_effects())
    assert replay.effects.meshcat.record and replay.effects.meshcat.port == 0


def test_a_new_physics_effect_is_kept_and_refused_by_mujoco(registered):
    scenario = load_scenario("five_stack")  # before: Scenario's Effects fields are the package's effects
    registered(DummyPhysics)
    scenario.effects.dummy_physics = DummyConfig()
    with pytest.raises(UnsupportedSceneError, match="effects.dummy_physics .*no MuJoCo translation"):
        check_supported(scenario)
    assert "dummy_physics" in variant(scenario, "truth").declared_effects()
    swept = configure(scenario, model="point", approximation="auto", time_step=1e-3, duration=0.1)
    assert "dummy_physics" in swept.declared_effects()


def test_time_step_sweep_keeps_the_crane():
    scenario = load_scenario("crane_edge_landing")
    swept = configure(scenario, model="point", approximation="auto", time_step=2e-3, duration=0.1)
    assert "crane" in swept.declared_effects()  # was dropped: the sweep listed contact, friction, wind
    assert [n for n in swept.declared_effects() if registry()[n].role is not Role.PHYSICS] == []


def test_mujoco_refusal_names_the_learned_loop_reason():
    scenario = load_scenario("two_stack", overrides=["effects.learned_dynamics={}"])
    with pytest.raises(UnsupportedSceneError, match="effects.learned_dynamics .*drives Drake's plant only"):
        check_supported(scenario)


# ----------------------------------------------------------------------------- lifecycle

LEARNED = ["effects.learned_dynamics={}", "effects.shadow_contact=null"]


@pytest.fixture
def predictor_loads(monkeypatch):
    """Counts learned_dynamics's predictor loads (the loader itself runs unchanged)."""
    calls = []
    real = learned_dynamics.load_named_predictor

    def counting(name):
        calls.append(name)
        return real(name)

    monkeypatch.setattr(learned_dynamics, "load_named_predictor", counting)
    return calls


def test_a_predictor_is_loaded_once_per_build(predictor_loads):
    scenario = load_scenario("two_stack", overrides=LEARNED)
    assert predictor_loads == ["improved"]  # the check loads it (a bad predictor fails at load time)
    scene = build_scene(scenario)
    assert predictor_loads == ["improved"]  # the build takes the checked effect (was 2 more loads)
    assert scene.effects["learned_dynamics"].predictor is not None
    build_scene(scenario)  # an effect builds one diagram: a second build checks anew
    assert len(predictor_loads) == 2
    changed = copy.deepcopy(scenario)  # a copy carries no checked effects
    build_scene(changed)
    assert len(predictor_loads) == 3


def test_a_scenario_changed_after_loading_is_checked_again(predictor_loads):
    scenario = load_scenario("two_stack", overrides=LEARNED)
    scenario.plant.time_step = 0.02  # unstable for the explicit contact step: the build must see it
    with pytest.raises(ScenarioError, match="time_step = 0.02"):
        build_scene(scenario)


def test_compare_loads_the_scene_once(monkeypatch, tmp_path):
    import testbed.compare.run_candidates as run_candidates
    import testbed.scenario as scenario_module
    from testbed.cli import main

    loads = []
    real = scenario_module.load_scenario

    def counting(*args, **kwargs):
        loads.append(args)
        return real(*args, **kwargs)

    monkeypatch.setattr(scenario_module, "load_scenario", counting)
    monkeypatch.setattr(run_candidates, "load_scenario", counting)  # the one comparison path loads by name too
    assert main(["compare", "defaults", "--duration", "0.01", "--no-replay", "--out", str(tmp_path / "c")]) == 0
    assert len(loads) == 1  # was 2: the command passes the loaded Scenario on


GENERIC_BOX = """
name: box_under_learned_loop
duration: 0.1
containers:
- {name: base, type: 1CC, mass: 20000.0, X_WC: {translation: [0.0, 0.0, 1.2955]}}
- name: crate
  type: box
  X_WC: {translation: [0.0, 0.0, 2.841]}
  box: {size: [1.2, 0.8, 0.5], density: 800.0}
effects: {contact: {}, friction: {}, learned_dynamics: {}}
"""


def test_closed_loop_refuses_a_generic_box():
    with pytest.raises(ScenarioError, match=r"containers\[1\]\.type.*'crate' is a generic 'box'.*learned_dynamics"):
        load_scenario(text=GENERIC_BOX)  # was a raw KeyError from the fitted stiffness table
