"""Where a learned closed-loop run's time goes: the system's cost counters, compare.json's
`cost_learned`, `testbed compare`'s line and the closed-loop verdict.

Timing ratios are not asserted (shared machines are noisy); the structure is: every part
non-negative, the parts summing to the run's wall time, one calc per step.
"""

import copy
import json
from pathlib import Path

import pytest

from testbed.cli import main
from testbed.compare import costs

TILTED_DROP = Path(__file__).parents[1] / "scenes" / "tilted_drop.yaml"
PARTS_S = ("drake_step_s", "learned_system_s", "predictor_s", "recording_s")


@pytest.fixture(scope="module")
def tilted_compare(tmp_path_factory):
    """`testbed compare` on the tilted drop for 0.35 s (the box lands at ~0.25 s)."""
    out = tmp_path_factory.mktemp("cmp") / "tilted"
    import contextlib
    import io

    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(["compare", str(TILTED_DROP), "--duration", "0.35", "--no-replay", "--out", str(out)])
    figures = json.loads((out / "compare.json").read_text())
    # 0.35 s is mid-landing: the gates may fail (exit 3, measured: 35 mm from the truth); the exit
    # status is the verdict's either way
    assert code == figures["exit_status"] and code in (0, 3)
    return figures, printed.getvalue()


def test_compare_json_carries_the_breakdown(tilted_compare):
    figures, _ = tilted_compare
    cost = figures["cost_learned"]
    assert cost["steps"] == 350  # 0.35 s at 1 ms
    assert all(cost[k] >= 0 for k in PARTS_S)
    # the parts are the run's wall time split (drake_step_s is the remainder): their sum is
    # the wall time up to the timers' rounding (1e-9 s)
    assert sum(cost[k] for k in PARTS_S) <= cost["wall_s"] + 1e-9
    assert sum(cost[k] for k in PARTS_S) == pytest.approx(cost["wall_s"], abs=1e-6)
    assert cost["recording_s"] == 0  # the twin runs drop the recorders
    # the wall time is the one speedup_vs_truth is computed from
    assert cost["wall_s"] / 0.35 == pytest.approx(figures["wall_per_sim_s_learned"], rel=1e-9)
    # one calc per step; the predictor is called on the steps with a candidate pair (the drop
    # starts 0.3 m apart, outside the 0.05 m candidate band, so not on every step)
    assert cost["calc_calls"] == 350
    assert 0 < cost["predictor_calls"] < cost["calc_calls"]
    for part in ("drake_step", "learned_system", "predictor"):
        assert cost[f"{part}_us_per_step"] == pytest.approx(1e6 * cost[f"{part}_s"] / 350)


def test_compare_prints_the_breakdown(tilted_compare):
    figures, printed = tilted_compare
    line = next(x for x in printed.splitlines() if "learned run's wall time" in x)
    for label in ("Drake's step", "learned system", "predictor"):
        assert label in line
    assert ("not faster than Drake hydroelastic" in line) == (figures["speedup_vs_truth"] < 1)


def test_breakdown_arithmetic():
    cost = costs.breakdown({"calc_s": 0.3, "predict_s": 0.1, "record_s": 0.2, "calc_calls": 10,
                            "predict_calls": 8}, wall_s=1.0, steps=10)
    assert cost["predictor_s"] == pytest.approx(0.1) and cost["learned_system_s"] == pytest.approx(0.2)
    assert cost["drake_step_s"] == pytest.approx(0.5) and cost["recording_s"] == pytest.approx(0.2)
    assert cost["drake_step_fraction"] == pytest.approx(0.5) and cost["predictor_us_per_step"] == pytest.approx(1e4)
    assert "recording 20%" in costs.breakdown_line(cost)
    assert costs.breakdown_line(None) is None


def test_system_counters_cover_calc_and_predictor():
    """The counters read back from a learned run: predictor time inside the calc time,
    inside the wall time, and zero after reset."""
    from testbed.compare.runs import run_variant, variant
    from testbed.scenario import load_scenario

    run = run_variant(variant(load_scenario(TILTED_DROP), "learned"), 0.3, 10)
    c = run.costs
    assert 0 < c["predict_s"] < c["calc_s"] < run.wall_s
    assert c["record_s"] == 0 and c["calc_calls"] == 300


