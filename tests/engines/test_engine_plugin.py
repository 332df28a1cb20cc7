"""A new engine is one package and nothing else: an Engine subclass registered with
testbed.engines.register appears in `testbed compare --engine all`'s candidates (and runs in the
one comparison path), in validate's engine case, in the scale study's models and, when a
predictor decides its contact, among the bench's yard-budget hosts, with no other edit.

The dummy engines delegate to Drake point contact (a real simulator, so the figures are real);
each is registered for one test only (the registry's entries restored after)."""

from __future__ import annotations

import pytest

from testbed import engines as engine_registry
from testbed.engines.base import Engine

SCENE_S = 0.05  # [s] simulated: enough for one recorded step of two_stack, seconds of work


class DummyPointEngine(Engine):
    """Drake's point contact under another name: an alternative engine with one parameter set."""

    name = "dummy_point"
    label = "Dummy point"
    order = 90
    param_sets = ("only",)

    def run(self, scenario, *, duration=None, record_every=1, params=None, predictor=None, contacts=False,
            source="<scenario>"):
        self.refuse_unused(params, predictor)
        run = engine_registry.engine("drake").run(scenario, duration=duration, record_every=record_every,
                                                  params="point", contacts=contacts, source=source)
        run.summary["version"] = "0"
        return run


class DummyHostEngine(DummyPointEngine):
    """A learned dummy: a predictor would decide its contact (only its registration is used)."""

    name = "dummy_host"
    label = "Dummy host"
    param_sets = ()
    learned = True


@pytest.fixture
def registered(monkeypatch):
    def register(cls):
        monkeypatch.setattr(engine_registry._REGISTRY, "_entries", dict(engine_registry.engines()))
        engine_registry.register(cls)
        return engine_registry.engine(cls.name)
    return register


def test_a_registered_engine_is_a_candidate_of_compare_all_and_runs_in_the_one_comparison_path(registered):
    from testbed.compare import compare_candidates
    from testbed.compare.candidates import Candidate, all_candidates
    from testbed.scenario import load_scenario

    registered(DummyPointEngine)
    assert "dummy_point" in [c.engine for c in all_candidates("improved")]
    figures = compare_candidates(load_scenario("two_stack"), [Candidate.point(), Candidate("dummy_point")],
                                 duration=SCENE_S)
    dummy, point = figures["candidates"]["Dummy point (only)"], figures["candidates"]["Drake point"]
    # the same simulator under two names against one truth: the same trajectory, so the same errors
    assert dummy["final_position_error_max_m"] == pytest.approx(point["final_position_error_max_m"], abs=1e-12)


def test_a_registered_engine_runs_in_validates_engine_case(registered):
    from testbed.validation.cases import registry

    registered(DummyPointEngine)
    row = registry()["engine"].run("two_stack", SCENE_S)
    assert row["available"] and "only" in row["dummy_point"]
    assert row["dummy_point"]["only"]["diverged"] is False


def test_a_registered_engine_is_a_model_of_the_scale_study(registered):
    from testbed.studies.scale.settings import models

    registered(DummyPointEngine)
    spec = models()["dummy_point"]
    assert spec.engine == "dummy_point" and spec.params == "only" and not spec.judged


def test_a_registered_learned_engine_is_a_host_of_the_bench_s_yard_budget(registered):
    from testbed.bench.yard_budget import host_models

    before = host_models()
    registered(DummyHostEngine)
    assert "dummy_host" in host_models() and "dummy_host" not in before
    assert host_models()[-1] == "learned"  # the Drake-hosted loop stays the last resort
