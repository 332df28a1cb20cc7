"""`compare --engine all`: every learned row answers with the predictor compare was given. The
"MuJoCo + learned" row used to run the engine's first parameter set (the shipped `improved`)
whatever --predictor named, while its neighbours ran the user's model. Here each candidate of
the list is run the way compare_candidates runs it (Engine.run with the candidate's params and
predictor), against stand-in engines that report what they were asked."""

from __future__ import annotations

import pytest

from testbed import load_scenario
from testbed.compare import candidates as candidates_module
from testbed.compare.candidates import Candidate, all_candidates
from testbed.engines import _REGISTRY, Engine


class _Asked(Exception):
    """Raised by the stand-in engines with the params and predictor they were run with."""


class _FakeLearned(Engine):
    name, label, order, learned = "fake_learned", "fake learned", 95, True

    def run(self, scenario, *, duration=None, record_every=1, params=None, predictor=None, contacts=False,
            source="<scenario>"):
        raise _Asked(self.name, params, predictor)


class _FakeMujoco(Engine):
    name, label, order, param_sets = "fake_mujoco", "fake MuJoCo", 96, ("matched", "default")

    def run(self, scenario, *, duration=None, record_every=1, params=None, predictor=None, contacts=False,
            source="<scenario>"):
        raise _Asked(self.name, params, predictor)


@pytest.fixture
def fakes(monkeypatch):
    for cls in (_FakeLearned, _FakeMujoco):
        _REGISTRY.register(cls)
    monkeypatch.setattr(candidates_module, "alternatives", lambda: [_FakeLearned(), _FakeMujoco()])
    yield
    for cls in (_FakeLearned, _FakeMujoco):
        _REGISTRY._entries.pop(cls.name, None)


def _asked(candidate: Candidate):
    """(engine, params, predictor) the candidate's engine is run with."""
    with pytest.raises(_Asked) as asked:
        candidate.spec.run(load_scenario("two_stack"), duration=0.01, params=candidate.run_params,
                           predictor=candidate.predictor)
    return asked.value.args


def test_the_learned_engine_runs_the_predictor_compare_was_given(fakes):
    chosen = all_candidates("tests/my_model.onnx")
    assert [c.label for c in chosen] == ["Drake point", "learned (tests/my_model.onnx)",
                                         "fake learned (tests/my_model.onnx)", "fake MuJoCo (matched)"]
    assert chosen[1].gated and chosen[1].predictor == "tests/my_model.onnx"
    assert _asked(chosen[2]) == ("fake_learned", None, "tests/my_model.onnx")


def test_an_engine_with_contact_parameters_keeps_its_parameter_set(fakes):
    assert _asked(all_candidates("tests/my_model.onnx", params="default")[3]) == ("fake_mujoco", "default", None)
    # not its set: its first
    assert _asked(all_candidates("tests/my_model.onnx", params="improved")[3]) == ("fake_mujoco", "matched", None)


def test_params_and_predictor_are_not_mixed_up():
    """A predictor for an engine no predictor decides, or a predictor passed as params, is refused."""
    with pytest.raises(ValueError, match="a predictor applies only to a learned engine"):
        Candidate("mujoco", predictor="paper")
    with pytest.raises(ValueError, match="not one of its contact-parameter sets"):
        _FakeMujoco().refuse_unused("paper", None)
    with pytest.raises(ValueError, match="no predictor decides its contact"):
        _FakeMujoco().refuse_unused(None, "paper")
    assert Candidate("learned").gated and not Candidate("learned").learned
    assert Candidate("mujoco_learned").learned and Candidate("mujoco_learned").judged
