"""`compare --engine all`: every learned row answers with the predictor compare was given. The
"MuJoCo + learned" row used to run the engine's first parameter set (the shipped `improved`)
whatever --predictor named, while its neighbours ran the user's model."""

from __future__ import annotations

import pytest

from testbed import load_scenario
from testbed.engines import three_way


class _Asked(Exception):
    """Raised by the fake engines with the params they were run with."""


class _FakeEngine:
    def __init__(self, name, learned, param_sets):
        self.name, self.label, self.learned, self.param_sets = name, name, learned, param_sets

    def run(self, scenario, *, duration=None, record_every=1, params=None, contacts=False, source="<scenario>"):
        raise _Asked(self.name, params)


def _asked(monkeypatch, engine, predictor, params="matched"):
    monkeypatch.setattr(three_way, "alternatives", lambda: [engine])
    monkeypatch.setattr(three_way, "engine_variant", lambda scenario, kind: scenario)
    figures = {"record_period_s": 0.01, "predictor": "my_model", "duration_s": 0.1}
    runs = {"truth": type("T", (), {"wall_s": 1.0, "simulated_s": 1.0})(), "learned": None, "point": None}
    with pytest.raises(_Asked) as asked:
        three_way.rows(load_scenario("two_stack"), figures, runs, params, predictor)
    return asked.value.args[1]


def test_the_learned_engine_runs_the_predictor_compare_was_given(monkeypatch):
    engine = _FakeEngine("mujoco_learned", learned=True, param_sets=("improved",))
    assert _asked(monkeypatch, engine, "tests/my_model.onnx") == "tests/my_model.onnx"


def test_an_engine_with_contact_parameters_keeps_its_parameter_set(monkeypatch):
    engine = _FakeEngine("mujoco", learned=False, param_sets=("matched", "default"))
    assert _asked(monkeypatch, engine, "tests/my_model.onnx", params="default") == "default"
    assert _asked(monkeypatch, engine, "tests/my_model.onnx", params="improved") == "matched"  # not its set: its first
