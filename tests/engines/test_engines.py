"""The Engine protocol and registry (testbed/engines), the one sampled-run loop
(testbed.simulation.advance) and the scene variants (testbed/variants.py)."""

import json

import numpy as np
import pytest

from testbed import variants
from testbed.cli import main
from testbed.engines import _REGISTRY, Engine, UnsupportedSceneError, alternatives, candidates, engine, engines
from testbed.errors import ScenarioError, SimulationError, TestbedError, UnknownChoiceError
from testbed.scenario import load_scenario
from testbed.simulation import advance


def test_the_registry_holds_drake_the_learned_loop_mujoco_and_bullet():
    assert list(engines()) == ["drake", "learned", "mujoco", "bullet", "mujoco_learned"]
    assert [n for n, e in engines().items() if e.reference] == ["drake"]
    assert [n for n, e in engines().items() if e.gated] == ["learned"]
    assert [n for n, e in engines().items() if e.learned] == ["mujoco_learned"]
    assert list(candidates()) == ["learned", "mujoco", "bullet", "mujoco_learned"]
    assert [e.name for e in alternatives()] == ["mujoco", "bullet", "mujoco_learned"]
    assert engine("mujoco").param_sets == ("matched", "default")
    with pytest.raises(UnknownChoiceError,
                       match="unknown engine 'physx'; expected one of: drake, learned, mujoco, bullet, mujoco_learned"):
        engine("physx")


def test_an_unsupported_scene_is_a_scenario_error_naming_scene_and_field():
    scenario = load_scenario("two_stack", overrides=["effects.learned_dynamics={}"])
    with pytest.raises(UnsupportedSceneError) as caught:
        engine("mujoco").check(scenario)
    e = caught.value
    assert isinstance(e, ScenarioError) and e.field == "effects.learned_dynamics"
    assert str(e).startswith("scene 'two_stack': effects.learned_dynamics is not supported by the MuJoCo engine: ")


class _Stub:
    """A simulator whose AdvanceTo raises past `fail_at` [s] (or whose state turns NaN there)."""

    def __init__(self, fail_at, error=None):
        self.t, self.fail_at, self.error = 0.0, fail_at, error

    def AdvanceTo(self, t):
        if t > self.fail_at and self.error is not None:
            raise self.error
        self.t = t

    def get_context(self):
        return self

    def get_time(self):
        return self.t

    def positions(self):
        return np.array([np.nan if self.t > self.fail_at else 0.0])


@pytest.mark.parametrize("error, status, describe", [
    (RuntimeError("solver failed\nsecond line"), "diverged", "RuntimeError: solver failed"),
    (ValueError("a predictor refused NaN poses"), "diverged", "ValueError: a predictor refused NaN poses"),
    (SimulationError("a child failed"), "diverged", "SimulationError: a child failed"),
    (None, "non-finite", "non-finite state"),
])
def test_one_failure_convention(error, status, describe):
    """Anything raised, or a non-finite state, ends the run at that sample; the samples
    before it are kept; an input error is not a run failure and propagates."""
    stub, seen = _Stub(0.025, error), []
    wall, failure = advance(stub, [0.01, 0.02, 0.03, 0.04], seen.append, positions=stub.positions)
    assert seen == [0.01, 0.02] and wall >= 0.0
    assert failure.status == status and failure.describe() == describe
    if error is not None:
        assert failure.time == 0.02 and "\n" not in failure.message


def test_an_input_error_propagates_from_the_loop():
    stub = _Stub(0.0, TestbedError("bad input"))
    with pytest.raises(TestbedError, match="bad input"):
        advance(stub, [0.01], lambda t: None)


def test_variants_compose_on_a_copy():
    base = load_scenario("windy_stack", overrides=["effects.contact_log={}"])
    out = variants.derive(base, variants.physics_only(), variants.contact("point"), variants.timing(time_step=2e-3),
                          variants.log_contacts(None))
    assert base.effects.contact.model == "hydroelastic_with_fallback" and base.plant.time_step == 1e-3  # untouched
    assert out.effects.contact.model == out.plant.contact_model == "point"
    assert out.plant.discrete_contact_approximation == "sap"  # 'auto' under point contact (effects/contact.py)
    assert out.effects.wind is not None  # a PHYSICS effect stays
    assert out.effects.contact_log.every_steps == 5  # one RECORD_PERIOD (10 ms) of 2 ms steps, after the timing edit


class _DrakePointAsAnEngine(Engine):
    """A stand-in for a new engine: Drake's point contact under another name."""

    name = "stand_in"
    label = "Stand-in"
    order = 90

    def run(self, scenario, **kw):
        return engine("drake").run(scenario, **{**kw, "params": "point"})


def test_an_engine_is_one_registration(tmp_path):
    """Registered, an engine is a `testbed compare --engine` choice, is compared against
    Drake's truth under its own name, and joins the simulation study's engines."""
    from testbed.studies.sim import sweep

    _REGISTRY.register(_DrakePointAsAnEngine)
    try:
        out = tmp_path / "cmp"
        assert main(["compare", "two_stack", "--engine", "stand_in", "--duration", "0.05", "--no-replay",
                     "--out", str(out)]) == 0
        figures = json.loads((out / "compare.json").read_text())
        assert figures["engine"] == "stand_in" and figures["params"] is None
        assert figures["candidates"]["Stand-in"]["engine"] == "stand_in"
        for key in ("simulated_s_learned", "wall_per_sim_s_learned", "contact_rows_missing",
                    "contact_rows_max_penetration_m", "speedup_vs_truth"):
            assert key in figures, key
        assert figures["simulated_s_learned"] == pytest.approx(0.05)
        # Drake point against Drake hydroelastic, 0.05 s of a resting stack: within 2 mm
        # (measured 1.1 mm at 0.3 s, compare --engine all on two_stack)
        assert figures["position_error_max_m"] < 2e-3
        with np.load(out / "trajectories.npz") as series:
            assert "stand_in_p_WB" in series.files
        rows = sweep("single_drop", models=["hydroelastic_with_fallback"], approximations=["sap"], time_steps=[5e-3],
                     reference_step=1e-3, duration=0.05, engines=("stand_in",))
        assert [(r["engine"], r["model"], r["status"]) for r in rows] == [("stand_in", "stand_in", "ok")]
    finally:
        _REGISTRY._entries.pop("stand_in", None)
    assert "stand_in" not in engines()
