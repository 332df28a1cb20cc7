"""Rolling out many tosses in parallel and summarising the errors.

`RolloutPool` keeps worker processes alive across calls (a fit evaluates thousands of
parameter sets); each worker loads the toss file once and keeps the TossSimulator of
the last parameter set it saw, so a plant is built once per worker per parameter set,
not per toss. workers=1 runs in this process (no pool).
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import time

import numpy as np

from testbed.calibration.data import TossSet, load_tosses
from testbed.calibration.rollout import CubeTossParams, TossResult, TossSimulator

_worker_state: dict = {}  # per process: 'data' (TossSet), 'key', 'sim'


def _simulator(params: CubeTossParams, dt: float) -> TossSimulator:
    key = (dataclasses.astuple(params), dt)
    if _worker_state.get("key") != key:
        _worker_state["sim"] = TossSimulator(params, dt)
        _worker_state["key"] = key
    return _worker_state["sim"]


def _init_worker(path: str) -> None:
    _worker_state["data"] = load_tosses(path)


def _run_chunk(args) -> list[TossResult]:
    params, indices, initial = args
    data: TossSet = _worker_state["data"]
    sim = _simulator(params, data.dt)
    return [sim.evaluate(data.tosses[i], initial) for i in indices]


class RolloutPool:
    """Evaluates parameter sets on tosses of one file, with `workers` processes."""

    def __init__(self, data: TossSet, workers: int = 1):
        self.data = data
        self.workers = max(1, int(workers))
        self._pool = None
        if self.workers > 1:
            ctx = multiprocessing.get_context("spawn")  # Drake is not fork-safe once it has threads
            self._pool = ctx.Pool(self.workers, initializer=_init_worker, initargs=(data.path,))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None

    def evaluate(self, params: CubeTossParams, indices=None, initial: str = "first-frame") -> list[TossResult]:
        """One TossResult per toss index (all tosses when None), in the order given;
        `initial`: the rollouts' initial state (initial_state.INITIAL_STATES)."""
        params.check()
        indices = list(range(len(self.data.tosses))) if indices is None else list(indices)
        if self._pool is None:
            sim = TossSimulator(params, self.data.dt)
            return [sim.evaluate(self.data.tosses[i], initial) for i in indices]
        n_chunks = min(len(indices), 4 * self.workers)  # a few chunks per worker balance long and short tosses
        chunks = [indices[c::n_chunks] for c in range(n_chunks)]
        by_index = {}
        for chunk, results in zip(chunks, self._pool.map(_run_chunk, [(params, c, initial) for c in chunks])):
            by_index.update(zip(chunk, results))
        return [by_index[i] for i in indices]


def summarize(results: list[TossResult], wall_s: float) -> dict:
    """The metrics.json figures of a set of toss results (errors in cube widths / degrees)."""
    position = np.array([r.position_error for r in results])
    rotation = np.array([r.rotation_error_deg for r in results])
    return {
        "position_error_mean": float(np.mean(position)),
        "position_error_median": float(np.median(position)),
        "rotation_error_mean_deg": float(np.nanmean(rotation)) if np.any(np.isfinite(rotation)) else float("nan"),
        "n_trajectories": len(results),
        "n_failed": int(sum(r.failed for r in results)),
        "wall_s": float(wall_s),
    }


def evaluate_file(params: CubeTossParams, path: str, workers: int = 1, initial: str = "first-frame") -> tuple[list[TossResult], dict]:
    """Rolls out every toss of `path` with `params` from `initial` states: (results, metrics dict)."""
    start = time.perf_counter()
    data = load_tosses(path)
    with RolloutPool(data, workers) as pool:
        results = pool.evaluate(params, initial=initial)
    return results, summarize(results, time.perf_counter() - start)
