"""Validate's report names no engine itself: an engine registered from its own package (here a
toy one, registered for the test only) gets its rows in the engine section and on the first
screen's candidates table, with its own words (Engine.report_note)."""

from testbed.document import to_markdown
from testbed.engines import _REGISTRY, Engine
from testbed.validation.cases import registry
from testbed.validation.cases.engine import keys
from testbed.validation.summary import candidate_rows


class ToyEngine(Engine):
    name = "toy_engine"
    label = "Toy"
    order = 90
    param_sets = ("coarse",)
    report_note = "Toy: an engine only this test knows."


def test_a_new_engine_reaches_the_report_from_its_own_package(monkeypatch):
    monkeypatch.setitem(_REGISTRY._entries, ToyEngine.name, ToyEngine())
    figures = {k: 0.001 for k in keys(ToyEngine.name)} | {"diverged": False, "speedup_vs_hydroelastic": 42.0}
    result = {"scene": "two_stack", "available": True, "wall_per_sim_s_hydroelastic": 0.5, "wall_per_sim_s_point": 0.1,
              ToyEngine.name: {"coarse": figures}}
    record = {"id": "engine-two_stack", "kind": "engine", "params": {}, "status": "ok", "result": result}
    (section,) = registry()["engine"].sections([record])
    text = to_markdown("t", [section])
    assert "Toy: an engine only this test knows." in text and "Toy (coarse)" in text
    rows = candidate_rows([record])
    toy = [r for r in rows if r[0] == "Toy (coarse)"]
    assert toy and toy[0][3] == "42"  # its speed against Drake hydroelastic, read from its own figures
