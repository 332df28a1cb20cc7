"""The validate case kinds `closed_loop` and `engine`, and the simulation study's MuJoCo curves:
runners return what their gates and sections read, a closed-loop gate fails when its figure is
out of bounds, a missing MuJoCo makes the engine case unavailable (not an error), and the
sections render to Markdown and HTML."""

import copy
import sys

import pytest

from testbed.document import Figure, Section, Table, to_html, to_markdown
from testbed.gates import closed_loop as cl
from testbed.validation.cases import registry

SHORT_S = 0.1  # [s] simulated: enough for every figure to be computed, ~2 s of wall time per runner


def _record(kind: str, result: dict, case_id: str = "x") -> dict:
    return {"id": case_id, "kind": kind, "params": {}, "status": "ok", "result": result, "wall_s": 0.0}


def _no_mujoco(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # `import mujoco` raises ImportError


@pytest.fixture(scope="module")
def closed_loop_result():
    return registry()["closed_loop"].run(scene="two_stack", duration=SHORT_S)


def test_closed_loop_runner_returns_what_gates_and_sections_read(closed_loop_result):
    s = closed_loop_result
    assert {"scene", "duration_s", "resting", "largest_potential_drop_J", "energy_limit_J"} <= set(s)
    assert set(s["predictors"]) == {"improved", "paper"}
    for f in s["predictors"].values():
        assert set(cl.KEYS) | {"leaves_truth_at_s", "energy_gain_gated_J"} <= set(f)
    # the drop is the truth's own: two_stack settles, so it is positive and the limit is 1% of it
    assert s["largest_potential_drop_J"] > 0
    assert s["energy_limit_J"] == pytest.approx(cl.ENERGY_FRACTION * s["largest_potential_drop_J"])
    gates = registry()["closed_loop"].gates(_record("closed_loop", s))
    names = {g.name.rsplit(": ", 1)[-1] for g in gates}
    assert names == {"no divergence", "final position", "final angle", "max penetration", "energy"}  # < 1 s: no drift
    assert all("improved" in g.name for g in gates)  # the paper MLP is reported, not gated


def _passing_result() -> dict:
    """A fabricated closed-loop result inside every bound (the figures are made up)."""
    f = {k: 0.0 for k in cl.KEYS}
    f.update(diverged=False, departed=False, learned_error="", simulated_s_learned=2.0, leaves_truth_at_s=None,
             energy_gain_gated_J=0.0, final_position_error_max_m=0.001, final_angle_error_max_deg=0.01,
             max_penetration_m=0.002, drift_m_per_min_learned=1e-5, speedup_vs_truth=2.0, speedup_vs_point=0.5,
             wall_per_sim_s_learned=0.5)
    return {"scene": "two_stack", "duration_s": 2.0, "time_step_s": 1e-3, "resting": True,
            "largest_potential_drop_J": 100.0, "energy_limit_J": 1.0, "predictors": {"improved": f}}


@pytest.mark.parametrize("field, value, gate", [
    ("diverged", True, "no divergence"),
    ("final_position_error_max_m", 0.021, "final position"),  # bound 2 cm
    ("final_angle_error_max_deg", 0.51, "final angle"),  # bound 0.5 deg
    ("max_penetration_m", 0.021, "max penetration"),  # bound 20 mm
    ("energy_gain_gated_J", 1.01, "energy"),  # bound 1% of the 100 J drop
    ("drift_m_per_min_learned", 1.1e-3, "resting drift"),  # bound 1 mm per minute
    ("final_position_error_max_m", float("nan"), "final position"),  # a figure not measured fails
])
def test_closed_loop_gate_fails_out_of_bounds(field, value, gate):
    kind = registry()["closed_loop"]
    good = _passing_result()
    verdicts = {g.name.rsplit(": ", 1)[-1]: g.passed for g in kind.gates(_record("closed_loop", good))}
    assert verdicts[gate] and all(verdicts.values())
    bad = copy.deepcopy(good)
    bad["predictors"]["improved"][field] = value
    flipped = {g.name.rsplit(": ", 1)[-1]: g.passed for g in kind.gates(_record("closed_loop", bad))}
    assert flipped[gate] is False
    assert all(v for k, v in flipped.items() if k != gate)  # only that gate flips


def test_drift_not_gated_on_crane_or_short_runs():
    kind = registry()["closed_loop"]
    for change in ({"resting": False}, {"duration_s": 0.3}):
        r = {**_passing_result(), **change}
        assert "resting drift" not in " ".join(g.name for g in kind.gates(_record("closed_loop", r)))


def test_engine_runner_returns_what_the_section_reads():
    pytest.importorskip("mujoco")
    from testbed.engines import engine as engine_of
    from testbed.validation.cases import engine

    s = registry()["engine"].run(scene="two_stack", duration=SHORT_S)
    assert s["available"] and set(s["mujoco"]) == set(engine_of("mujoco").param_sets)
    assert {"wall_per_sim_s_hydroelastic", "wall_per_sim_s_point", "mujoco_version"} <= set(s)
    for f in s["mujoco"].values():
        assert set(engine.keys("mujoco")) <= set(f)
        assert f["speedup_vs_hydroelastic"] > 0 and f["position_error_max_m"] >= 0


def test_engine_unavailable_without_mujoco(monkeypatch):
    _no_mujoco(monkeypatch)
    monkeypatch.setitem(sys.modules, "pybullet", None)  # nor Bullet: no other engine can run
    kind = registry()["engine"]
    s = kind.run(scene="two_stack", duration=SHORT_S)  # no exception: a result saying why
    assert s["available"] is False and "pip install" in s["reason"]
    (section,) = kind.sections([_record("engine", s)])
    assert "Unavailable: two_stack" in to_markdown("t", [section])
    from testbed.validation.report import _environment

    assert _environment()["engines"]["mujoco"] == "not installed"


def test_sim_sweep_mujoco_curves_and_missing_mujoco(monkeypatch):
    from testbed.errors import TestbedError
    from testbed.studies.sim import sweep

    args = dict(models=["hydroelastic_with_fallback"], approximations=["sap"], time_steps=[5e-3],
                reference_step=1e-3, duration=SHORT_S)
    with pytest.raises(TestbedError, match="engines"):
        sweep("single_drop", engines=("physx",), **args)
    if "mujoco" not in sys.modules:
        pytest.importorskip("mujoco")
    rows = sweep("single_drop", engines=("drake", "mujoco"), **args)
    assert [(r["engine"], r["approximation"]) for r in rows] == [("drake", "sap"), ("mujoco", "matched"),
                                                                  ("mujoco", "default")]
    assert all(r["status"] == "ok" and r["deviation_m"] >= 0 for r in rows)
    _no_mujoco(monkeypatch)
    rows = sweep("single_drop", engines=("mujoco",), **args)
    assert rows and all(r["status"].startswith("unavailable") for r in rows)


def test_sections_render_to_markdown_and_html(closed_loop_result):
    from testbed.validation.cases import engine

    nan = float("nan")
    sim_row = {"scene": "two_stack", "engine": "mujoco", "model": "mujoco", "approximation": "matched",
               "time_step": 1e-3, "ms_per_sim_second": 10.0, "deviation_m": 1e-3, "max_penetration_m": 1e-3,
               "energy_gain_J": 0.0, "status": "ok"}
    drake_row = {**sim_row, "engine": "drake", "model": "hydroelastic_with_fallback", "approximation": "sap",
                 "ms_per_sim_second": 500.0}
    from testbed.engines import engine as engine_of

    engine_figures = {k: 0.001 for k in engine.keys("mujoco")} | {"diverged": False, "contact_normal_error_max_deg": nan}
    engine_result = {"scene": "two_stack", "available": True, "wall_per_sim_s_hydroelastic": 0.5,
                     "wall_per_sim_s_point": 0.1, "mujoco": {p: engine_figures for p in engine_of("mujoco").param_sets}}
    kinds = registry()
    parts = (kinds["closed_loop"].sections([_record("closed_loop", closed_loop_result, "closed-two_stack")])
             + kinds["engine"].sections([_record("engine", engine_result)])
             + kinds["sim_sweep"].sections([{**_record("sim_sweep", {"rows": [drake_row, sim_row]}),
                                             "params": {"engines": ["drake", "mujoco"]}}]))
    assert all(isinstance(p, Section) for p in parts)
    titles = [p.title for p in sorted(parts, key=lambda p: p.order)]
    i = titles.index(engine.SECTION_TITLE)
    assert titles[i + 1] is None  # the engine chart follows its section
    assert any(isinstance(b, Figure) and b.file == "figures/engine_speed_accuracy.png" for b in parts[-1].blocks)
    assert sum(isinstance(b, Table) for p in parts for b in p.blocks) >= 3
    md, html = to_markdown("report", parts), to_html("report", parts)
    for text in ("Closed loop: the improved predictor drives", "two_stack: improved", "x vs hydroelastic",
                 engine.SECTION_TITLE, "MuJoCo (matched) runs"):
        assert text in md and text in html
    assert "figures/engine_speed_accuracy.png" in md and "data:image/png;base64," in html


def test_corner_drop_known_limit_is_pinned_both_ways():
    """The pinned closed-loop limit holds only inside its band: the pinned final error passes as
    a known limit, 3x it (worse) and a third of it (the pin is stale) both fail, and the unpinned
    gates of that scene stay plain."""
    from testbed.gates.closed_loop import KNOWN_LIMITS
    from testbed.validation.cases import registry

    kind = registry()["closed_loop"]
    pins = KNOWN_LIMITS["corner_drop"][1]
    at = pins["final position"][0]

    def record(final_m):
        f = {"diverged": False, "final_position_error_max_m": final_m, "final_angle_error_max_deg": pins["final angle"][0],
             "max_penetration_m": 0.0457, "energy_gain_gated_J": 0.0}
        return {"id": "closed-loop-corner_drop", "result": {
            "scene": "corner_drop", "predictors": {"improved": f}, "energy_limit_J": 100.0,
            "largest_potential_drop_J": 1e4, "resting": False, "duration_s": 2.0}}

    def verdict(final_m, key="final position"):
        return next(g.passed for g in kind.gates(record(final_m)) if key in g.name)

    assert verdict(at) is True
    assert verdict(3.0 * at) is False
    assert verdict(at / 3.0) is False
    names = [g.name for g in kind.gates(record(at))]
    assert any(n.endswith("no divergence") for n in names) and any("(known limit)" in n for n in names)
