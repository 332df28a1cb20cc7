"""The bench's cost of a user's model: the model's own call (onnxruntime's session.run
on a prepared feed, the Python object's predict) is timed beside the full predict call in the
same process, and bench.json, the verdict line, the cost section and the yard budget carry
both, the wrapper's share being the difference. No figure is asserted: only that the model's
own call, a strict part of the full call's work, is not reported dearer than it, and that every
derived field is derived from the measured ones."""

from __future__ import annotations

import bench_models as bm
import numpy as np
import pytest

from learned_contact import load_predictor
from testbed.bench import yard_budget
from testbed.document import to_markdown

pytest.importorskip("onnxruntime", reason="pip install onnxruntime==1.30.0")

PYTHON_MODEL = "slow_models:CentreLine"  # the centre-line model in numpy (no sleeping)


class _Poses:
    """The four pose arrays of a held-out set, as testbed.bench.cost reads them."""

    def __init__(self, p_AB, R_AB, size_A, size_B):
        self.p_AB, self.R_AB, self.size_A, self.size_B = p_AB, R_AB, size_A, size_B

    def __len__(self):
        return len(self.p_AB)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    return str(bm.centre_line_onnx(tmp_path_factory.mktemp("tiny") / "tiny.onnx"))


@pytest.fixture(scope="module")
def costs(tiny):
    from testbed.bench.cost import cost_table

    data = {"stacking": _Poses(*yard_budget.stacking_poses(40, "1AA")),
            "general": _Poses(*yard_budget.stacking_poses(40, "1CC", seed=1))}
    return cost_table(["improved", tiny, PYTHON_MODEL], data, repeats=2)


def test_the_own_call_answers_what_the_model_answers(tiny):
    """own_call runs the model itself: the same answer as the bounded call, before the wrapper."""
    pred = load_predictor(tiny)
    p, R, sA, sB = yard_budget.stacking_poses(5, "1CC")
    point, normal = pred.own_call(p, R, sA, sB)()
    want_point, want_normal = bm.centre_line_numpy(p)
    assert np.allclose(point, want_point, atol=1e-5) and np.allclose(normal, want_normal, atol=1e-5)
    point, _ = load_predictor(PYTHON_MODEL).own_call(p, R, sA, sB)()
    assert np.allclose(point, 0.5 * p)


def test_the_cost_table_carries_the_models_own_cost_and_the_wrappers_share(costs, tiny):
    refs = costs["references"]
    drake = refs["drake_point_pair_set_pose_and_query_s_per_pair"]
    # the reference's every round is kept (its spread on the first screen); the ratios read the fastest
    rounds = refs["drake_point_pair_rounds_s_per_pair"]
    assert len(rounds) >= 5 and min(rounds) == drake and all(r > 0 for r in rounds)
    for spec in (tiny, PYTHON_MODEL):
        c = costs["predictors"][spec]
        for how in ("single", "batched"):
            full, own, wrapper = (c[f"{k}{how}_s_per_pair"] for k in ("", "model_", "wrapper_"))
            assert 0 < own <= full, (spec, how, own, full)
            assert wrapper == pytest.approx(full - own, rel=1e-12)
            assert c[f"{how}_vs_drake_point"] == pytest.approx(full / drake)  # the headline ratios: the full call
            assert c[f"model_{how}_vs_drake_point"] == pytest.approx(own / drake)
    shipped = costs["predictors"]["improved"]
    assert shipped["single_s_per_pair"] > 0 and "model_single_s_per_pair" not in shipped  # no wrapper: one figure


def test_the_verdict_and_the_cost_section_show_both(costs, tiny):
    from testbed.bench.report import _cost
    from testbed.bench.run import _verdict

    c = costs["predictors"][tiny]
    entry = {"accuracy": {"gates_passed": 1, "gates_total": 1, "gates": []},
             "closed_loop": {"two_stack": {"passed": True, "gates": []}}, "cost": c}
    _, line = _verdict(entry)
    assert (f"{c['single_vs_drake_point']:.2g}x one pair per call (the model's own call: "
            f"{c['model_batched_vs_drake_point']:.2g}x and {c['model_single_vs_drake_point']:.2g}x") in line
    data = {"references": costs["references"], "leaderboard": [tiny],
            "predictors": {tiny: {"label": "tiny", "cost": {**c, "first_call_s": 1.0}, "closed_loop": {}}}}
    md = to_markdown("bench", [_cost(data)])
    assert "wrapper us/pair single / batched" in md
    row = next(line for line in md.splitlines() if line.startswith("| tiny |") and "/" in line)
    assert f"{c['wrapper_single_s_per_pair'] * 1e6:.3g} / {c['wrapper_batched_s_per_pair'] * 1e6:.3g}" in row


def test_the_yard_budget_counts_the_model_beside_the_full_call(tiny):
    host = {"model": "given", "n": 96, "host_step_s": 4e-4, "learned_system_s": 1e-4, "pairs_per_step": 72.0}
    settings = yard_budget.BudgetSettings(batch_sizes=(1, 16, 64), repeats=2, host=host)
    budget = yard_budget.yard_budget([tiny, PYTHON_MODEL, "paper"], settings)
    for spec in (tiny, PYTHON_MODEL):
        entry = budget["predictors"][spec]
        assert all(0 < own <= full for own, full in zip(entry["model_call_s"], entry["call_s"])), entry
        assert entry["model_pairs_within_step"] == yard_budget.pairs_within(6e-4, entry["model_fixed_s"],
                                                                            entry["model_per_pair_s"])
        assert entry["model_pairs_beside_loop"] == yard_budget.pairs_within(5e-4, entry["model_fixed_s"],
                                                                            entry["model_per_pair_s"])
    assert "model_call_s" not in budget["predictors"]["paper"]
    md = to_markdown("bench", [yard_budget.budget_section(budget)])
    assert "the model alone: pairs within the step beside the host" in md
    own = budget["predictors"][tiny]
    assert f"| {own['model_fixed_s'] * 1e6:.1f} + {own['model_per_pair_s'] * 1e6:.3f} per pair | " \
           f"{own['model_pairs_within_step']} |" in md
