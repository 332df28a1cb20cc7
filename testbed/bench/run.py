"""`bench(specs)`: judge predictors side by side (the Python API behind `testbed bench`).

    from testbed.bench import bench
    data = bench(["improved", "paper", "my_model.onnx"], quick=True, out_dir="reports/bench")

Returns the dict written to bench.json: {"schema", "quick", "seed", "predictors": {spec:
{"label", "kind", "name", "accuracy", "cost", "in_scene", "closed_loop", "verdict"}},
"references", "yard_budget" (testbed.bench.yard_budget), "leaderboard": [spec, ...] best first}. Every predictor is loaded first,
so a bad file fails before anything runs (WeightsError: exit 2 from the CLI).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from learned_contact.interface import SIZE_TOLERANCE
from learned_contact.sources import SHIPPED_NAMES, label, load_predictor
from testbed.bench.accuracy import accuracy, pose_sets
from testbed.bench.cost import cost_table
from testbed.bench.report import write_bench
from testbed.bench.scenes import CLOSED_SCENES, OPEN_SCENES, QUICK_CLOSED_SCENES, QUICK_OPEN_SCENES, closed_loop, open_loop
from testbed.bench.yard_budget import BudgetSettings, yard_budget
from testbed.errors import TestbedError
from testbed.gates import is_known_limit
from testbed.provenance import provenance
from testbed.scenario import load_scenario

SCHEMA = "testbed.bench/1"
DEFAULT_PREDICTORS = SHIPPED_NAMES
# Poses per held-out set: the gates' 400 in both modes (their thresholds are set for it; labelling
# the five sets costs ~8 s on 2 cores), so a quick bench judges accuracy exactly as a full one.
N_POSES = 400


def known_limits(entry: dict) -> list[str]:
    """The gates this predictor passes only within a pinned known-limit band (accuracy
    gates by name, closed-loop ones as 'scene: gate'): targets it does not meet."""
    out = [g["name"] for g in entry["accuracy"]["gates"] if g["passed"] and is_known_limit(g)]
    return out + [f"{s}: {g['name']}" for s, f in entry["closed_loop"].items() for g in f["gates"]
                  if g["passed"] and is_known_limit(g)]


def judged(specs) -> list[str]:
    """The models a bench run speaks about: those the user named that the testbed did not
    ship, or, when every one is shipped, all of them (its headline and exit status)."""
    own = [s for s in specs if s not in SHIPPED_NAMES]
    return own or list(specs)


def uncovered(predictor, scene: str) -> str | None:
    """None, or "SCENE: container 'NAME' (type T, size (x, y, z) m) is not a size the model
    declares" for the first container of the scene the predictor does not answer."""
    supported = np.asarray(predictor.supported_sizes, dtype=float).reshape(-1, 3)
    for c in load_scenario(scene).containers:
        size = np.asarray(c.container_type().size, dtype=float)
        if np.abs(supported - size).max(axis=1).min() > SIZE_TOLERANCE:
            return (f"{scene}: container '{c.name}' (type {c.type}, size {tuple(round(float(v), 3) for v in size)} m) "
                    "is not a size the model declares")
    return None


def _uncovered_sets(acc: dict) -> list[str]:
    return [f"accuracy set {name}: {kept} of {of} poses have sizes the model declares" + ("" if kept else " (not judged)")
            for name, (kept, of) in acc["coverage"].items() if kept < of]


def _verdict(entry: dict) -> tuple[bool, str]:
    """(good enough, one line): every accuracy gate and every closed-loop scene's gates pass;
    'within known limits' when some pass only within their pinned bands (targets not met). The
    cost ratios are of the full call; for a model the testbed did not ship its own call's follow."""
    acc, closed = entry["accuracy"], entry["closed_loop"]
    held = [s for s, f in closed.items() if f["passed"]]
    failed = [s for s, f in closed.items() if not f["passed"]]
    cost = entry["cost"]
    good = acc["gates_passed"] == acc["gates_total"] and not failed
    limits = known_limits(entry)
    good = good and acc["gates_total"] > 0 and bool(closed)  # nothing judged is not good enough
    word = ("GOOD ENOUGH" + (f" WITHIN {len(limits)} KNOWN LIMITS" if limits else "")) if good else "NOT GOOD ENOUGH"
    return good, (f"{word}: accuracy gates {acc['gates_passed']} of "
                  f"{acc['gates_total']} passed, closed loop {len(held)} of {len(closed)} scenes within gates"
                  + (f" (fails {', '.join(failed)})" if failed else "")
                  + (f"; not covered: {len(entry['not_covered'])} (the model declares fewer container sizes)"
                     if entry.get("not_covered") else "")
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
            -acc["gates_passed"], acc["sets"]["stacking"]["point_median_m"], entry["cost"]["batched_s_per_pair"])


