"""`bench(specs)`: judge predictors side by side (the Python API behind `testbed bench`).

    from testbed.bench import bench
    data = bench(["my_model.onnx"], quick=True, out_dir="reports/bench")  # + improved and paper beside it

Returns the dict written to bench.json: {"schema", "quick", "seed", "predictors": {spec:
{"label", "kind", "name", "sizes" (what it declares and what that excludes: sizes_entry),
"accuracy", "cost", "in_scene" (figures and testbed.gates.in_scene's gates per scene),
"closed_loop", "verdict"}}, "references", "yard_budget" (testbed.bench.yard_budget),
"leaderboard": [spec, ...] best first}. Every predictor is resolved once (testbed.bench.model:
loaded, its declared sizes read) before anything runs, so a bad file fails first (WeightsError:
exit 2 from the CLI), and that one BenchModel is what every section takes.

A model that declares fewer container sizes (`supported_sizes`) is judged within them: its
accuracy sets are drawn over its own container types' pairs (as many poses), and the scenes it
runs are the listed ones it covers plus, in place of the others, the shipped scenes it covers
(testbed.bench.scenes.choose); the first screen says what was left out and why.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from learned_contact.data.sampling import DEFAULT_TYPES
from learned_contact.sources import SHIPPED_NAMES
from testbed.bench.accuracy import accuracy, pose_sets
from testbed.bench.cost import cost_table
from testbed.bench.force import force_section, own_force_figures, step_cost_rows
from testbed.bench.model import BenchModel, distinct_labels, resolve, uncovered as _uncovered
from testbed.bench.report import write_bench
from testbed.bench.scenes import (
    CLOSED_SCENES,
    OPEN_SCENES,
    QUICK_CLOSED_SCENES,
    QUICK_LEAST_CLOSED,
    QUICK_LEAST_OPEN,
    QUICK_OPEN_SCENES,
    choose,
    pool,
    scene_sections,
)
from testbed.bench.yard_budget import BudgetSettings, yard_budget
from testbed.errors import TestbedError
from testbed.gates import is_known_limit
from testbed.provenance import provenance

SCHEMA = "testbed.bench/1"
DEFAULT_PREDICTORS = SHIPPED_NAMES
# Poses per held-out set: the gates' 400 in both modes (their thresholds are set for it; labelling
# the five sets costs ~8 s on 2 cores), so a quick bench judges accuracy exactly as a full one. A
# model declaring fewer container sizes gets as many, drawn over its own types (bench.accuracy).
N_POSES = 400


def known_limits(entry: dict) -> list[str]:
    """The gates this predictor passes only within a pinned known-limit band (accuracy
    gates by name, in-scene and closed-loop ones as 'scene: gate'): targets it does not meet."""
    out = [g["name"] for g in entry["accuracy"]["gates"] if g["passed"] and is_known_limit(g)]
    out += [f"{s}: {g['name']}" for s, f in entry.get("in_scene", {}).items() for g in f.get("gates", [])
            if g["passed"] and is_known_limit(g)]
    return out + [f"{s}: {g['name']}" for s, f in entry["closed_loop"].items() for g in f["gates"]
                  if g["passed"] and is_known_limit(g)]


def judged(specs) -> list[str]:
    """The models a bench run speaks about: those the user named that the testbed did not
    ship, or, when every one is shipped, all of them (its headline and exit status)."""
    own = [s for s in specs if s not in SHIPPED_NAMES]
    return own or list(specs)


def uncovered(predictor, scene: str) -> str | None:
    """None, or "SCENE: container 'NAME' (type T, size (x, y, z) m) is not a size the model
    declares" for the first container of the scene the predictor (or BenchModel) does not answer."""
    if isinstance(predictor, BenchModel):
        return predictor.uncovered(scene)
    return _uncovered(np.asarray(predictor.supported_sizes, dtype=float), scene)


def sizes_entry(model: BenchModel, open_choice, closed_choice) -> dict:
    """What the model declares and what that excludes (bench.json's per-predictor "sizes"): the
    declared sizes [m] and their shipped types, whether they are every shipped type, the pose sets'
    type pairs, and per scene section the listed scenes skipped (why) and those run in their place."""
    pairs = [f"{a}/{b}" for a in model.types for b in model.types]
    every = [f"{a}/{b}" for a in DEFAULT_TYPES for b in DEFAULT_TYPES]
    return {"declared": model.declared_sizes.tolist(), "text": model.sizes_text(), "types": list(model.types),
            "every_size": model.every_size, "accuracy_pairs": pairs, "accuracy_pairs_of": len(every),
            "in_scene": {"skipped": open_choice[1], "added": open_choice[2]},
            "closed_loop": {"skipped": closed_choice[1], "added": closed_choice[2]}}


