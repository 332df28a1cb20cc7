"""Timing of the query study: every method on every pose, side by side in one process.

time.perf_counter_ns around each call; every pose is run once to warm up, then
`repeats` times; a pose's time is the fastest of its repeats (the cost without
interference from other processes on shared cores); for batched calls the batch time
divided by its size. numpy's BLAS is limited to one thread while measuring
(threadpoolctl, when installed), so every method runs on one core; on 2 shared cores a
threaded BLAS made batched MLP calls 10x slower and erratic.
"query" time = pose in -> point and normal out, including Python glue; "kernel" time
= the library's collision call alone on an already-posed scene (Drake query,
fcl.collide, mj_collision). Absolute times depend on the machine: compare ratios.
"""

from __future__ import annotations

import time

import numpy as np

from learned_contact.evaluation import cost
from learned_contact.evaluation.cost import fastest_ns
from testbed.progress import progress as progress_bar
from testbed.studies.query.methods import ContactMethod, build_methods
from testbed.studies.query.poses import pooled

THROUGHPUT_BATCH = 4096  # pairs per call for the batched methods' throughput figure


def _min_ns(fn, repeats: int) -> float:
    """Fastest wall time [ns] of `repeats` calls of fn (after the caller's warm-up):
    learned_contact.evaluation.cost's timing, which the bench and the benchmark script use too."""
    return fastest_ns(fn, repeats)


def measure_set(poses, methods: list[ContactMethod], repeats: int, *, progress: bool):
    """Runs every available method on every pose of one set.

    Returns {method name: {"point" (n, 3), "normal" (n, 3), "count" (n,),
    "query_ns" (n,), "kernel_ns" (n,) or None, "candidates" (n,) (methods that count them)}}.
    """

    n = len(poses)
    out = {}
    for m in methods:
        if not m.available:
            continue
        point, normal = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
        count, q_ns = np.full(n, -1, dtype=np.int64), np.full(n, np.nan)
        k_ns = np.full(n, np.nan) if m.prepare_kernel is not None else None
        if m.batched is not None:
            m.batched()  # warm-up
            t = np.empty(repeats)
            for r in range(repeats):
                t0 = time.perf_counter_ns()
                pts, nrm = m.batched()
                t[r] = time.perf_counter_ns() - t0
            point[:], normal[:] = pts, nrm
            q_ns[:] = np.min(t) / n
            out[m.name] = {"point": point, "normal": normal, "count": count, "query_ns": q_ns, "kernel_ns": None,
                           "batch_ns": t / n}
            continue
        for i in progress_bar(range(n), desc=f"{poses.name}: {m.name}", disable=not progress, leave=False):
            p, nr, c = m.single(i)  # warm-up, and the answer
            point[i], normal[i] = p, nr
            count[i] = -1 if c is None else c
            q_ns[i] = _min_ns(lambda m=m, i=i: m.single(i), repeats)
            if k_ns is not None:
                fn = m.prepare_kernel(i)
                fn()
                k_ns[i] = _min_ns(fn, repeats)
        res = {"point": point, "normal": normal, "count": count, "query_ns": q_ns, "kernel_ns": k_ns}
        if m.candidates is not None:
            res["candidates"] = np.array([m.candidates(i) for i in range(n)], dtype=np.int64)
        out[m.name] = res
    return out


one_blas_thread = cost.one_blas_thread  # numpy's BLAS on one thread while timing


def throughput(methods_metrics: dict, sets: dict, scenes, options, repeats: int) -> None:
    """Adds "throughput_us_per_pair" (batch of THROUGHPUT_BATCH pairs: all poses,
    repeated) and "throughput_batch" to every available batched method in
    methods_metrics ({name: entry}, the study's metrics["methods"])."""
    if not any(len(v) for v in sets.values()):
        return
    big = pooled(sets, THROUGHPUT_BATCH)
    no_soup = type(options)(soup_ns=(), predictor=options.predictor, paper_weights=options.paper_weights)
    for m in build_methods(big, scenes, no_soup):
        if m.available and m.batched is not None and m.name in methods_metrics:
            m.batched()
            methods_metrics[m.name]["throughput_us_per_pair"] = _min_ns(m.batched, repeats) * 1e-3 / THROUGHPUT_BATCH
            methods_metrics[m.name]["throughput_batch"] = THROUGHPUT_BATCH
