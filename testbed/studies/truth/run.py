"""The truth study: shipped scenes under every rung (rungs.py), then per scene and quantity
(quantities.py) the GCI of two sequences (gci.py), the reference, and the classification.

Per quantity:
  mesh sequence        polygon (L0) -> refined_L1 -> refined_L2, ratio 2 (each level halves
                       the tetrahedra's edges): gci3, uncertainty of refined_L2
  accuracy sequence    the continuous plant at its accuracies, coarsest first, ratio the
                       accuracies' ratio: gci3 with three accuracies (a constant ratio), gci2
                       (assumed order 1, Fs 3) with two: uncertainty of the finest
  reference            the finest rung run: the continuous plant at its finest accuracy,
                       else refined_L2, refined_L1, triangle, half_step (in that order)
  band                 the reference's uncertainty (its sequence's, above), at least the
                       quantity's resolution (quantities.resolution)
  default_error        |f_polygon - f_reference|
  within               default_error <= band
  uncertainty          max(default_error, band): what the gates can take as the absolute
                       uncertainty of the default truth on this quantity
A scene is "converged" when every quantity is within, else "truth-sensitive" (the quantities
outside named with their uncertainty); "unclassified" when the default or the reference rung
did not run.
"""

from __future__ import annotations

import math
import time

from testbed.builder import build_scene
from testbed.gates.closed_loop import DEFAULT_SCENES
from testbed.scenario import load_scenario
from testbed.studies.truth import gci
from testbed.studies.truth.quantities import resolution
from testbed.studies.truth.rungs import DEFAULT_ACCURACIES, RUNGS, base_scenario, continuous_name, expand, run_rung

DEFAULT_RUNG = "polygon"
# (scene, duration [s]): the closed-loop gates' durations where they judge the scene
# (testbed.gates.closed_loop.DEFAULT_SCENES), else the scene's own.
FULL_SCENES = ("overhang_hold", "overhang_tip", "two_stack", "single_drop", "crane_hard_landing",
               "stack_slide_rest", "crane_edge_landing")
QUICK_SCENES = ("overhang_hold", "two_stack")
QUICK_DURATION_S = 0.1


def scene_duration(name: str, scenario, given: float | None, quick: bool) -> float:
    """[s] simulated per rung: `given`, else QUICK_DURATION_S with quick, else the gates'
    duration of the scene (closed_loop.DEFAULT_SCENES), else the scene's own."""
    if given is not None:
        return float(given)
    if quick:
        return QUICK_DURATION_S
    return float(dict(DEFAULT_SCENES).get(name, scenario.duration))


def reference_rung(rows: dict) -> str | None:
    """The finest rung that ran (module doc), or None."""
    ok = [name for name, row in rows.items() if row["status"] == "ok"]
    continuous = sorted((rows[n]["accuracy"], n) for n in ok if rows[n]["kind"] == "continuous")
    if continuous:
        return continuous[0][1]
    return next((n for n in ("refined_L2", "refined_L1", "triangle", "half_step") if n in ok), None)


def _value(rows: dict, rung: str, quantity: str):
    row = rows.get(rung)
    return None if row is None or row["status"] != "ok" else row["quantities"].get(quantity)


def accuracy_gci(rows: dict, quantity: str, f_default, f_reference) -> dict | None:
    """The accuracy sequence's GCI of `quantity` (module doc), or None with fewer than 2 accuracies."""
    runs = sorted((row["accuracy"], name) for name, row in rows.items() if row["kind"] == "continuous")
    if len(runs) < 2:
        return None
    values = [_value(rows, name, quantity) for _, name in runs]  # finest first
    accuracies = [a for a, _ in runs]
    r = accuracies[1] / accuracies[0]
    if len(runs) >= 3:
        result = gci.gci3(values[0], values[1], values[2], r, f_default=f_default, f_reference=f_reference)
        if not math.isclose(accuracies[2] / accuracies[1], r, rel_tol=1e-6):
            result["note"] += f" (accuracy ratios {accuracies[2] / accuracies[1]:g} and {r:g} differ: r = {r:g} used)"
        return result
    return gci.gci2(values[0], values[1], r)


