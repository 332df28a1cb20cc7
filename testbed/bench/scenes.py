"""The bench's scene sections: every predictor in the shipped scenes.

- In-scene, open loop: the scene runs with Drake hydroelastic contact driving it and the
  `learned_contact` effect asking the predictor at every recorded step (the validation
  scene case's comparison): point and normal error against Drake's centre of pressure,
  median and max, per scene.
- Closed loop: the predictor drives the container-container contact (`learned_dynamics`)
  from the same initial state as Drake's hydroelastic truth and point contact, one truth
  run shared by every predictor (testbed.compare.compare_predictors); the closed-loop
  section's gates (testbed.gates.closed_loop) judge each predictor alike.
"""

from __future__ import annotations

import tempfile

from testbed.compare import compare_predictors
from testbed.gates.closed_loop import DEFAULT_SCENES, case_result, judge
from testbed.scenario import load_scenario
from testbed.simulation import run_scenario

OPEN_SCENES = (("two_stack", 1.0), ("five_stack", 1.0), ("bridge", 1.0), ("nine_mixed_stack", 1.0),
               ("crane_misaligned", 3.0), ("yard_small", 1.0))  # yard_small: the poses a yard's stacks take
CLOSED_SCENES = DEFAULT_SCENES  # the validation's closed-loop scenes, each at its own duration
QUICK_OPEN_SCENES = (("two_stack", 0.5),)
QUICK_CLOSED_SCENES = (("two_stack", 1.0), ("crane_misaligned", 2.0), ("overhang_tip", 0.9))  # overhang_tip: where the point decides
OPEN_KEYS = ("learned_vs_hydro_point_error_median_m", "learned_vs_hydro_point_error_max_m",
             "learned_vs_hydro_normal_error_median_deg", "learned_vs_hydro_normal_error_max_deg")


def open_loop(spec: str, scene: str, duration: float) -> dict:
    """In-scene figures of predictor `spec` on `scene` driven by Drake hydroelastic contact."""
    scenario = load_scenario(scene, overrides=["effects.contact.model=hydroelastic", "effects.contact_log={}",
                                               "effects.shadow_contact={}", "effects.learned_contact={}"])
    scenario.effects.learned_contact.predictor = spec
    summary = run_scenario(scenario, duration=duration).summary
    return {"scene": scene, "duration_s": duration,
            **{k.replace("learned_vs_hydro_", ""): summary.get(k) for k in OPEN_KEYS}}


def closed_loop(specs: list[str], scene: str, duration: float) -> dict:
    """{"scene", ..., "predictors": {spec: figures + "gates" + "passed"}} for one scene: every
    predictor against one truth run, judged by testbed.gates.closed_loop."""
    with tempfile.TemporaryDirectory(prefix="bench-closed-") as tmp:
        dirs = [f"{tmp}/{i}" for i in range(len(specs))]
        figures = compare_predictors(scene, list(specs), out_dirs=dirs, duration=duration, with_point=True,
                                     replay=False)
        result = case_result(scene, duration, list(zip(specs, figures, dirs)))
    for f in result["predictors"].values():
        gates = judge(result, f, "")
        f["gates"] = [{"name": g.name, "passed": bool(g.passed), "value": g.value, "threshold": g.threshold,
                       "unit": g.unit, **({"known_limit": True} if g.known_limit is not None else {})} for g in gates]
        f["passed"] = all(g.passed for g in gates)
    return result
