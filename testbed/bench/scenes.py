"""The bench's scene sections: every predictor in the shipped scenes its sizes allow.

`scene_sections` runs both sections for every model, then judges them:
- In-scene, open loop (testbed.compare.in_scene_figures): the scene runs with Drake hydroelastic contact
  driving it and the `learned_contact` effect asking the predictor at every recorded step (the
  validation scene case's comparison): point and normal error against Drake's centre of
  pressure, median and max, judged by testbed.gates.in_scene (the scene case's bound). The
  same function measures `testbed compare`'s figures["in_scene"].
- Closed loop: the predictor drives the container-container contact (`learned_dynamics`)
  from the same initial state as Drake's hydroelastic truth and point contact, one truth
  run shared by every predictor (testbed.compare.compare_predictors); the closed-loop
  section's gates (testbed.gates.closed_loop) judge each predictor alike.

Which scenes (`choose`): a model that declares every size a listed scene holds runs the fixed
lists (OPEN_SCENES / CLOSED_SCENES; quick: QUICK_OPEN_SCENES / QUICK_CLOSED_SCENES). A model
that declares fewer sizes runs the listed scenes it covers and, in place of the others, every
other shipped scene with a container pair whose containers are all of its declared sizes (each
at its own duration; the yard scenes for a 40 ft model), or in quick mode the cheapest of them
(containers x simulated seconds) until it has QUICK_LEAST_OPEN / QUICK_LEAST_CLOSED scenes.
"""

from __future__ import annotations

import tempfile

from testbed.bench.model import BenchModel, scene_containers
from testbed.compare.in_scene import in_scene_figures
from testbed.compare.twin import compare_predictors
from testbed.gates.closed_loop import DEFAULT_SCENES, case_result, judge
from testbed.gates.in_scene import in_scene_gates
from testbed.scenario import load_scenario, shipped_scenes

OPEN_SCENES = (("two_stack", 1.0), ("five_stack", 1.0), ("bridge", 1.0), ("nine_mixed_stack", 1.0),
               ("crane_misaligned", 3.0), ("yard_small", 1.0))  # yard_small: the poses a yard's stacks take
CLOSED_SCENES = DEFAULT_SCENES  # the validation's closed-loop scenes, each at its own duration
QUICK_OPEN_SCENES = (("two_stack", 0.5),)
QUICK_CLOSED_SCENES = (("two_stack", 1.0), ("crane_misaligned", 2.0), ("overhang_tip", 0.9))  # overhang_tip: where the point decides
QUICK_LEAST_OPEN, QUICK_LEAST_CLOSED = 1, 2  # quick mode: scenes at least, when that many are allowed
OPEN_KEYS = ("point_error_median_m", "point_error_max_m", "normal_error_median_deg", "normal_error_max_deg")


def cost(scene: str, duration: float) -> float:
    """A scene's cost proxy: containers x simulated seconds (each container's dynamics per step)."""
    return len(scene_containers(scene)) * duration


def pool(listed) -> list[tuple[str, float]]:
    """`listed` ((scene, duration) pairs) and then every other shipped scene with two or more
    containers, at its own duration."""
    names = {s for s, _ in listed}
    extra = [(name, float(load_scenario(name).duration)) for name in shipped_scenes()
             if name not in names and len(scene_containers(name)) >= 2]
    return [*listed, *extra]


def choose(model: BenchModel, listed, candidates, least: int | None) -> tuple[list, list, list]:
    """(scenes [(scene, duration)], skipped [why, per listed scene it does not cover], added
    [scene, run in their place]) for `model`: the `listed` scenes when it covers them all; else
    the listed ones it covers and, from `candidates` (pool(...)), every other scene it covers
    (least None) or the cheapest ones (`cost`) until it has `least`."""
    skipped = [why for why in (model.uncovered(s) for s, _ in listed) if why]
    if not skipped:
        return list(listed), [], []
    kept = [(s, d) for s, d in listed if model.uncovered(s) is None]
    names = {s for s, _ in listed}
    others = [(s, d) for s, d in candidates if s not in names and model.uncovered(s) is None]
    if least is not None:
        others = sorted(others, key=lambda sd: cost(*sd))[:max(0, least - len(kept))]
    return kept + others, skipped, [s for s, _ in others]


def scene_sections(models, chosen: dict, say=lambda msg: None) -> dict:
    """{spec: {"in_scene": {scene: figures + "gates" + "passed"}, "closed_loop": {scene: figures +
    "gates" + "passed" + "duration_s"}}} for `models` (BenchModels), each running the scenes of
    chosen[spec] = (open-loop choice, closed-loop choice) (`choose`'s). Every run first: in scene
    (open loop) per model and scene (in_scene_figures), and per closed-loop scene every model that
    runs it against one truth run (compare_predictors); then every gate, testbed.gates.in_scene's
    and testbed.gates.closed_loop's, on what those runs recorded. say: a progress line."""
    opened = []  # (spec, scene, in-scene figures)
    for m in models:
        for scene, duration in chosen[m.spec][0][0]:
            say(f"in-scene (open loop): {m.spec} on {scene}")
            opened.append((m.spec, scene, in_scene_figures(scene, m.spec, duration)))
    runs: dict = {}  # (scene, duration) -> the specs that run it, in the order chosen
    for m in models:
        for scene_duration in chosen[m.spec][1][0]:
            runs.setdefault(scene_duration, []).append(m.spec)
    out = {m.spec: {"in_scene": {}, "closed_loop": {}} for m in models}
    with tempfile.TemporaryDirectory(prefix="bench-closed-") as tmp:
        closed = []  # (scene, duration, [(spec, figures, directory)])
        for k, ((scene, duration), specs) in enumerate(runs.items()):
            say(f"closed loop: {scene} ({duration:g} s), every predictor against one truth run")
            dirs = [f"{tmp}/{k}/{i}" for i in range(len(specs))]
            figures = compare_predictors(scene, specs, out_dirs=dirs, duration=duration, with_point=True, replay=False)
            closed.append((scene, duration, list(zip(specs, figures, dirs))))
        for spec, scene, f in opened:
            gates = [g.to_dict() for g in in_scene_gates(f)]
            out[spec]["in_scene"][scene] = {**f, "gates": gates, "passed": all(g["passed"] for g in gates)}
        for scene, duration, judged_runs in closed:
            result = case_result(scene, duration, judged_runs)
            for spec, f in result["predictors"].items():
                gates = judge(result, f, "")
                f["gates"] = [{"name": g.name, "passed": bool(g.passed), "value": g.value, "threshold": g.threshold,
                               "unit": g.unit, **({"known_limit": True} if g.known_limit is not None else {})}
                              for g in gates]
                f["passed"] = all(g.passed for g in gates)
                out[spec]["closed_loop"][scene] = {**f, "duration_s": result["duration_s"]}
    return out
