"""Judging your own contact model: load it through the same door the bench uses (bounded in
time and memory, probed for consistency), ask it, and put it in the loop of a shipped scene
against Drake's ground truth. Run: python examples/judge_your_model.py (about 30 s).

The full judgement is one command: `testbed bench my_model:OverlapCentre` (from this folder),
which ranks it beside the shipped predictors and exits 0 only if it is good enough."""

import sys
import tempfile
from pathlib import Path

import numpy as np

from learned_contact import load_predictor
from learned_contact.predictors.poses import relative_pose, rotation_from_rpy
from testbed.compare import compare_scene
from testbed.compare.verdict import judge

sys.path.insert(0, str(Path(__file__).resolve().parent))  # my_model.py beside this script
model = load_predictor("my_model:OverlapCentre")

# One pose from two world poses: a 40 ft box resting on another, yawed 1 deg, 0.3 m along A's x.
R_WA, R_WB = np.eye(3), rotation_from_rpy([[0.0, 0.0, np.radians(1.0)]])[0]
p_AB, R_AB = relative_pose([0.0, 0.0, 1.2955], R_WA, [0.3, 0.0, 3.8865 - 0.001], R_WB)
size = np.array([12.192, 2.438, 2.591])
point_A, normal_A = model.predict(p_AB, R_AB, size_A=size, size_B=size)
print(f"{model.name}: contact point {np.round(point_A[0], 3)} m in A, normal {np.round(normal_A[0], 3)}")

# In the loop: the model drives the container-container contact of a shipped scene; the
# closed-loop gates judge it against Drake hydroelastic from the same initial state.
with tempfile.TemporaryDirectory() as out:
    figures = compare_scene("windy_stack", predictor="my_model:OverlapCentre", out_dir=Path(out) / "cmp",
                            duration=0.3, replay=False, judge=judge)
failed = figures["gates_failed"]
print(f"windy_stack in the loop: {figures['verdict']}, final position {figures['final_position_error_max_m'] * 1e3:.3g} mm "
      f"from the truth; {len(failed)} of {len(figures['gates'])} gates failed {failed}")