def _within_sizes(entry: dict) -> str:
    """'; judged within its declared sizes (...)' for a model that declares fewer sizes, else ''."""
    z = entry.get("sizes")
    if not z or z["every_size"]:
        return ""
    skipped = len(z["in_scene"]["skipped"]) + len(z["closed_loop"]["skipped"])
    added = list(dict.fromkeys(z["in_scene"]["added"] + z["closed_loop"]["added"]))
    return (f"; judged within its declared sizes ({', '.join(z['types']) or 'no shipped type'}: accuracy poses of "
            f"{len(z['accuracy_pairs'])} of {z['accuracy_pairs_of']} type pairs, {skipped} listed scenes skipped"
            + (f", run instead: {', '.join(added)}" if added else "") + ")")


def _verdict(entry: dict) -> tuple[bool, str]:
    """(good enough, one line): every accuracy gate, every in-scene gate and every closed-loop
    scene's gates pass; 'within known limits' when some pass only within their pinned bands
    (targets not met). The cost ratios are of the full call; for a model the testbed did not ship
    its own call's follow."""
    acc, closed = entry["accuracy"], entry["closed_loop"]
    held = [s for s, f in closed.items() if f["passed"]]
    failed = [s for s, f in closed.items() if not f["passed"]]
    in_scene = entry.get("in_scene", {})  # (absent from an entry made before the in-scene gates)
    scene_gates = [g for f in in_scene.values() for g in f.get("gates", [])]
    scene_failed = [s for s, f in in_scene.items() if not f.get("passed", True)]
    cost = entry["cost"]
    good = acc["gates_passed"] == acc["gates_total"] and not failed and not scene_failed
    limits = known_limits(entry)
    good = good and acc["gates_total"] > 0 and bool(closed)  # nothing judged is not good enough
    word = ("GOOD ENOUGH" + (f" WITHIN {len(limits)} KNOWN LIMITS" if limits else "")) if good else "NOT GOOD ENOUGH"
    return good, (f"{word}: accuracy gates {acc['gates_passed']} of "
                  f"{acc['gates_total']} passed, in-scene gates {sum(g['passed'] for g in scene_gates)} of "
                  f"{len(scene_gates)} passed" + (f" (fails {', '.join(scene_failed)})" if scene_failed else "")
                  + f", closed loop {len(held)} of {len(closed)} scenes within gates"
                  + (f" (fails {', '.join(failed)})" if failed else "")
                  + _within_sizes(entry)
                  + (f"; targets not met, held only within pinned bands: {', '.join(limits)}" if good and limits else "")
                  + f", {cost['batched_vs_drake_point']:.2g}x Drake point-pair's cost per pair batched, "
                  f"{cost['single_vs_drake_point']:.2g}x one pair per call"
                  + (f" (the model's own call: {cost['model_batched_vs_drake_point']:.2g}x and "
                     f"{cost['model_single_vs_drake_point']:.2g}x; the rest is the testbed's wrapper)"
                     if "model_single_vs_drake_point" in cost else ""))


def _score(entry: dict) -> tuple:
    """Leaderboard order: good enough first, fewer known limits, then closed-loop scenes held, accuracy gates
    passed, stacking point median, then batched cost."""
    acc = entry["accuracy"]
    return (not entry["good_enough"], len(entry["known_limits"]), -sum(f["passed"] for f in entry["closed_loop"].values()),
            -acc["gates_passed"], acc["sets"].get("stacking", {}).get("point_median_m", float("inf")),
            entry["cost"]["batched_s_per_pair"])


def _sets_per_types(models, seed: int, n: int, workers: int, say) -> dict:
    """{types: pose_sets} for every distinct tuple of declared types (the full sets always: the
    cost section's reference poses)."""
    out = {}
    for types in dict.fromkeys([tuple(DEFAULT_TYPES), *(m.types for m in models if m.types)]):
        say(f"labelling held-out poses ({n} per set) with Drake" + ("" if types == tuple(DEFAULT_TYPES) else
                                                                      f", container types {', '.join(types)} only"))
        out[types] = pose_sets(seed, n, workers=workers, types=types)
    return out


