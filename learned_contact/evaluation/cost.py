"""What a contact query costs: the one timing code behind the bench's cost section
(testbed.bench.cost), the query study (testbed/studies/query) and the benchmark script
(learned_contact.evaluation.benchmark).

- `fastest_ns(fn, repeats)`: the fastest of `repeats` calls [ns], the cost of the call
  without interference from other processes on shared cores (the caller warms up first);
- `per_pair_s(fn, pairs, rounds)`: the fastest round [s] divided by the pairs it answers;
- `one_blas_thread()`: numpy's BLAS limited to one thread while timing (threadpoolctl): Drake's
  queries are single-threaded, and on 2 shared cores a threaded BLAS made batched calls 10x
  slower and erratic;
- `fastest_side_by_side(fns, rounds, clock)`: the fastest call [ns] of each function, their
  rounds interleaved (what the machine's load does to one it does to all); wall time, or the
  process's CPU time for a gate that must hold on an oversubscribed machine;
- `predictor_cost(pred, singles, batched)`: seconds per pair asked one pair per call (a
  simulator's per-contact call) and batched (every pair of a step in one call); for a model
  the testbed did not ship also its own call alone and the wrapper's share (the difference);
- `drake_point_pair_cost(singles)`: Drake's point-pair query per pair, with the pose set per
  call (its fastest round and every round: the reference's spread in the run) and the query
  alone (the reference every ratio is stated against);
- `first_call_s(spec)`: import, load and the first answer in a fresh interpreter (what a
  simulator pays at start-up), under learned_contact.predictors.limits' bounds.

Poses: `singles` is a list of (p_AB (3,) [m], R_AB (3, 3), size_A (3,), size_B (3,)) and
`batched` one tuple of (n, 3), (n, 3, 3), (n, 3), (n, 3) arrays. Absolute times depend on the
machine: state ratios measured in the same run.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

from learned_contact.data.labels import pair_scene, posed_query
from learned_contact.errors import WeightsError
from learned_contact.predictors import limits
from testbed.bodies.containers import CONTAINER_TYPES

ROUNDS = 3  # timing rounds; the fastest counts


def fastest_ns(fn, repeats: int) -> float:
    """Fastest wall time [ns] of `repeats` calls of fn()."""
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        fn()
        best = min(best, time.perf_counter_ns() - t0)
    return float(best)


def fastest_side_by_side(fns, rounds: int, clock=time.perf_counter_ns) -> list[float]:
    """The fastest time [ns] of each function of no arguments in `fns`, over `rounds` rounds
    that each call every function once in turn. clock: wall time by default (what a caller
    waits); time.process_time_ns counts the CPU time of the process's threads instead, which
    time another process takes from shared cores does not inflate (for single-threaded calls
    the two agree on an idle machine)."""
    best = [math.inf] * len(fns)
    for _ in range(rounds):
        for i, fn in enumerate(fns):
            t0 = clock()
            fn()
            best[i] = min(best[i], clock() - t0)
    return [float(b) for b in best]


def per_pair_s(fn, pairs: int, rounds: int = ROUNDS) -> float:
    """Seconds per pair of fn(), which answers `pairs` pairs: its fastest of `rounds` calls."""
    return fastest_ns(fn, rounds) * 1e-9 / pairs


@contextlib.contextmanager
def one_blas_thread():
    """numpy's BLAS on one thread inside the block (threadpoolctl); yields 1, or a note
    when threadpoolctl is not installed (the timing is then not limited)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        yield "not limited (threadpoolctl not installed)"
        return
    with threadpool_limits(limits=1):
        yield 1