def bench(specs=DEFAULT_PREDICTORS, *, quick: bool = False, out_dir=None, seed: int = 0, workers: int = 2,
          progress: bool = True) -> dict:
    """Judges each predictor in `specs` (learned_contact.sources strings) the same way; see
    the module docstring. Writes bench.json, summary.md and index.html to out_dir when given."""
    specs = list(dict.fromkeys(str(s) for s in specs)) or list(DEFAULT_PREDICTORS)
    labels = [label(s) for s in specs]
    if len(set(labels)) != len(labels):
        raise TestbedError(f"predictors {specs}: two have the same label {labels}; give them distinct file names")
    say = (lambda msg: print(f"bench: {msg}", flush=True)) if progress else (lambda msg: None)
    loaded = {s: load_predictor(s) for s in specs}  # every model checked before anything runs
    t0 = time.perf_counter()
    n = N_POSES
    say(f"labelling held-out poses ({n} per set) with Drake")
    data = pose_sets(seed, n, workers=workers)
    entries = {}
    for s in specs:
        say(f"accuracy: {s}")
        entries[s] = {"label": label(s), "kind": getattr(loaded[s], "kind", "?"),
                      "name": getattr(loaded[s], "name", label(s)), "accuracy": accuracy(loaded[s], data, seed)}
    say("cost per query (side by side, one process)")
    costs = cost_table(specs, data, repeats=2 if quick else 3)
    for s in specs:
        entries[s]["cost"] = costs["predictors"][s]
    say("yard budget: pairs per 1 ms step beside the host engine's own step (96-container yard)")
    budget = yard_budget(specs, BudgetSettings(repeats=2 if quick else 3))
    for s in specs:
        entries[s]["in_scene"], entries[s]["not_covered"] = {}, _uncovered_sets(entries[s]["accuracy"])
        for scene, duration in (QUICK_OPEN_SCENES if quick else OPEN_SCENES):
            missing = uncovered(loaded[s], scene)
            if missing:
                entries[s]["not_covered"].append(missing)
                continue
            say(f"in-scene (open loop): {s} on {scene}")
            entries[s]["in_scene"][scene] = open_loop(s, scene, duration)
    for s in specs:
        entries[s]["closed_loop"] = {}
    for scene, duration in (QUICK_CLOSED_SCENES if quick else CLOSED_SCENES):
        able = []
        for s in specs:
            missing = uncovered(loaded[s], scene)
            if missing:
                entries[s]["not_covered"].append(f"closed loop: {missing}")
            else:
                able.append(s)
        if not able:
            continue
        say(f"closed loop: {scene} ({duration:g} s), every predictor against one truth run")
        result = closed_loop(able, scene, duration)
        for s in able:
            entries[s]["closed_loop"][scene] = {**result["predictors"][s], "duration_s": result["duration_s"]}
    for s in specs:
        entries[s]["good_enough"], entries[s]["verdict"] = _verdict(entries[s])
        entries[s]["known_limits"] = known_limits(entries[s])
    board = sorted(specs, key=lambda s: _score(entries[s]))
    out = {"schema": SCHEMA, "quick": quick, "seed": seed, "poses_per_set": n, "predictors": entries,
           "references": costs["references"], "yard_budget": budget, "leaderboard": board, "judged": judged(specs),
           "provenance": provenance(), "wall_s": time.perf_counter() - t0}
    if out_dir is not None:

        write_bench(Path(out_dir), out)
    return out
