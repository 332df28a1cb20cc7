"""A user's model that answers its own contact force (the contract's optional outputs force_n,
stiffness and area, at 1e8 Pa; a Python model's `force` method): loaded and checked like the point,
applied by the closed loop in place of the testbed's exact field force, judged by the bench against
Drake's. Without one, the testbed's force drives the model (and the bench says so)."""

from __future__ import annotations

import numpy as np
import pytest

from learned_contact.errors import PredictorOutputError, WeightsError
from learned_contact.sources import load_predictor
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.compare.runs import run_variant, variant
from testbed.scenario import load_scenario

SIZE = np.array(CONTAINER_TYPES["1CC"].size)
REST = """
name: own_force_rest
duration: 0.3
containers:
- {name: base, type: 1CC, mass: 20000.0, fixed: true, X_WC: {translation: [0.0, 0.0, 1.2955]}}
- {name: top, type: 1CC, mass: 10000.0, X_WC: {translation: [0.0, 0.0, 3.8865]}}
effects:
  contact: {}
  friction: {}
"""


def _poses(n=20, seed=7):
    rng = np.random.default_rng(seed)
    p = np.column_stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.2, 0.2, n), SIZE[2] - rng.uniform(1e-4, 4e-3, n)])
    return p, np.repeat(np.eye(3)[None], n, axis=0)


def test_a_python_models_force_is_read_and_checked():
    model = load_predictor("bench_models:DoubleForce")
    assert model.has_force and not load_predictor("bench_models:GeometricModel").has_force
    p, R = _poses()
    rows = model.contact_force(p, R, size_A=SIZE, size_B=SIZE)
    from testbed.effects.learned_dynamics.static import static_answer

    exact = static_answer(p, R, SIZE, SIZE)
    assert np.allclose(rows[:, 0], 2 * np.linalg.norm(exact.force, axis=1), rtol=1e-12)
    assert np.allclose(rows[:, 2], exact.area, rtol=1e-12)
    with pytest.raises(PredictorOutputError, match="force_n"):
        load_predictor("bench_models:NaNForce").contact_force(p, R, size_A=SIZE, size_B=SIZE)


def test_an_onnx_models_force_outputs_are_read_and_checked(tmp_path):
    pytest.importorskip("onnxruntime")
    from bench_models import centre_line_onnx

    model = load_predictor(str(centre_line_onnx(tmp_path / "f.onnx", force="area")))
    p, R = _poses(5)
    rows = model.contact_force(p, R, size_A=SIZE, size_B=SIZE)
    assert model.has_force and np.allclose(rows, [[1000.0, 1.0e6, 2.0]] * 5)
    with pytest.raises(WeightsError, match="force_n.*stiffness"):
        load_predictor(str(centre_line_onnx(tmp_path / "g.onnx", force="no_stiffness")))
    assert not load_predictor(str(centre_line_onnx(tmp_path / "h.onnx"))).has_force


def _compression(predictor: str) -> float:
    """[m] the top box's rest compression into the base after 0.3 s (their faces' overlap)."""
    run = run_variant(variant(load_scenario(text=REST), "learned", predictor), 0.3, 10)
    assert not run.error, run.error
    return float(SIZE[2] - (run.p_WB[-1, 0, 2] - 1.2955))


def test_the_loop_applies_the_models_own_force():
    """At rest the force carries the weight: the testbed's exact force and a model answering that
    same force compress alike (the model's path damps at the point only: no surface torque, which
    a level rest does not need); a model answering twice the force and stiffness compresses half."""
    testbed_force = _compression("improved")
    own = _compression("bench_models:ExactForce")
    double = _compression("bench_models:DoubleForce")
    assert testbed_force > 1e-5
    assert own == pytest.approx(testbed_force, rel=1e-3), (own, testbed_force)
    assert double / testbed_force == pytest.approx(0.5, abs=0.02), (double, testbed_force)


def test_the_bench_judges_a_models_own_force_and_says_which_force_drives_it():
    from learned_contact.data.labels import make_dataset
    from testbed.bench.force import force_section, own_force_figures
    from testbed.bench.report import _force, verdict_lines
    from testbed.document import to_markdown

    data = {"stacking": make_dataset("stacking", 120, 535353, progress=False)}
    exact = own_force_figures(load_predictor("bench_models:ExactForce"), data)["stacking"]
    double = own_force_figures(load_predictor("bench_models:DoubleForce"), data)["stacking"]
    assert exact["force_rel_p95"] < 1e-9 and exact["stiffness_rel_p95"] < 1e-5 and exact["zero_answers"] == 0
    assert double["force_rel_median"] == pytest.approx(1.0, abs=1e-9)  # twice the truth: error 100 %
    assert double["stiffness_rel_median"] == pytest.approx(1.0, abs=1e-4)
    entries = {"own": {"label": "own", "verdict": "v", "force_source": "own", "own_force": {"stacking": double}},
               "plain": {"label": "plain", "verdict": "v", "force_source": "testbed"}}
    lines = verdict_lines({"predictors": entries, "leaderboard": ["own", "plain"], "judged": ["own", "plain"]})
    assert "force: its own" in lines[0] and "force: the testbed's" in lines[1]
    text = to_markdown("bench", _force({"force": force_section(data), "predictors": entries}))
    row = next(line for line in text.splitlines() if "stacking (own's own force)" in line)
    assert row.split("|")[3].strip() == "1", row  # its force error median: 100 %
