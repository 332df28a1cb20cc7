"""The shipped cube-toss parameter files (testbed/calibration/cube_toss_<model>.yaml): they
evaluate to the README's figures, stay inside a pinned band, are judged against the calibration's
11% target, and work as scenes. The slow tests share one evaluation per file.

Tolerances (and why) are stated at each assertion.
"""

import re

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from test_calibration import CALIBRATION_DIR, DATA, DT, _simulated, _synthetic_toss  # noqa: E402  (shared helpers)

from testbed.calibration.data import load_tosses
from testbed.calibration.evaluate import RolloutPool
from testbed.calibration.params_file import from_fragment
from testbed.calibration.rollout import TossSimulator, initial_velocity
from testbed.calibration.split import train_test_split


def _readme_figures():
    """{model: {'test', 'train', 'all': position error mean [fraction]}} from the README
    table rows '| `cube_toss_<model>.yaml` | held-out | train | all 275 | ...'."""
    text = (CALIBRATION_DIR / "README.md").read_text()
    out = {}
    for model in ("point", "hydroelastic"):
        row = re.search(rf"^\| `cube_toss_{model}.yaml` \|(.*)$", text, re.MULTILINE)
        cells = [c.strip() for c in row.group(1).split("|")]
        out[model] = {"test": float(cells[0].rstrip("%")) / 100, "train": float(cells[1].rstrip("%")) / 100,
                      "all": float(cells[2].rstrip("%")) / 100}
    return out


TARGET = 0.11  # the calibration target: held-out position error <= 11% of the cube width, for each contact model
# Held-out errors of the shipped files when they were shipped, plus 0.3 percentage points:
# a refit or a code change that makes a shipped file worse than this fails for real, while
# the 11% target itself is an expected failure (xfail below) until a file reaches it.
HELD_OUT_CEILING = {"point": 0.1238 + 0.003, "hydroelastic": 0.1297 + 0.003}


@pytest.fixture(scope="module")
def shipped_evaluation():
    """model -> {'test', 'train', 'all': position error mean [cube widths]} of the shipped
    file on the shipped data (testbed/calibration/cube_tosses/even.npz), split 0.5 seed 0; each file is evaluated once per module."""
    from testbed.calibration.evaluate import summarize

    cache = {}

    def figures(model):
        if model not in cache:
            params = from_fragment(CALIBRATION_DIR / f"cube_toss_{model}.yaml")
            data = load_tosses(DATA)
            train, test = train_test_split(data.tosses, 0.5, 0)
            with RolloutPool(data, 2) as pool:
                results = pool.evaluate(params)
            cache[model] = {name: summarize([results[i] for i in indices], 0)["position_error_mean"]
                            for name, indices in (("test", test), ("train", train), ("all", range(len(results))))}
        return cache[model]

    return figures


# How far the README's figures may move on another machine, as a
# fraction of the cube width. On one machine the evaluation is bitwise repeatable: per-toss
# errors identical with 1 or 2 rollout workers and with OMP/OPENBLAS/MKL/NUMBA threads unset,
# 1 or 4 (results are placed by toss index, not by arrival). Between machines, CPU-dependent
# rounding (SIMD kernels, libm) differs, and impacts amplify it: another machine gave 12.99%
# held-out for hydroelastic against the README's 12.97%. Measured proxy: each toss's first
# position moved by a uniform +-1e-15 m per axis (a few ulps), six seeds plus the unperturbed
# run. Hydroelastic: held-out 12.934..12.981% (std sigma = 1.6e-4), train std 9.9e-5, all
# std 8.9e-5; point: std <= 8.5e-7 on every split (its rollouts barely depend on rounding).
# Tolerance = the README's rounding (5e-5) + 3 * sqrt(2) * sigma (two independent machines,
# each one sample), sigma the largest split's: hydroelastic 5e-5 + 6.9e-4 -> 8e-4; point
# 5e-5 + 3.6e-6 -> 1e-4. Seven samples: the std is known to about +-30%.
README_FIGURE_TOLERANCE = {"point": 1e-4, "hydroelastic": 8e-4}


@pytest.mark.slow
@pytest.mark.parametrize("model", ["point", "hydroelastic"])
def test_shipped_parameters_evaluate_to_the_readme_figures(model, shipped_evaluation):
    """Same code, same data: the figures must agree with the README to the README's rounding
    plus the spread that rounding differences between machines cause (README_FIGURE_TOLERANCE)."""
    figures, readme = shipped_evaluation(model), _readme_figures()[model]
    for split in ("test", "train", "all"):
        assert figures[split] == pytest.approx(readme[split], abs=README_FIGURE_TOLERANCE[model]), split


@pytest.mark.slow
@pytest.mark.parametrize("model", ["point", "hydroelastic"])
def test_shipped_held_out_error_stays_in_its_band(model, shipped_evaluation):
    assert shipped_evaluation(model)["test"] <= HELD_OUT_CEILING[model]


@pytest.mark.slow
@pytest.mark.parametrize("model", [
    pytest.param("point", marks=pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
        "target not reached: held-out 12.38% (see testbed/calibration/README.md, 'Why not 11%')"))),
    pytest.param("hydroelastic", marks=pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
        "target not reached: held-out 12.97% (see testbed/calibration/README.md, 'Why not 11%')"))),
])
def test_shipped_parameters_meet_the_11_percent_target(model, shipped_evaluation):
    """The calibration target, on tosses the fit never saw (the first-frame protocol)."""
    assert shipped_evaluation(model)["test"] <= TARGET


@pytest.mark.parametrize("model", ["point", "hydroelastic"])
def test_shipped_fragment_as_a_scene_reproduces_the_rollout(model):
    """The params file is a scene: built by the scene builder and started from a toss's first
    state, it must follow the rollout's plant (same SDF text, same plant config) to 1e-9 m."""
    from pydrake.math import RigidTransform
    from pydrake.multibody.math import SpatialVelocity
    from pydrake.systems.analysis import Simulator

    from testbed.builder import build_scene
    from testbed.scenario import load_scenario

    path = CALIBRATION_DIR / f"cube_toss_{model}.yaml"
    params = from_fragment(path)
    toss = _simulated([_synthetic_toss(0, [0, 0, 0.15], [10, 20, 0], [4, 1, 0], [1.0, 0.2, -0.5], 40)], params)[0]
    p_rollout, _ = TossSimulator(params, DT).rollout(toss)
    scene = build_scene(load_scenario(path))
    simulator = Simulator(scene.diagram)
    context = simulator.get_mutable_context()
    plant_context = scene.plant.GetMyMutableContextFromRoot(context)
    body = scene.bodies["cube"]
    scene.plant.SetFreeBodyPose(plant_context, body, RigidTransform(Quaternion(toss.q_WB[0]), toss.p_WB[0]))
    w, v = initial_velocity(toss)
    scene.plant.SetFreeBodySpatialVelocity(plant_context, body, SpatialVelocity(w=w, v=v))
    simulator.Initialize()
    simulator.AdvanceTo(float(toss.t[-1]))
    p_scene = scene.plant.EvalBodyPoseInWorld(plant_context, body).translation()
    assert np.linalg.norm(p_scene - p_rollout[-1]) < 1e-9