def test_closed_loop_verdict_says_where_the_time_goes_when_not_faster(tilted_compare):
    from testbed.gates.closed_loop import KEYS
    from testbed.validation.cases.closed_loop import verdict

    figures, _ = tilted_compare
    assert "cost_learned" in KEYS  # kept in the validate record
    f = {k: figures.get(k) for k in KEYS}
    f.update(leaves_truth_at_s=None, energy_gain_gated_J=0.0)
    record = {"scene": "tilted_drop", "duration_s": 0.35, "resting": False, "energy_limit_J": 1e9,
              "largest_potential_drop_J": 1e11, "predictors": {"improved": f}}
    slower, faster = copy.deepcopy(record), copy.deepcopy(record)
    slower["predictors"]["improved"]["speedup_vs_truth"] = 0.91
    faster["predictors"]["improved"]["speedup_vs_truth"] = 1.7
    assert "its wall time: Drake's step" in verdict(slower) and "predictor" in verdict(slower)
    assert "its wall time" not in verdict(faster)


def test_logger_distances_from_body_poses_are_drakes():
    """contact_log computes the boxes' signed distances from the bodies' poses it already
    read: the same pairs and distances as near_distances on Drake's geometry poses."""
    from pydrake.systems.analysis import Simulator

    from testbed.builder import build_scene
    from testbed.contact.extraction import near_distances
    from testbed.scenario import load_scenario

    scene = build_scene(load_scenario(TILTED_DROP, overrides=["effects.contact_log={}"]))
    context = scene.create_context()
    simulator = Simulator(scene.diagram, context)
    simulator.Initialize()
    logger = scene.effects["contact_log"].logger
    for t, near in ((0.0, 1), (0.3, 2)):  # the base on the quay; then the box landed (tilted) on it too
        simulator.AdvanceTo(t)
        sub = logger.GetMyContextFromRoot(context)
        step, _, p, R, mine = logger._geometry(sub)
        drake = near_distances(logger._query_port.Eval(sub))
        assert logger._box_body is not None and set(mine) == set(drake) and len(drake) == near
        # the same poses composed in another order: equal to 1e-12 m
        assert all(abs(mine[k] - drake[k]) < 1e-12 for k in drake)


def test_closed_loop_records_keep_touching_rows_and_place_the_truth():
    """build() keeps the rows with fn > 0 in step order, maps containers to body rows, and
    puts each sampled step's truth on that step's touching rows (NaN elsewhere)."""
    import numpy as np

    from testbed.effects.learned_dynamics.truth import ClosedLoopRecords, ShadowTruth, absent

    records = ClosedLoopRecords([1, 2, 3], ShadowTruth(["1CC"] * 3, 1e8, 2))
    z3 = np.zeros((2, 3))
    records.add(0, 0.0, (np.array([0, 1]), np.array([1, 2]), np.array([5.0, 0.0]), z3 + 1, z3, z3, np.ones(2)),
                truth={**absent(1), "has_truth": np.array([True]), "fn_truth": np.array([4.0])})
    records.add(1, 0.001, (np.array([0, 1]), np.array([1, 2]), np.array([0.0, 7.0]), z3 + 2, z3, z3, np.ones(2)))
    records.add(2, 0.002, (np.array([], int), np.array([], int), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)),
                           np.zeros((0, 3)), np.zeros(0)))
    table = records.build()
    assert table["step"].tolist() == [0, 1] and table["a"].tolist() == [1, 2] and table["b"].tolist() == [2, 3]
    assert table["fn"].tolist() == [5.0, 7.0] and table["p_W"][:, 0].tolist() == [1.0, 2.0]
    assert table["has_truth"].tolist() == [True, False]
    assert table["fn_truth"][0] == 4.0 and np.isnan(table["fn_truth"][1])
    empty = ClosedLoopRecords([0], None).build()
    assert len(empty["a"]) == 0 and "has_truth" not in empty and empty["step"].dtype == np.int64
