"""The bench's yard budget: how many container pairs each predictor answers within
one real-time step, beside the host engine's own step.

A crane simulator's loop steps every h = 1 ms. That step holds the host engine's own step
(integrating the containers, its own contact with the quay) and the learned contact's, whose
predictor is called once per step on every pair in contact (one batched call). The call's wall
time is measured at several batch sizes k (the best of `repeats` rounds each, stacked 40 ft
poses: the cost of a pair hardly depends on its pose) and fitted as t(k) = a + b k (least
squares): a [s] the call's fixed cost, b [s] per pair. The budget is the largest k with
host + a + b k <= h:

  pairs_within_step   beside the host's own step alone
  pairs_beside_loop   beside the host's step and the rest of the learned system's work per step
                      (state, broad phase, force law, forces), as measured with the host

The host's step is measured on a yard of `host_size` containers (default 96, the shipped
yard_block's 4 x 6 x 4) by testbed.studies.scale's cell of the MuJoCo-hosted learned loop
(its 'engine_step': MuJoCo's integration and its quay contact) when that engine is
registered, else of the Drake-hosted one (Drake's step); or given by the caller.

For a model the testbed did not ship, its own call alone (onnxruntime's session.run, the
Python object's predict: ExternalPredictor.own_call) is timed beside the full call at each
batch size, in the same rounds, and fitted the same way (fields prefixed 'model_'): what the
model itself costs a simulator, apart from the testbed's wrapper (the per-call bound, the
input checks, depth and clipping). The per-call bound is one watchdog thread per process
(learned_contact.predictors.limits), so neither figure holds a thread started per call.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time

import numpy as np

from testbed.bench.model import resolve
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.document import Section, Text, table
from testbed.geometry.rotations import rotation_from_rpy
from testbed.studies.scale import ScaleConfig, run_cell, tasks
from testbed.studies.scale.settings import models

BATCH_SIZES = (1, 8, 32, 128, 512)  # pairs per call
STEP_S = 1e-3  # [s] the real-time step
HOST_SIZE = 96  # containers of the yard the host's step is measured on


def stacking_poses(k: int, type_name: str = "1AA", seed: int = 0):
    """(p_AB (k, 3) [m], R_AB (k, 3, 3), size_A (k, 3), size_B (k, 3) [m]): box B of `type_name`
    resting on box A of the same type, offset up to 0.3 m, overlap 0 to 2 mm, tilt up to 0.01 rad."""
    rng = np.random.default_rng(seed)
    size = np.asarray(CONTAINER_TYPES[type_name].size, float)
    p = np.column_stack([rng.uniform(-0.3, 0.3, k), rng.uniform(-0.3, 0.3, k), size[2] - rng.uniform(0.0, 2e-3, k)])
    R = rotation_from_rpy(np.column_stack([rng.uniform(-0.01, 0.01, (k, 2)), np.zeros(k)]))
    sizes = np.tile(size, (k, 1))
    return p, R, sizes, sizes.copy()


def _calls_per_round(fn, within) -> int:
    """How many calls of fn() last about 5 ms (for the timer's resolution), 1 to 1000, from one
    call run inside within(1) (fn has answered once before: this call is not the first)."""
    t0 = time.perf_counter()
    with within(1):
        fn()
    return max(1, min(1000, int(5e-3 / max(time.perf_counter() - t0, 1e-7))))


def side_by_side_costs(predictor, batch_sizes=BATCH_SIZES, repeats: int = 3, type_name: str = "1AA") -> dict:
    """{'call_s': [s] wall time of one full batched predict call per batch size, 'model_call_s':
    the model's own call alone on the same poses (predictor.own_call: a model the testbed did
    not ship) or None}: best of `repeats` rounds, the two timed in turn within each round; each
    round repeats small calls until it lasts about 5 ms."""
    p, R, sA, sB = stacking_poses(max(batch_sizes), type_name)
    own = getattr(predictor, "own_call", None)
    full, alone = [], []
    for k in batch_sizes:
        args = (p[:k], R[:k], sA[:k], sB[:k])
        # (a call, the context a round of n of them runs in): the model's own calls are bounded
        # one round at a time (ExternalPredictor.own_round), the full call bounds itself
        fns = [(lambda a=args: predictor.predict(a[0], a[1], size_A=a[2], size_B=a[3]), _unbounded)]
        if own is not None:
            fns.append((own(*args), predictor.own_round))
        for fn, within in fns:
            with within(1):
                fn()  # warm
        calls = [_calls_per_round(fn, within) for fn, within in fns]
        best = [math.inf] * len(fns)
        for _ in range(repeats):
            for i, ((fn, within), n) in enumerate(zip(fns, calls)):
                t0 = time.perf_counter()
                with within(n):
                    for _ in range(n):
                        fn()
                best[i] = min(best[i], (time.perf_counter() - t0) / n)
        full.append(best[0])
        alone.append(best[-1])
    return {"call_s": full, "model_call_s": alone if own is not None else None}


def _unbounded(calls: int):
    """No bound over a round: the full predict call bounds each model call itself."""
    return contextlib.nullcontext()


def call_costs(predictor, batch_sizes=BATCH_SIZES, repeats: int = 3, type_name: str = "1AA") -> list[float]:
    """[s] wall time of one batched predict call per batch size (side_by_side_costs' 'call_s')."""
    return side_by_side_costs(predictor, batch_sizes, repeats, type_name)["call_s"]


def fit_call_cost(batch_sizes, seconds) -> tuple[float, float]:
    """(a fixed [s], b per pair [s]) of t(k) = a + b k, least squares; a and b at least 0."""
    b, a = np.polyfit(np.asarray(batch_sizes, float), np.asarray(seconds, float), 1)
    return max(0.0, float(a)), max(float(b), 1e-12)


def pairs_within(budget_s: float, fixed_s: float, per_pair_s: float) -> int:
    """The most pairs k with fixed_s + per_pair_s k <= budget_s (0 when the budget is spent)."""
    return max(0, int(math.floor((budget_s - fixed_s) / per_pair_s))) if budget_s > fixed_s else 0


def host_models() -> tuple[str, ...]:
    """The scale study's learned models (every engine a predictor decides, from the registry),
    tried in this order for the host's step: a real-time host first, the Drake-hosted (gated) loop last."""
    specs = models()
    learned = [name for name, spec in specs.items() if spec.judged]
    return tuple(sorted(learned, key=lambda name: specs[name].gated))


def host_step(host_size: int = HOST_SIZE, duration: float = 0.05, step_s: float = STEP_S) -> dict:
    """The host engine's own step on a host_size-container yard (module doc): {'model' (the
    scale study's), 'n', 'host_step_s', 'learned_system_s' [s per step], 'pairs_per_step'};
    'host_step_s' NaN and 'why' set when neither learned loop ran."""
    config = ScaleConfig(sizes=(host_size,), duration=duration, big_duration=duration, time_step=step_s,
                         models=host_models(), repeats=2, repeat_below_s=1.0, yards=("settled",), passes=1,
                         settle_s=0.1)  # an awake yard: the budget is for a predictor asked about every touching pair
    why = []
    for task in tasks(config):
        row = run_cell(task)
        if row["status"] == "ok":
            split = row["split_us"]
            return {"model": row["model"], "n": host_size, "host_step_s": 1e-6 * split["engine_step"],
                    "learned_system_s": 1e-6 * split["learned_system"], "pairs_per_step": row["pairs_per_step"]}
        why.append(f"{row['model']}: {row['status']} ({row['why']})")
    return {"model": "", "n": host_size, "host_step_s": float("nan"), "learned_system_s": float("nan"),
            "pairs_per_step": float("nan"), "why": "; ".join(why)}


@dataclasses.dataclass(frozen=True)
class BudgetSettings:
    """step_s [s]: the real-time step; batch_sizes: pairs per timed call; repeats: rounds per
    size; host: a host_step() dict to use (None: measured here on a host_size-container yard)."""

    step_s: float = STEP_S
    batch_sizes: tuple[int, ...] = BATCH_SIZES
    repeats: int = 3
    host_size: int = HOST_SIZE
    host: dict | None = None


def yard_budget(models, settings: BudgetSettings = BudgetSettings()) -> dict:
    """{'step_s', 'host' (host_step's dict), 'predictors': {spec: {'label', 'batch_sizes',
    'call_s' (per size), 'fixed_s', 'per_pair_s', 'pairs_within_step', 'pairs_beside_loop'} or,
    when its calls failed, {'label', 'why'}}} for each of `models` (BenchModels or learned_contact.sources
    strings; keyed by spec), measured side by side. The figures are of the full predict call; for a model the
    testbed did not ship the same five of its own call alone follow, prefixed 'model_'
    ('model_pairs_within_step': what the model itself leaves room for, without the testbed's
    wrapper)."""
    host = settings.host if settings.host is not None else host_step(settings.host_size, step_s=settings.step_s)
    out = {}
    for m in map(resolve, models):
        spec, pred, label = m.spec, m.predictor, m.label
        type_name = "1AA"
        supported = m.declared_sizes
        if np.abs(supported - np.asarray(CONTAINER_TYPES[type_name].size)).max(axis=1).min() > 1e-3:
            type_name = next((n for n, t in CONTAINER_TYPES.items()
                              if np.abs(supported - np.asarray(t.size)).max(axis=1).min() <= 1e-3), type_name)
        try:
            timed = side_by_side_costs(pred, settings.batch_sizes, settings.repeats, type_name)
        except Exception as e:  # noqa: BLE001 - a model that cannot answer these poses: a row that says so
            out[spec] = {"label": label, "batch_sizes": list(settings.batch_sizes), "container_type": type_name,
                         "why": f"{type(e).__name__}: {(str(e).strip().splitlines() or [''])[0][:200]}"}
            continue
        spare = settings.step_s - host["host_step_s"]
        out[spec] = {"label": label, "batch_sizes": list(settings.batch_sizes), "container_type": type_name,
                     **_budget(timed["call_s"], settings.batch_sizes, spare, host["learned_system_s"])}
        if timed["model_call_s"] is not None:  # the model's own call, beside the full one
            own = _budget(timed["model_call_s"], settings.batch_sizes, spare, host["learned_system_s"])
            out[spec].update({f"model_{k}": v for k, v in own.items()})
    return {"step_s": settings.step_s, "host": host, "predictors": out}


def _budget(seconds, batch_sizes, spare_s: float, learned_system_s: float) -> dict:
    """{'call_s', 'fixed_s', 'per_pair_s', 'pairs_within_step', 'pairs_beside_loop'} of calls
    that took `seconds` [s] at `batch_sizes`, within spare_s [s] of the step (NaN: no budget)."""
    fixed, per_pair = fit_call_cost(batch_sizes, seconds)
    known = math.isfinite(spare_s)
    return {"call_s": list(seconds), "fixed_s": fixed, "per_pair_s": per_pair,
            "pairs_within_step": pairs_within(spare_s, fixed, per_pair) if known else None,
            "pairs_beside_loop": pairs_within(spare_s - learned_system_s, fixed, per_pair) if known else None}


def budget_section(budget: dict, order: int = 45) -> Section:
    """The bench report's 'Yard budget' section: the host's step and one row per predictor."""
    host, h = budget["host"], budget["step_s"]
    where = (f"the host's own step: {host['host_step_s'] * 1e6:.0f} us per step on a {host['n']}-container yard "
             f"(scale study's {host['model']} run; the learned system's other work {host['learned_system_s'] * 1e6:.0f} us "
             f"per step at {host['pairs_per_step']:.0f} pairs)" if math.isfinite(host["host_step_s"])
             else f"the host's step could not be measured ({host.get('why', '')}): no budget")
    key = Text(f"How many container pairs each predictor answers within a {h * 1e3:g} ms step, beside {where}. "
               "One batched call per step, its wall time fitted as fixed + per pair x pairs over batch sizes "
               f"{', '.join(map(str, next(iter(budget['predictors'].values()))['batch_sizes'])) if budget['predictors'] else '-'}.")

    def n(v):
        return "-" if v is None else str(v)

    def alone(p):
        if "model_fixed_s" not in p:
            return ["-", "-"]
        return [f"{p['model_fixed_s'] * 1e6:.1f} + {p['model_per_pair_s'] * 1e6:.3f} per pair",
                n(p["model_pairs_within_step"])]

    rows = [[p["label"], f"{p['fixed_s'] * 1e6:.1f}", f"{p['per_pair_s'] * 1e6:.3f}", n(p["pairs_within_step"]),
             n(p["pairs_beside_loop"]), *alone(p)] if "why" not in p
            else [p["label"], "-", "-", f"not measured: {p['why']}", "-", "-", "-"]
            for p in budget["predictors"].values()]
    note = Text("For a model the testbed did not ship, the last two columns time its own call alone (onnxruntime's "
                "session.run, the Python object's predict) beside the full call: the rest of the full call is the "
                "testbed's wrapper (the per-call bound, input checks, depth, clipping), which a simulator calling the "
                "model directly does not pay.")
    return Section("Yard budget", [key, table(["predictor", "fixed cost per call [us]", "per pair [us]",
                                               "pairs within the step beside the host",
                                               "pairs beside the host and the learned system",
                                               "the model alone: fixed + per pair [us]",
                                               "the model alone: pairs within the step beside the host"], rows),
                                   note], order=order)
