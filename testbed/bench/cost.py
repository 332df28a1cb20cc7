"""The bench's cost section: what one contact answer costs, side by side in one process.

Per predictor, on the same stacking and general poses: seconds per pair asked one pair
per call (a simulator's per-contact call) and batched (every pair of a step in one
call), and the first-call cost (importing learned_contact, loading the model and
answering one pose, in a fresh Python process: what a simulator pays at start-up; the
native core is built at install, so nothing compiles). References measured in the same run:
Drake's point-pair query (set the pose, then query: what the labels cost per pair) and the
shipped improved predictor's compiled path; every figure is also given as a ratio to those
(< 1: cheaper). Drake's query is timed in DRAKE_ROUNDS rounds at least, each kept
("drake_point_pair_rounds_s_per_pair"): the ratios read its fastest, the first screen gives
the spread. For a model the testbed did not ship the model's own call (onnxruntime's
session.run, the Python object's predict) is timed beside the full call, and the wrapper's
share (the per-call bound, the testbed's checks, depth and clipping) is their difference.
The timing itself is learned_contact.evaluation.cost's (the query study and the benchmark
script use the same).
"""

from __future__ import annotations

import numpy as np

from learned_contact.evaluation.cost import drake_point_pair_cost, first_call_s, one_blas_thread, predictor_cost as _timed
from learned_contact.sources import DEFAULT
from testbed.bench.accuracy import covered
from testbed.bench.model import resolve

SINGLE_PAIRS = 200
BATCH = 1000
DRAKE_ROUNDS = 5  # rounds of the reference at least (~3 ms each): its spread in the run, on the first screen


def poses(data: dict, n_single: int = SINGLE_PAIRS, batch: int = BATCH, seed: int = 0):
    """(singles [(p, R, sA, sB)], batched (p, R, sA, sB)) drawn from the stacking and
    general sets of `data` (bench.accuracy.pose_sets)."""
    sets = [data[k] for k in ("stacking", "general") if k in data]
    p, R, sA, sB = (np.concatenate([getattr(d, f) for d in sets]) for f in ("p_AB", "R_AB", "size_A", "size_B"))
    rng = np.random.default_rng(seed)
    rows = rng.choice(len(p), size=batch, replace=batch > len(p))
    batched = tuple(np.ascontiguousarray(a[rows]) for a in (p, R, sA, sB))
    rows = rng.choice(len(p), size=min(n_single, len(p)), replace=False)
    singles = [(p[i].copy(), R[i].copy(), sA[i].copy(), sB[i].copy()) for i in rows]
    return singles, batched


def cost_table(models, data: dict, repeats: int = 3) -> dict:
    """{"predictors": {spec: costs + ratios}, "references": {...}} measured in this process for
    `models` (BenchModels or predictor strings).
    Costs [s per pair] as learned_contact.evaluation.cost.predictor_cost (for a model the testbed did
    not ship: the full call, the model's own call and the wrapper's share); ratios to Drake's
    point-pair query and to the shipped predictor are of the full call, and for such a model also
    of its own call ("model_single_vs_drake_point", "model_batched_vs_drake_point").
    A model that declares fewer container sizes is timed on the poses of its own sizes
    (bench.accuracy.covered; the cost of a pair hardly depends on its pose)."""
    singles, batched = poses(data)
    resolved = {m.spec: m for m in map(resolve, models)}  # loaded once per process (load_predictor)
    asked = {}  # spec -> (BenchModel, its poses); the shipped predictor first: every ratio's reference
    for m in [resolved.get(DEFAULT) or resolve(DEFAULT), *(m for spec, m in resolved.items() if spec != DEFAULT)]:
        own, counts = covered(m.predictor, {k: data[k] for k in ("stacking", "general")})
        asked[m.spec] = (m, (singles, batched) if all(kept == of for kept, of in counts.values()) else poses(own))
    with one_blas_thread():  # every figure side by side in this process; the first call in a fresh one each
        measured = drake_point_pair_cost(singles, max(repeats, DRAKE_ROUNDS))
        drake = measured["set_pose_and_query_s_per_pair"]
        costs = {spec: {"first_call_s": first_call_s(spec), **_timed(m.predictor, *mine, repeats)}
                 for spec, (m, mine) in asked.items()}
    reference = costs[DEFAULT]
    out = {}
    for spec in resolved:
        c = costs[spec]
        out[spec] = {**c,
                     "single_vs_drake_point": c["single_s_per_pair"] / drake,
                     "batched_vs_drake_point": c["batched_s_per_pair"] / drake,
                     "single_vs_improved_compiled": c["single_s_per_pair"] / reference["single_s_per_pair"],
                     "batched_vs_improved_compiled": c["batched_s_per_pair"] / reference["batched_s_per_pair"]}
        if "model_single_s_per_pair" in c:  # the model's own call beside the full one (the same ratios)
            out[spec].update({"model_single_vs_drake_point": c["model_single_s_per_pair"] / drake,
                              "model_batched_vs_drake_point": c["model_batched_s_per_pair"] / drake})
    return {"predictors": out, "references": {
        "drake_point_pair_set_pose_and_query_s_per_pair": drake,
        "drake_point_pair_rounds_s_per_pair": measured["set_pose_and_query_rounds_s_per_pair"],
        "improved_compiled_single_s_per_pair": reference["single_s_per_pair"],
        "improved_compiled_batched_s_per_pair": reference["batched_s_per_pair"],
        "single_pairs": len(singles), "batch": len(batched[0]), "repeats": repeats}}