def with_references(specs, references: bool = True) -> list[str]:
    """The specs a bench runs: `specs` (learned_contact.sources strings, each once, in order;
    none: the shipped predictors), then, when `references`, every shipped predictor not named
    (the reference lines beside a user's model: README's promise)."""
    specs = list(dict.fromkeys(str(s) for s in specs)) or list(DEFAULT_PREDICTORS)
    return specs + [s for s in SHIPPED_NAMES if s not in specs] if references else specs


def bench(specs=DEFAULT_PREDICTORS, *, quick: bool = False, out_dir=None, seed: int = 0, workers: int = 2,
          progress: bool = True, references: bool = True) -> dict:
    """Judges each predictor in `specs` (learned_contact.sources strings) the same way, and with
    `references` every shipped predictor not named beside them (with_references); see the module
    docstring. Writes bench.json, summary.md and index.html to out_dir when given."""
    named, specs = with_references(specs, False), with_references(specs, references)
    models = distinct_labels([resolve(s) for s in specs])  # every model loaded (and checked) once, before anything runs
    labels = [m.label for m in models]
    if len(set(labels)) != len(labels):
        raise TestbedError(f"predictors {specs}: two have the same label {labels}; give them distinct file names "
                           "(or distinct metadata names)")
    say = (lambda msg: print(f"bench: {msg}", flush=True)) if progress else (lambda msg: None)
    t0 = time.perf_counter()
    n = N_POSES
    sets = _sets_per_types(models, seed, n, workers, say)
    open_list, closed_list = (QUICK_OPEN_SCENES, QUICK_CLOSED_SCENES) if quick else (OPEN_SCENES, CLOSED_SCENES)
    least_open, least_closed = (QUICK_LEAST_OPEN, QUICK_LEAST_CLOSED) if quick else (None, None)
    open_pool, closed_pool = pool(OPEN_SCENES), pool(CLOSED_SCENES)
    entries, chosen = {}, {}
    for m in models:
        say(f"accuracy: {m.spec}")
        chosen[m.spec] = (choose(m, open_list, open_pool, least_open), choose(m, closed_list, closed_pool, least_closed))
        entries[m.spec] = {"label": m.label, "kind": m.kind, "name": m.name, "sizes": sizes_entry(m, *chosen[m.spec]),
                           "accuracy": accuracy(m, sets.get(m.types, {}), seed)}
    say("force: the law's against Drake's on the shipped types' pose sets")
    force = force_section(sets[tuple(DEFAULT_TYPES)])
    force["step_cost"] = step_cost_rows(budget_s=0.02 if quick else 0.05)
    for m in models:  # a model's own force (its contract's optional outputs) drives its loop: judged too
        entries[m.spec]["force_source"] = "own" if getattr(m.predictor, "has_force", False) else "testbed"
        if entries[m.spec]["force_source"] == "own":
            entries[m.spec]["own_force"] = own_force_figures(m.predictor, sets.get(m.types, {}))
    say("cost per query (side by side, one process)")
    costs = cost_table(models, sets[tuple(DEFAULT_TYPES)], repeats=2 if quick else 3)
    for m in models:
        entries[m.spec]["cost"] = costs["predictors"][m.spec]
    say("yard budget: pairs per 1 ms step beside the host engine's own step (96-container yard)")
    budget = yard_budget(models, BudgetSettings(repeats=2 if quick else 3))
    scenes = scene_sections(models, chosen, say)  # every scene run first, then every gate
    for m in models:
        entries[m.spec].update(scenes[m.spec])
    for s in specs:
        entries[s]["good_enough"], entries[s]["verdict"] = _verdict(entries[s])
        entries[s]["known_limits"] = known_limits(entries[s])
    board = sorted(specs, key=lambda s: _score(entries[s]))
    out = {"schema": SCHEMA, "quick": quick, "seed": seed, "poses_per_set": n, "predictors": entries,
           "references": costs["references"], "force": force, "yard_budget": budget, "leaderboard": board, "judged": judged(named),
           "provenance": provenance(), "wall_s": time.perf_counter() - t0}
    if out_dir is not None:
        write_bench(Path(out_dir), out)
    return out