def predictor_cost(pred, singles, batched, rounds: int = ROUNDS) -> dict:
    """{"single_s_per_pair", "batched_s_per_pair"} [s] of a loaded predictor on the same poses:
    its full predict call. For a model the testbed did not ship
    (learned_contact.predictors.external.ExternalPredictor, which has `own_call`) also, timed
    side by side with it (rounds interleaved): "model_single_s_per_pair",
    "model_batched_s_per_pair", the model's own call alone on inputs prepared beforehand
    (onnxruntime's session.run, the Python object's predict: what an integrator calling the
    model directly pays; the model is still bounded, one bound over each round of calls:
    ExternalPredictor.own_round), and "wrapper_single_s_per_pair", "wrapper_batched_s_per_pair", the
    full call less the model's own (the per-call bound, input conversion, the testbed's checks,
    depth and clipping; 0 when the difference is within the timing's noise and negative)."""
    pb, Rb, sAb, sBb = batched
    pred.predict(pb, Rb, size_A=sAb, size_B=sBb)  # warm (compiled code loaded, caches filled)
    fns = [lambda: [pred.predict(a, b, size_A=c, size_B=d) for a, b, c, d in singles],
           lambda: pred.predict(pb, Rb, size_A=sAb, size_B=sBb)]
    own = getattr(pred, "own_call", None)
    if own is not None:
        ones = [own(*(np.asarray(v, dtype=float).reshape((1, *np.shape(v))) for v in pose)) for pose in singles]
        whole = own(pb, Rb, sAb, sBb)

        def one_by_one():
            with pred.own_round(len(ones)):  # one bound over the round, not one per call
                return [call() for call in ones]

        def batched():
            with pred.own_round(1):
                return whole()

        batched()  # warm
        fns += [one_by_one, batched]
    ns = fastest_side_by_side(fns, rounds)
    out = {"single_s_per_pair": ns[0] * 1e-9 / len(singles), "batched_s_per_pair": ns[1] * 1e-9 / len(pb)}
    if own is not None:
        out["model_single_s_per_pair"] = ns[2] * 1e-9 / len(singles)
        out["model_batched_s_per_pair"] = ns[3] * 1e-9 / len(pb)
        for how in ("single", "batched"):
            out[f"wrapper_{how}_s_per_pair"] = max(0.0, out[f"{how}_s_per_pair"] - out[f"model_{how}_s_per_pair"])
    return out


def _type_of(size) -> str:
    code = {tuple(np.round(t.size, 3)): name for name, t in CONTAINER_TYPES.items()}
    return code[tuple(np.round(np.asarray(size, dtype=float), 3))]


def rounds_ns(fn, rounds: int) -> list[float]:
    """Wall time [ns] of each of `rounds` calls of fn(), in order (their spread: what the
    machine's load did to the figure in this run)."""
    out = []
    for _ in range(rounds):
        t0 = time.perf_counter_ns()
        fn()
        out.append(float(time.perf_counter_ns() - t0))
    return out


def drake_point_pair_cost(singles, rounds: int = ROUNDS) -> dict:
    """{"set_pose_and_query_s_per_pair", "kernel_s_per_pair", "set_pose_and_query_rounds_s_per_pair"}:
    Drake's point-pair penetration query on the pair scenes the labels use
    (learned_contact.data.labels), pose set per call (the fastest round, and every round's
    figure in order: the spread of the reference in this run), and the query alone on an
    already-posed scene (the first pose)."""
    scenes = [pair_scene(_type_of(a), _type_of(b)) for _, _, a, b in singles]
    for scene, (p, R, _, _) in zip(scenes[:3], singles):  # build and warm
        posed_query(scene, R, p).ComputePointPairPenetration()
    query = posed_query(scenes[0], singles[0][1], singles[0][0])

    def every_pose():
        return [posed_query(s, R, p).ComputePointPairPenetration() for s, (p, R, _, _) in zip(scenes, singles)]

    every_pose()  # one untimed round: every scene touched once, so the rounds' spread is the machine's, not first use
    each = [ns * 1e-9 / len(singles) for ns in rounds_ns(every_pose, rounds)]
    return {"set_pose_and_query_s_per_pair": min(each), "set_pose_and_query_rounds_s_per_pair": each,
            "kernel_s_per_pair": per_pair_s(lambda: [query.ComputePointPairPenetration() for _ in range(1000)], 1000,
                                            rounds)}


FIRST_CALL = (
    "import json, os, sys, time\n"
    "sys.path.append(os.getcwd())\n"
    "t0 = time.perf_counter()\n"
    "import numpy as np\n"
    "from learned_contact import load_predictor\n"
    "from learned_contact.predictors import limits\n"
    "limits.set_limits(**json.loads(sys.argv[2]))\n"
    "pred = load_predictor(sys.argv[1])\n"
    "size = pred.supported_sizes[0]\n"
    "pred.predict(np.array([0.0, 0.0, size[2] - 0.005]), np.eye(3), size_A=size, size_B=size)\n"
    "print(time.perf_counter() - t0)\n"
)


def first_call_s(spec: str, env: dict | None = None) -> float:
    """Seconds from a fresh interpreter's first import to the first answer of `spec` (the
    child sees this process's sys.path, so a Python model found here is found there; `env`
    adds variables, e.g. NUMBA_CACHE_DIR for a cold cache). WeightsError naming the model
    when it fails or outruns twice its load bound plus its call bound and a minute."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p), **(env or {})}
    bound = limits.limits()
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
