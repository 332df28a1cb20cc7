"""The bench's cost section: what one contact answer costs, side by side in one process.

Per predictor, on the same stacking and general poses: seconds per pair asked one pair
per call (a simulator's per-contact call) and batched (every pair of a step in one
call), and the first-call cost (importing learned_contact, loading the model and
answering one pose, in a fresh Python process: what a simulator pays at start-up, with
numba's on-disk cache as this machine has it). References measured
in the same run: Drake's point-pair query (set the pose, then query: what the labels
cost per pair) and the shipped improved predictor's compiled path; every figure is also
given as a ratio to those (< 1: cheaper). Timings take the best of `repeats` rounds (the
least disturbed by other work on a shared machine).
"""

from __future__ import annotations

import dataclasses
import json
import time

import numpy as np

from learned_contact import limits
from learned_contact.errors import WeightsError
from learned_contact.labels import _pair_scene, _query
from learned_contact.sources import DEFAULT, load_predictor
from testbed.bench.accuracy import covered
from testbed.bodies.containers import CONTAINER_TYPES

SINGLE_PAIRS = 200
BATCH = 1000


def _best(fn, repeats: int, pairs: int) -> float:
    """Best seconds per pair of `fn` over `repeats` rounds."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best / pairs


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


FIRST_CALL = (
    "import json, os, sys, time\n"
    "sys.path.append(os.getcwd())\n"
    "t0 = time.perf_counter()\n"
    "import numpy as np\n"
    "from learned_contact import limits, load_predictor\n"
    "limits.set_limits(**json.loads(sys.argv[2]))\n"
    "pred = load_predictor(sys.argv[1])\n"
    "size = pred.supported_sizes[0]\n"
    "pred.predict(np.array([0.0, 0.0, size[2] - 0.005]), np.eye(3), size_A=size, size_B=size)\n"
    "print(time.perf_counter() - t0)\n"
)


def first_call_cost(spec: str) -> float:
    """Seconds from a fresh interpreter's first import to the first answer of `spec` (the
    child sees this process's sys.path, so a Python model found here is found there)."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    bound = limits.limits()
    # the model's own load bound twice (vetting child, then this process), one call, and a
    # minute for the interpreter and numba's cache
    timeout = 2 * bound.load_timeout_s + bound.call_timeout_s + 60.0
    try:
        proc = subprocess.run([sys.executable, "-c", FIRST_CALL, spec, json.dumps(dataclasses.asdict(bound))],
                              capture_output=True, text=True, timeout=timeout, env=env, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        raise WeightsError(f"model {spec}: its first call in a fresh process took longer than {timeout:g} s "
                           "(twice --model-load-timeout, --model-call-timeout and 60 s) and was stopped") from None
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        raise WeightsError(f"model {spec}: its first call in a fresh process failed: {tail[:300]}")
    try:
        return float(proc.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        raise WeightsError(f"model {spec}: its first call in a fresh process printed no time "
                           f"(its output: {proc.stdout.strip()[-200:]!r})") from None


def predictor_cost(spec: str, singles, batched, repeats: int = 3) -> dict:
    """{"first_call_s", "single_s_per_pair", "batched_s_per_pair"} of the predictor `spec`."""
    pred = load_predictor(spec)
    first = first_call_cost(spec)
    pb, Rb, sAb, sBb = batched
    pred.predict(pb, Rb, size_A=sAb, size_B=sBb)  # warm
    return {
        "first_call_s": first,
        "single_s_per_pair": _best(lambda: [pred.predict(a, b, size_A=c, size_B=d) for a, b, c, d in singles],
                                   repeats, len(singles)),
        "batched_s_per_pair": _best(lambda: pred.predict(pb, Rb, size_A=sAb, size_B=sBb), repeats, len(pb)),
    }


def drake_point_cost(singles, repeats: int = 3) -> float:
    """Seconds per pair of Drake's point-pair query, pose set each time (labels' pair plants)."""

    code = {tuple(np.round(t.size, 3)): name for name, t in CONTAINER_TYPES.items()}
    scenes = [_pair_scene(code[tuple(np.round(a, 3))], code[tuple(np.round(b, 3))]) for _, _, a, b in singles]
    for scene, (p, R, _, _) in zip(scenes[:3], singles):  # build and warm
        _query(scene, R, p).ComputePointPairPenetration()
    return _best(lambda: [_query(s, R, p).ComputePointPairPenetration() for s, (p, R, _, _) in zip(scenes, singles)],
                 repeats, len(singles))


def cost_table(specs: list[str], data: dict, repeats: int = 3) -> dict:
    """{"predictors": {spec: costs + ratios}, "references": {...}} measured in this process.
    A model that declares fewer container sizes is timed on the poses of its own sizes
    (bench.accuracy.covered; the cost of a pair hardly depends on its pose)."""
    singles, batched = poses(data)
    reference = predictor_cost(DEFAULT, singles, batched, repeats)
    drake = drake_point_cost(singles, repeats)
    out = {}
    for spec in specs:
        own, counts = covered(load_predictor(spec), {k: data[k] for k in ("stacking", "general")})
        mine = (singles, batched) if all(kept == of for kept, of in counts.values()) else poses(own)
        c = reference if spec == DEFAULT else predictor_cost(spec, *mine, repeats)
        out[spec] = {**c,
                     "single_vs_drake_point": c["single_s_per_pair"] / drake,
                     "batched_vs_drake_point": c["batched_s_per_pair"] / drake,
                     "single_vs_improved_compiled": c["single_s_per_pair"] / reference["single_s_per_pair"],
                     "batched_vs_improved_compiled": c["batched_s_per_pair"] / reference["batched_s_per_pair"]}
    return {"predictors": out, "references": {
        "drake_point_pair_set_pose_and_query_s_per_pair": drake,
        "improved_compiled_single_s_per_pair": reference["single_s_per_pair"],
        "improved_compiled_batched_s_per_pair": reference["batched_s_per_pair"],
        "single_pairs": len(singles), "batch": len(batched[0]), "repeats": repeats}}