def analyze(rows: dict) -> dict:
    """Per-quantity figures and the scene's classification from its rung rows {name: row}."""
    reference = reference_rung(rows)
    names = []
    for row in rows.values():
        names += [q for q in row["quantities"] if q not in names]
    out = {}
    for q in names:
        f_default, f_ref = _value(rows, DEFAULT_RUNG, q), _value(rows, reference, q) if reference else None
        mesh = gci.gci3(_value(rows, "refined_L2", q), _value(rows, "refined_L1", q), _value(rows, "polygon", q), 2.0,
                        f_default=f_default, f_reference=f_ref)
        acc = accuracy_gci(rows, q, f_default, f_ref)
        if reference is None:
            band_source = None
        elif rows[reference]["kind"] == "continuous":
            band_source = acc
        else:
            band_source = mesh if reference == "refined_L2" else None
        u_ref = band_source["uncertainty"] if band_source else None
        floor = resolution(q, f_ref)
        entry = {"values": {n: _value(rows, n, q) for n in rows}, "default": f_default, "reference": f_ref,
                 "mesh_gci": mesh, "accuracy_gci": acc, "reference_uncertainty": u_ref, "resolution": floor,
                 "band": None, "default_error": None, "within": None, "uncertainty": None}
        if f_default is not None and f_ref is not None:
            band = max(u_ref or 0.0, floor)
            error = abs(f_default - f_ref)
            entry.update(band=band, default_error=error, within=bool(error <= band), uncertainty=max(error, band))
        out[q] = entry
    judged = [e for e in out.values() if e["within"] is not None]
    if not judged or rows.get(DEFAULT_RUNG, {}).get("status") != "ok" or reference is None:
        classification = "unclassified"
    else:
        classification = "converged" if all(e["within"] for e in judged) else "truth-sensitive"
    sensitive = {q: e["uncertainty"] for q, e in out.items() if e["within"] is False}
    return {"reference_rung": reference, "quantities": out, "classification": classification, "sensitive": sensitive}


def run_scene(name: str, scenario, duration: float, rungs, accuracies, cache_dir, *, on_rung=None) -> dict:
    """Every rung of one scene and its analysis: {'scene', 'duration_s', 'time_step_s',
    'default_rung', 'rungs': {rung: run_rung row}, **analyze(...)}."""
    base = base_scenario(scenario, duration)
    rows = {}
    for rung, kind, accuracy in expand(rungs, accuracies):
        rows[rung] = run_rung(rung, kind, base, accuracy=accuracy, cache_dir=cache_dir, source=name)
        if on_rung is not None:
            on_rung(name, rows[rung])
    return {"scene": name, "duration_s": duration, "time_step_s": base.plant.time_step, "default_rung": DEFAULT_RUNG,
            "rungs": rows, **analyze(rows)}


def load_scenes(names, duration: float | None, quick: bool) -> list[tuple[str, object, float]]:
    """[(name, Scenario, duration [s])], every scene loaded and built once before any run: a
    bad scene file is a ScenarioError (one line, exit 2) before anything is simulated."""
    out = []
    for name in names:
        scenario = load_scenario(name)
        d = scene_duration(name, scenario, duration, quick)
        build_scene(base_scenario(scenario, d), name)  # overlaps and effects checked here
        out.append((name, scenario, d))
    return out


def run_study(names, *, rungs=RUNGS, accuracies=DEFAULT_ACCURACIES, duration: float | None = None,
              quick: bool = False, cache_dir, on_rung=None) -> dict:
    """The study over `names` (shipped scene names or scene files); see the module doc."""
    return run_loaded(load_scenes(names, duration, quick), rungs=rungs, accuracies=accuracies, quick=quick,
                      cache_dir=cache_dir, on_rung=on_rung)


def run_loaded(scenes, *, rungs=RUNGS, accuracies=DEFAULT_ACCURACIES, quick: bool = False, cache_dir,
               on_rung=None) -> dict:
    """The study over scenes already loaded (load_scenes): {'study', 'settings', 'wall_s',
    'scenes': [run_scene results]}; cache_dir: where the refined meshes are written."""
    start = time.perf_counter()
    results = [run_scene(n, s, d, rungs, accuracies, cache_dir, on_rung=on_rung) for n, s, d in scenes]
    return {"study": "truth", "settings": {"rungs": list(rungs), "accuracies": [float(a) for a in accuracies],
                                           "quick": bool(quick), "default_rung": DEFAULT_RUNG,
                                           "continuous_rungs": [continuous_name(a) for a in accuracies],
                                           "mesh_refinement_ratio": 2.0, "fs": [gci.FS_CONFIDENT, gci.FS_CAUTIOUS],
                                           "p_range": list(gci.P_RANGE)},
            "wall_s": time.perf_counter() - start, "scenes": results}
