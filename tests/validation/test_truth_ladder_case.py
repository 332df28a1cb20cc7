"""validate's truth-ladder cell (testbed/validation/cases/truth_ladder.py) on its quick scenes.

What it must show, on data: overhang_tip's discrete truth is mesh-sensitive beyond the closed-loop
final-angle bound (0.75 deg from the continuous plant, measured; bound 0.5 deg), so judging the scene
against it would fail the cell's gate, while the continuous truth the scene names is converged in
its accuracy (1e-2 against 1e-3: 8e-4 deg) and passes; two_stack's discrete truth is converged (all
within 5 % of each bound, the ladder's resolution floor)."""

import pytest

from testbed.gates.closed_loop import FINAL_ANGLE_TOL_DEG
from testbed.validation.cases import registry
from testbed.validation.cases.truth_ladder import scene_uncertainties


@pytest.fixture(scope="module")
def ladder():
    kind = registry()["truth_ladder"]
    result = kind.run(quick=True)
    record = {"id": "truth-ladder", "kind": "truth_ladder", "params": {"quick": True}, "status": "ok", "result": result}
    return {s["scene"]: s for s in result["scenes"]}, kind.gates(record)


def test_overhang_tip_is_judged_against_the_converged_rung_because_the_discrete_one_misses_the_bound(ladder):
    scenes, gates = ladder
    tip = scenes["overhang_tip"]
    assert tip["classification"] == "truth-sensitive" and tip["judged_against"] == "continuous"
    discrete = scene_uncertainties(tip, continuous=False)
    assert discrete["final angle"] > FINAL_ANGLE_TOL_DEG  # a discrete judgement would fail the gate
    assert tip["gate_uncertainties"]["final angle"] <= 0.1 * FINAL_ANGLE_TOL_DEG
    angle = tip["quantities"]["top.final_angle_deg"]["values"]
    assert abs(angle["continuous_a1e-02"] - angle["continuous_a1e-03"]) < 0.01  # converged in its accuracy [deg]
    assert angle["polygon"] - angle["continuous_a1e-03"] > 0.5  # the one-point rule tips it further [deg]
    assert all(g.passed for g in gates if "overhang_tip" in g.name)


def test_two_stack_is_converged_under_its_discrete_truth(ladder):
    scenes, gates = ladder
    stack = scenes["two_stack"]
    assert stack["classification"] == "converged" and stack["judged_against"] == "discrete"
    assert all(g.passed and g.uncertainty is not None for g in gates if "two_stack" in g.name)
