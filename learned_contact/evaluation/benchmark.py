"""Speed benchmark (a script, not a test): the predictors against Drake's queries.

    python -m learned_contact.evaluation.benchmark [--n 2048] [--single 300] [--batch 4096] [--first-call] [--onnx FILE]

In ONE process, on the same labelled stacking and general poses (contact guaranteed),
times in microseconds per pair:
- each predictor ("improved", "paper"), compiled (the native core, C: native/src) and numpy
  reference, one pair per call (single pose arrays, as a user's loop would pass them) and
  batched (`--batch` poses per call); for the compiled improved predictor also the bare
  core call of one pair (learned_contact._native.predict on preallocated outputs: what the
  predictor's Python layer adds is the difference);
- where the compiled improved predictor's time goes: its geometry and features alone
  (batched), the rest being the MLP;
- Drake's point-pair query for one pair: the kernel alone (pose already in the context)
  and with the pose set per call; Drake's hydroelastic query with the pose set per call.
Also, on centred stacks (`centred_stacks`: what a yard is made of), the compiled improved
predictor and Drake's point-pair query side by side.
Prints the table and the ratios the issues' targets are stated in (TARGETS), each with its
verdict: met, NOT met, or, for a target pinned as a known limit (KNOWN_COST_LIMITS: the
figure when pinned and a band around it), "known limit" inside the band and "worse than
pinned" / "better than pinned" outside it (tests/learned/test_cost_targets.py holds the
same verdicts on every test run):
  single pair (compiled) / Drake point-pair with the pose set per call   <= 0.5 (was 1)
  batched improved (compiled) / Drake point-pair kernel                  <= 0.25
  batched paper (compiled) / Drake point-pair kernel                     <= 0.05
  centred stacks: batched improved, the core timed in C / Drake kernel   <= 0.5
and the native core's own cost per pair, cc_predict timed in C with no Python between calls
(CORE_TARGETS_US: <= 1 us one pair per call on centred stacks, <= 2 us on the mix; printed
with their verdicts, not tested: they are absolute times). `--onnx FILE` adds an exported
ONNX file (`testbed export-onnx improved FILE`): its full predict and onnxruntime's
session.run alone, one pair per call and batched, for the per-pair table of every path.
`--first-call` also measures, in fresh processes, the import, the load and the first predict
call (the native core needs no compilation at run time: there is no cache to warm).

Timings are best-of-5 minima (least disturbed by other load), by learned_contact.evaluation.cost (the
bench and the query study time with the same code); BLAS is limited to one thread where
threadpoolctl is installed (Drake's queries are single-threaded, and on a 2-core machine two
OpenBLAS pools, numpy's and scipy's, otherwise spin against each other).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from learned_contact.compiled import features as native_features
from learned_contact.compiled.kernels import _native
from learned_contact.data.labels import make_dataset, pair_scene, posed_query
from learned_contact.evaluation.cost import fastest_side_by_side, first_call_s, one_blas_thread, per_pair_s
from learned_contact.predictors.poses import rotation_from_rpy
from learned_contact.sources import SHIPPED_NAMES, load_predictor
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.geometry.boxes import sat_normal

TARGETS = {  # ratio name -> upper bound
    "single improved compiled / drake point-pair set+query": 0.5,
    "centred stacks: single improved compiled / drake point-pair set+query": 0.5,
    "centred stacks: batched improved compiled / drake point-pair kernel": 0.25,
    "single paper compiled / drake point-pair set+query": 1.0,
    "batched improved compiled / drake point-pair kernel": 0.25,
    "batched paper compiled / drake point-pair kernel": 0.05,
    # the native core's own cost, timed in C (no Python between calls)
    "centred stacks: batched improved core in C / drake point-pair kernel": 0.5,
}
# The native core's own cost per pair [us], timed in C (learned_contact._native.time_core): targets
# stated in microseconds, so printed with their verdicts by the script but never asserted
# by a test (tests assert no absolute times; a shared machine's load moves them).
CORE_TARGETS_US = {
    "centred stacks: improved core in C, one pair per call": 1.0,
    "improved core in C, one pair per call": 2.0,
}
# The targets not met, pinned: ratio name -> (figure when pinned, (low, high) band, why). A
# ratio above its band fails (the cost got worse), below it fails too (better: re-pin, or
# drop the pin where the target is met). The bands are a factor of 2 each way of the figure
# measured on the development machine (2 shared cores; the same code measured within +-30 %
# over runs there, more with other jobs beside it, and a CI machine's CPU may favour the core
# or Drake's C++ differently). Re-pinned for the native core (C instead of numba)
# from four runs with drake 1.51.1 (Python 3.11) on a busy machine: batched improved
# 2.5-4.7, centred stacks batched 0.89-1.49, paper batched 0.35-0.51. The one-pair-per-call
# targets are met since (mix 0.24-0.41, centred stacks 0.18-0.29; with numba 0.60-0.66 and
# 0.40-0.66), so their pins went.
# Re-pinned 2026-12-04 (batched improved 3.1 -> 2.4, batched paper 0.43 -> 0.35): measured on the 2-core
# development machine, idle, six runs each: 2.24-2.89 and 0.33-0.37 in wall time, 1.98-2.51 and 0.31-0.37 in
# CPU time (the tests' clock); beside a fresh-clone suite and the main job, CPU time: 1.45-1.54 (below the
# old band's 1.55) and 0.223 (the old band's edge 0.215): contention for the shared core's caches still
# slows Drake's kernel more than the networks there, which the clock cannot remove and the 2x bands cover.
KNOWN_COST_LIMITS: dict[str, tuple[float, tuple[float, float], str]] = {
    "batched improved compiled / drake point-pair kernel": (2.4, (1.2, 4.8), (
        "the target allows 0.32 us per pair; where the faces tilt (most of the mix's general half) the "
        "main network runs, 10,304 multiply-adds on 82 KB of float64 weights (more than the core's L1 "
        "cache): ~2.2 us per evaluation in the native core with AVX on the development machine (3.0 us "
        "without; numba: ~4 us), 0.76 evaluations per pair on the mix; the face-on-face quadrature "
        "where faces meet 1-2 us")),
    "centred stacks: batched improved compiled / drake point-pair kernel": (1.2, (0.6, 2.4), (
        "Drake's own quadrature (16 clipped pairs of triangles and 32 edge strips, what makes the "
        "answer Drake's to 0.05 mm) costs ~1.1 us per pair in the native core, about Drake's whole "
        "box-box point-pair query; the target allows 0.36 us")),
    "centred stacks: batched improved core in C / drake point-pair kernel": (1.2, (0.6, 2.4), (
        "the same cost as the centred stacks' batched call from Python (the call's fixed cost is "
        "shared by 2,048 pairs): Drake's face-on-face quadrature, ~1.1 us per pair, about Drake's "
        "whole point-pair query; the target allows 0.65 us")),
    "batched paper compiled / drake point-pair kernel": (0.35, (0.175, 0.7), (
        "the paper's 6-20-18-4 network costs ~0.5 us per pair in the native core (38 tanh, three "
        "libm angle functions, the separating-axis depth); the target allows 0.06 us")),
}


def _per_pair(fn, repeats: int, pairs: int) -> float:
    """Best-of-5 microseconds per pair of calling fn() `repeats` times on `pairs` pairs each."""
    return per_pair_s(lambda: [fn() for _ in range(repeats)], repeats * pairs, rounds=5) * 1e6


def first_call_costs(kinds=SHIPPED_NAMES) -> dict:
    """{kind: seconds from a fresh interpreter's first import to the first answer} (twice per
    kind: the first run also pays for the file system's cold caches)."""
    out = {}
    for kind in kinds:
        out[f"{kind}, first run"] = first_call_s(kind)
        out[f"{kind}, second run"] = first_call_s(kind)
    return out


def _poses(n: int):
    data = [make_dataset(d, n, 424_242, progress=False) for d in ("stacking", "general")]
    cat = lambda f: np.concatenate([getattr(d, f) for d in data])  # noqa: E731
    return cat("p_AB"), cat("R_AB"), cat("size_A"), cat("size_B")


def centred_stacks(n: int, seed: int = 5150):
    """n centred stacks, what a yard is made of (no Drake): B on A of the same type (1CC, 1AA,
    1AAA), B's centre within 2 cm of A's, yaw within 1 deg, roll and pitch within 0.05 deg,
    overlap 5 um - 0.5 mm log-uniform placed by the separating axis. (p, R, size_A, size_B)."""
    rng = np.random.default_rng(seed)
    sizes = np.array([CONTAINER_TYPES[t].size for t in ("1CC", "1AA", "1AAA")])
    s = sizes[rng.integers(0, len(sizes), n)]
    R = rotation_from_rpy(np.radians(np.c_[rng.uniform(-0.05, 0.05, (n, 2)), rng.uniform(-1.0, 1.0, n)]))
    p = np.c_[rng.uniform(-0.02, 0.02, (n, 2)), s[:, 2]]
    depth = np.exp(rng.uniform(np.log(5e-6), np.log(5e-4), n))
    for _ in range(3):  # the overlap is linear in B's height here: one step lands it, two more polish
        p[:, 2] -= depth - sat_normal(p, R, 0.5 * s, 0.5 * s)[1]
    return p, R, s, s.copy()


def _side_by_side(timed: dict, clock=time.perf_counter_ns) -> dict:
    """{name: us per pair} of {name: (fn, pairs per call of fn)}, every fn called once per round in
    turn over 5 rounds (learned_contact.evaluation.cost.fastest_side_by_side): a ratio of two of
    them compares calls made within milliseconds of each other, so load that comes and goes on
    a shared machine slows both sides alike instead of whichever was timed during it."""
    names = list(timed)
    ns = fastest_side_by_side([timed[k][0] for k in names], rounds=5, clock=clock)
    return {k: t * 1e-3 / timed[k][1] for k, t in zip(names, ns)}


def measure(args, numpy_paths: bool = True, clock=time.perf_counter_ns) -> dict:
    """{what: us per pair} (module docstring); numpy_paths=False leaves out the numpy
    reference paths and Drake's hydroelastic query, which no target names (the cost pins'
    test times only what the targets need). Each target's two sides (a predictor's call and
    Drake's query) are timed side by side (`_side_by_side`) by `clock`: wall time, or
    time.process_time_ns (CPU time: the pins' test, which must hold on a loaded machine)."""
    from pydrake.geometry import HydroelasticContactRepresentation

    p, R, sA, sB = _poses(args.n)
    n = len(p)
    rng = np.random.default_rng(0)
    batch = rng.choice(n, size=args.batch, replace=args.batch > n)
    pb, Rb, sAb, sBb = (np.ascontiguousarray(a[batch]) for a in (p, R, sA, sB))
    idx = rng.choice(n, size=min(args.single, n), replace=False)
    singles = [(p[i].copy(), R[i].copy(), sA[i].copy(), sB[i].copy()) for i in idx]
    code = {tuple(CONTAINER_TYPES[t].size): t for t in ("1CC", "1AA", "1AAA")}
    scenes = {int(i): pair_scene(code[tuple(sA[i])], code[tuple(sB[i])]) for i in idx}
    poly = HydroelasticContactRepresentation.kPolygon
    i0 = int(idx[0])
    q = posed_query(scenes[i0], R[i0], p[i0])
    assert q.ComputePointPairPenetration() and q.ComputeContactSurfaces(poly)  # in contact
    kernel_calls = 2000
    res, timed = {}, {}
    for kind in SHIPPED_NAMES:
        for compiled in (True, False) if numpy_paths else (True,):
            pred = load_predictor(kind, compiled=compiled)
            label = f"{kind} {'compiled' if compiled else 'numpy'}"
            pred.predict(pb, Rb, size_A=sAb, size_B=sBb)  # warm up (caches, the first call's imports)
            one = lambda pred=pred: [pred.predict(a, b, size_A=c, size_B=d) for a, b, c, d in singles]  # noqa: E731
            batched = lambda pred=pred: pred.predict(pb, Rb, size_A=sAb, size_B=sBb)  # noqa: E731
            if compiled:  # a target's side: timed beside Drake's query below
                timed[f"{label}, one pair per call"] = (one, len(singles))
                timed[f"{label}, batched {args.batch}"] = (batched, len(pb))
            else:
                res[f"{label}, one pair per call"] = _per_pair(one, 1, len(singles))
                res[f"{label}, batched {args.batch}"] = _per_pair(batched, 1, len(pb))
    timed["drake point-pair, kernel (query only)"] = (lambda: [q.ComputePointPairPenetration() for _ in range(kernel_calls)],
                                                      kernel_calls)
    timed["drake point-pair, set pose + query"] = (
        lambda: [posed_query(scenes[int(i)], R[i], p[i]).ComputePointPairPenetration() for i in idx], len(idx))
    res.update(_side_by_side(timed, clock))
    fast = load_predictor("improved")
    if fast.compiled:  # the native core is built
        native_features(pb, Rb, sAb, sBb)
        res["improved compiled, geometry + features only, batched"] = _per_pair(
            lambda: native_features(pb, Rb, sAb, sBb), 3, len(pb))
        packed = [(a[None], b[None], c[None], d[None]) for a, b, c, d in singles]
        out = (np.empty((1, 3)), np.empty((1, 3)), np.empty(1))
        res["improved compiled, bare core call, one pair"] = _per_pair(
            lambda: [_native.predict(fast._native, a, b, c, d, *out) for a, b, c, d in packed], 1, len(packed))
        for kind in SHIPPED_NAMES:  # the core's own cost: cc_predict timed in C, no Python per call
            model = load_predictor(kind)._native
            res[f"{kind} core in C, one pair per call"] = _native.time_core(model, pb, Rb, sAb, sBb, 1, 5) * 1e6
            res[f"{kind} core in C, batched {args.batch}"] = _native.time_core(model, pb, Rb, sAb, sBb, args.batch, 5) * 1e6
    if getattr(args, "onnx", None):  # an exported ONNX file (testbed export-onnx improved FILE)
        onnx = load_predictor(str(args.onnx))
        small = slice(0, 96)
        onnx.predict(pb[small], Rb[small], size_A=sAb[small], size_B=sBb[small])
        res["ONNX export, one pair per call"] = _per_pair(
            lambda: [onnx.predict(a, b, size_A=c, size_B=d) for a, b, c, d in singles[:100]], 1, len(singles[:100]))
        res["ONNX export, batched 96"] = _per_pair(
            lambda: onnx.predict(pb[small], Rb[small], size_A=sAb[small], size_B=sBb[small]), 1, 96)
        own = [onnx.own_call(a[None], b[None], c[None], d[None]) for a, b, c, d in singles[:100]]
        with onnx.own_round(5 * len(own) + 5):
            res["ONNX export, session.run alone, one pair per call"] = _per_pair(lambda: [f() for f in own], 1, len(own))
    if numpy_paths:
        res["drake hydroelastic, set pose + query"] = _per_pair(
            lambda: [posed_query(scenes[int(i)], R[i], p[i]).ComputeContactSurfaces(poly) for i in idx[:100]], 1, len(idx[:100]))
    # centred stacks (the quadrature answers them alone, no network runs)
    cp, cR, csA, csB = centred_stacks(args.batch)
    fast.predict(cp, cR, size_A=csA, size_B=csB)
    c_singles = [(cp[i:i + 1].copy(), cR[i:i + 1].copy(), csA[i:i + 1].copy(), csB[i:i + 1].copy())
                 for i in range(min(args.single, len(cp)))]
    c_scenes = [pair_scene(code[tuple(a)], code[tuple(b)]) for a, b in zip(csA[:len(c_singles)], csB[:len(c_singles)])]
    cq = posed_query(c_scenes[0], cR[0], cp[0])
    assert cq.ComputePointPairPenetration()  # in contact
    centred = {
        f"centred stacks: improved compiled, batched {args.batch}": (lambda: fast.predict(cp, cR, size_A=csA, size_B=csB), len(cp)),
        "centred stacks: improved compiled, one pair per call": (
            lambda: [fast.predict(a, b, size_A=c, size_B=d) for a, b, c, d in c_singles], len(c_singles)),
        "centred stacks: drake point-pair, kernel (query only)": (
            lambda: [cq.ComputePointPairPenetration() for _ in range(kernel_calls)], kernel_calls),
        "centred stacks: drake point-pair, set pose + query": (
            lambda: [posed_query(c_scenes[i], cR[i], cp[i]).ComputePointPairPenetration() for i in range(len(c_scenes))],
            len(c_scenes)),
    }
    if fast.compiled:  # the core's own cost, one pass of time_core per round (its fn returns its own clock)
        for label, per_call in (("one pair per call", 1), (f"batched {args.batch}", args.batch)):
            centred[f"centred stacks: improved core in C, {label}"] = (
                lambda per_call=per_call: _native.time_core(fast._native, cp, cR, csA, csB, per_call, 1), len(cp))
    res.update(_side_by_side(centred, clock))
    return res


def ratios(res: dict, batch: int) -> dict:
    """{ratio name: value} of `measure`'s figures (the targets' ratios among them)."""
    pp_set, pp_kernel = res["drake point-pair, set pose + query"], res["drake point-pair, kernel (query only)"]
    out = {}
    for kind in SHIPPED_NAMES:
        out[f"single {kind} compiled / drake point-pair set+query"] = res[f"{kind} compiled, one pair per call"] / pp_set
        out[f"batched {kind} compiled / drake point-pair kernel"] = res[f"{kind} compiled, batched {batch}"] / pp_kernel
        if f"{kind} numpy, batched {batch}" in res:  # measured unless numpy_paths=False
            out[f"batched {kind} numpy / drake point-pair kernel"] = res[f"{kind} numpy, batched {batch}"] / pp_kernel
            out[f"batched {kind}: numpy / compiled"] = res[f"{kind} numpy, batched {batch}"] / res[
                f"{kind} compiled, batched {batch}"]
    out["centred stacks: single improved compiled / drake point-pair set+query"] = (
        res["centred stacks: improved compiled, one pair per call"] / res["centred stacks: drake point-pair, set pose + query"])
    if f"centred stacks: improved core in C, batched {batch}" in res:
        out["centred stacks: batched improved core in C / drake point-pair kernel"] = (
            res[f"centred stacks: improved core in C, batched {batch}"] / res["centred stacks: drake point-pair, kernel (query only)"])
    out["centred stacks: batched improved compiled / drake point-pair kernel"] = (
        res[f"centred stacks: improved compiled, batched {batch}"] / res["centred stacks: drake point-pair, kernel (query only)"])
    return out


def verdicts(rat: dict) -> dict:
    """{ratio name: "met" | "NOT met" | "known limit" | "worse than pinned" | "better than
    pinned"} for every ratio in TARGETS (rat: `ratios`)."""
    out = {}
    for name, target in TARGETS.items():
        if name not in rat:  # the core's own figures need the native core built
            out[name] = "not measured (native core not built)"
            continue
        r = rat[name]
        if name not in KNOWN_COST_LIMITS:
            out[name] = "met" if r <= target else "NOT met"
            continue
        low, high = KNOWN_COST_LIMITS[name][1]
        out[name] = "worse than pinned" if r > high else ("better than pinned" if r < low else "known limit")
    return out


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2048, help="labelled poses per distribution")
    parser.add_argument("--single", type=int, default=300, help="poses timed one per call")
    parser.add_argument("--batch", type=int, default=4096, help="poses per batched call")
    parser.add_argument("--first-call", action="store_true", help="also time first calls in fresh processes")
    parser.add_argument("--onnx", help="also time this ONNX file (e.g. `testbed export-onnx improved improved.onnx`): "
                                       "full predict and session.run alone")
    args = parser.parse_args(argv)
    with one_blas_thread():
        res = measure(args)
    rat = ratios(res, args.batch)
    width = max(len(k) for k in (*res, *rat)) + 2
    print(f"poses: {2 * args.n} labelled (stacking + general); {args.single} one per call; batches of {args.batch}")
    for k, v in res.items():
        print(f"{k:<{width}} {v:10.3f} us/pair")
    print("ratios (target where given):")
    said = verdicts(rat)
    for k, v in rat.items():
        verdict = ""
        if k in TARGETS:
            verdict = f"  target <= {TARGETS[k]:g}: {said[k]}"
            if k in KNOWN_COST_LIMITS:
                figure, (low, high), _ = KNOWN_COST_LIMITS[k]
                verdict += f" (pinned at {figure:g}, band {low:g}-{high:g})"
        print(f"  {k:<{width}} {v:8.3f}{verdict}")
    print("the native core's own cost [us per pair], timed in C (targets in microseconds, not tested):")
    for k, target in CORE_TARGETS_US.items():
        if k in res:
            print(f"  {k:<{width}} {res[k]:8.3f}  target <= {target:g}: {'met' if res[k] <= target else 'NOT met'}")
    out = {"us_per_pair": res, "ratios": rat, "verdicts": said}
    if args.first_call:
        first = first_call_costs()
        print("first call in a fresh process [s]: import learned_contact, load and the first predict")
        for k, seconds in first.items():
            print(f"  {k:<24} {seconds:8.3f}")
        out["first_call_s"] = first
    return out


if __name__ == "__main__":
    main()
