"""The scale study's cells: one run per (pass, N, model, yard kind), timed past the settling.

The MuJoCo-hosted learned loop (settings.CONTINUED): one run from rest of config.settle_s
(untimed), the window (config.duration_for(N) [s], timed inside the run) and one step: the
window continues the settling run, so the islands asleep at its start stay asleep (window.py:
how it is clocked, and what the row says of the yard at the window's start, the asleep
fraction included). The crane's load hangs still through the settling; its hoist starts
with the window. Its CPU time per step is this process's over the window alone.

Every other model first SETTLES its yard: the block alone simulated config.settle_for(model)
[s] from rest by the cell's own engine and model, untimed (settle: cached in this process, so
the settled and the crane cell of one N and model share it). The timed window is then a fresh
run from that settled state (testbed/studies/scale/yard.py) and lasts config.duration_for(N)
[s]; its wall time is the stepping alone (Drake's AdvanceTo calls, MuJoCo's mj_step: no
recorder, observer or viewer).
The CPU time of this process over the window (less that of a second build and one step) gives a
second cost per step that other work on a shared machine hardly disturbs (cpu_us_per_step), but
the spread of the builds' own CPU time does (a large yard's build costs about as much as its window).
The row says where the window started (window_start_s: the settling run's simulated time) and
how settled the yard was there: the largest container speed [m/s] and the block's kinetic
energy [J] at the end of the settling run, which the window starts from.

The cells are independent: run_cell(task) is a module-level function, so a caller may map them
over processes or a Ray cluster (validate's executors); cells run side by side share the
machine, so the default runs them one after the other in this process.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from testbed.bodies.containers import CONTAINER_TYPES
from testbed.drake_support import drake_version
from testbed.engines import engines
from testbed.engines.base import UnsupportedSceneError
from testbed.errors import OptionalDependencyError, TestbedError
from testbed.geometry.rotations import angle_between_quaternions_deg
from testbed.studies.scale.settings import REFERENCE, ScaleConfig, from_dict, models
from testbed.studies.scale.window import continued_run
from testbed.studies.scale.yard import LOAD, SettledState, layout, top_name, yard_scenario

SPLIT = ("engine_step", "learned_system", "predictor")  # the per-step parts [us]
_SETTLED: dict = {}  # (config, n, model) -> settle()'s result, in this process


def tasks(config: ScaleConfig) -> list[dict]:
    """The cells: pass by pass, smallest yard first, the models in config order, the yard kinds
    in config order; picklable dicts for run_cell."""
    asdict = dataclasses.asdict(config)
    return [{"config": asdict, "n": n, "model": m, "yard": y, "pass": p}
            for p in range(1, config.passes + 1) for n in sorted(config.sizes) for m in config.model_names()
            for y in config.yards]


def _run(engine, spec, scenario, duration: float, config: ScaleConfig, records: int = 1):
    """One engine run of `scenario` for `duration` [s], recording its start and `records` times
    after (1: its end only)."""
    every = max(1, round(duration / config.time_step / records))
    extra = {"predictor": config.predictor} if spec.judged and config.predictor else {}
    return engine.run(scenario, duration=duration, record_every=every, params=spec.params, **extra)


def settle(config: ScaleConfig, n: int, model: str) -> dict:
    """The settling run of the N-container block with `model` (untimed for the study): {'state'
    SettledState or None, 'max_speed_mps' [m/s] largest container speed at its end,
    'kinetic_J' [J] the block's kinetic energy there, 'peak_kinetic_J' [J] the largest of ten
    records over the run, 'wall_s', 'error'}; cached in this process."""
    key = (repr(dataclasses.astuple(config)), n, model)
    if key not in _SETTLED:
        spec = models()[model]
        settle_s = config.settle_for(model)
        traj = _run(engines()[spec.engine], spec, yard_scenario(n, config, "settled", duration=settle_s),
                    settle_s, config, records=10).trajectory
        V = np.asarray(traj.V_WB[-1], float)
        finite = bool(np.all(np.isfinite(traj.p_WB[-1])) and np.all(np.isfinite(V)))
        state = SettledState(list(traj.names), np.asarray(traj.p_WB[-1]), np.asarray(traj.q_WB[-1]), V,
                             float(traj.simulated_s)) if finite and not traj.error else None
        _SETTLED[key] = {"state": state, "max_speed_mps": float(np.linalg.norm(V[:, 3:], axis=1).max()) if finite else math.nan,
                         "kinetic_J": float(traj.energy[-1] - traj.potential[-1]) if finite else math.nan,
                         "peak_kinetic_J": float(np.max(traj.energy - traj.potential)) if finite else math.nan,
                         "wall_s": float(traj.wall_s), "error": traj.error or ("" if finite else "non-finite state")}
    return _SETTLED[key]


def run_cell(task: dict) -> dict:
    """One (pass, N, model, yard) cell of `tasks`; never raises (a failure is the row's status).

    Returns {'n', 'layout' 'RxBxT', 'model', 'label', 'engine', 'params', 'yard', 'pass',
    'status': 'ok' | 'diverged' | 'refused' | 'unavailable' | 'skipped' (above the model's cap)
    | 'error', 'why', 'settle_s' [s] untimed before the window (settle_for), 'window_start_s' [s] simulated
    when the window starts, 'start_max_speed_mps', 'start_kinetic_J' (the yard there),
    'settle_peak_kinetic_J' (the largest kinetic energy recorded while settling),
    'duration_s' [s] of the window, 'simulated_s', 'steps', 'wall_s' (the window's stepping
    only), 'wall_per_sim_s', 'real_time_factor', 'us_per_step', 'cpu_us_per_step' and
    'cpu_real_time_factor' (this process's CPU time per step: the fastest window's CPU time less
    the fastest run of the same build and one step, over the other steps; other work on a shared
    machine slows the wall time, hardly the CPU time), 'split_us' {engine_step,
    learned_system, predictor: [us per step]; the last two None where the engine's own contact
    is inside its step}, 'pairs_per_step' (None without a predictor), 'runs' (timed repeats),
    'version'; a continued window (window.py) adds 'start_asleep_fraction' (free bodies in
    asleep islands at its start), 'start_islands', 'start_islands_asleep', 'start_asked_pairs',
    'asleep_fraction' (the window's mean), 'reused_pairs_per_step' and, with the crane,
    'start_load_clearance_m'; crane yards: 'landed' (the load ends within half crane_gap of its stack's top)
    and 'load_clearance_m'; for the error against the reference 'p_final' (m, 3) [m] and
    'q_final' (m, 4) wxyz of the block's containers at the window's end}."""
    config = from_dict(task["config"])
    n, model, yard = int(task["n"]), task["model"], task.get("yard", "settled")
    rows, bays, tiers = layout(n, config.tiers)
    spec = models().get(model)
    row = {"n": n, "layout": f"{rows}x{bays}x{tiers}", "model": model, "label": spec.label if spec else model,
           "engine": spec.engine if spec else "", "params": spec.params if spec else None, "yard": yard,
           "pass": int(task.get("pass", 1)), "settle_s": config.settle_for(model), "duration_s": config.duration_for(n),
           "time_step_s": config.time_step, "why": ""}
    engine = engines().get(spec.engine) if spec else None
    if engine is None:
        return {**row, "status": "unavailable", "why": f"no registered engine gives the model {model!r}"}
    cap = config.cap(model)
    if cap is not None and n > cap:
        return {**row, "status": "skipped", "why": f"above this model's size cap of {cap} containers"}
    try:
        why = engine.unavailable()
        if why is not None:
            return {**row, "status": "unavailable", "why": why}
        engine.check(yard_scenario(n, config, yard))
        if config.continues(model):
            return _continued(row, n, yard, config)
        return _fresh(row, engine, spec, n, yard, config)
    except (UnsupportedSceneError, OptionalDependencyError, ImportError) as e:
        return {**row, "status": "unavailable", "why": _line(e)}
    except TestbedError as e:  # the build refused the yard (the learned loop's stability check, ...)
        return {**row, "status": "refused", "why": _line(e)}
    except Exception as e:  # noqa: BLE001 - a crashed cell is a result too
        return {**row, "status": "error", "why": f"{type(e).__name__}: {_line(e)}"}


def _fresh(row: dict, engine, spec, n: int, yard: str, config: ScaleConfig) -> dict:
    """run_cell's row of a window that is a fresh run from the state its settling run ended in."""
    settled = settle(config, n, row["model"])
    row.update(start_max_speed_mps=settled["max_speed_mps"], start_kinetic_J=settled["kinetic_J"],
               settle_peak_kinetic_J=settled["peak_kinetic_J"])
    if settled["state"] is None:
        return {**row, "status": "diverged", "why": f"while settling: {settled['error']}"}
    row["window_start_s"] = settled["state"].time
    scenario = yard_scenario(n, config, yard, state=settled["state"])
    runs, cpu_window, cpu_base = [], [], []
    while not runs or (len(runs) < config.repeats and runs[-1].trajectory.wall_s < config.repeat_below_s):
        start = time.process_time()
        runs.append(_run(engine, spec, scenario, config.duration_for(n), config))
        cpu_window.append(time.process_time() - start)
        start = time.process_time()  # the same build and one step: what the window's CPU time holds besides its steps
        _run(engine, spec, scenario, config.time_step, config)
        cpu_base.append(time.process_time() - start)
    best = min(runs, key=lambda r: r.trajectory.wall_s)
    version = best.summary.get("version") or (drake_version() if engine.name in ("drake", "learned") else "")
    out = {**row, **_figures(best.trajectory, config.time_step), "runs": len(runs), "version": version}
    steps = out["steps"]
    cpu = (min(cpu_window) - min(cpu_base)) / (steps - 1) if steps > 1 else math.nan  # [s] per step
    out.update(cpu_us_per_step=1e6 * cpu if cpu > 0 else math.nan,
               cpu_real_time_factor=config.time_step / cpu if cpu > 0 else math.nan)
    if yard == "crane" and out["status"] == "ok":
        out.update(_landing(best.trajectory, n, config))
    return out


def _continued(row: dict, n: int, yard: str, config: ScaleConfig) -> dict:
    """run_cell's row of a window that continues its settling run (window.py): one run from rest
    of settle_s, the window and one step, the window clocked inside it; repeated as _fresh's."""
    h = config.time_step
    settle_steps, window_steps = int(round(config.settle_s / h)), int(round(config.duration_for(n) / h))
    scenario = yard_scenario(n, config, yard, duration=(settle_steps + window_steps + 1) * h, hold=settle_steps * h)
    crane = (LOAD, top_name(n, config)) if yard == "crane" else None
    row["window_start_s"] = settle_steps * h
    best, cpu, runs = None, [], 0
    while best is None or (runs < config.repeats and best[1]["wall_s"] < config.repeat_below_s):
        result, figures = continued_run(scenario, settle_steps, window_steps, config, crane)
        runs += 1
        if figures is None:
            return {**row, "status": "diverged", "why": result.trajectory.error, "runs": runs}
        cpu.append(figures["cpu_s"])
        if best is None or figures["wall_s"] < best[1]["wall_s"]:
            best = (result, figures)
    result, figures = best
    traj, steps, wall = result.trajectory, figures["steps"], figures["wall_s"]
    final = _figures(traj, h)  # status and the final state (one step past the window's end)
    cpu_step = min(cpu) / steps
    out = {**row, **{k: v for k, v in figures.items() if k != "cpu_s"}, "status": final["status"], "why": final["why"],
           "wall_per_sim_s": wall / figures["simulated_s"], "real_time_factor": figures["simulated_s"] / wall if wall > 0 else math.inf,
           "us_per_step": 1e6 * wall / steps, "cpu_us_per_step": 1e6 * cpu_step,
           "cpu_real_time_factor": h / cpu_step if cpu_step > 0 else math.nan,
           "p_final": final["p_final"], "q_final": final["q_final"], "runs": runs, "version": result.summary.get("version", "")}
    if yard == "crane" and out["status"] == "ok":
        out.update(_landing(traj, n, config))
    return out


def _line(e: Exception) -> str:
    return (str(e).strip().splitlines() or [type(e).__name__])[0][:300]


def _landing(traj, n: int, config: ScaleConfig) -> dict:
    """'load_clearance_m' [m] between the load's bottom and its stack's top at the window's
    end (both faces level: the load sits square on the stack), and 'landed' (within half
    crane_gap of touching: it came down onto the stack inside the window)."""
    names = list(traj.names)
    p_load, p_top = traj.p_WB[-1][names.index(LOAD)], traj.p_WB[-1][names.index(top_name(n, config))]
    gap = (p_load[2] - 0.5 * CONTAINER_TYPES[config.crane_type].size[2]) - (p_top[2] + 0.5 * CONTAINER_TYPES[config.container_type].size[2])
    return {"load_clearance_m": float(gap), "landed": bool(gap < 0.5 * config.crane_gap)}


def _figures(traj, h: float) -> dict:
    """run_cell's timing and final-state figures of a Trajectory (testbed.simulation)."""
    steps = int(round(traj.simulated_s / h))
    wall = float(traj.wall_s)
    us = 1e6 * wall / steps if steps else float("nan")
    if traj.costs and steps:  # a learned loop's own timers (testbed/compare/costs.py's calc_s, predict_s)
        calc, predict = traj.costs["calc_s"], traj.costs["predict_s"]
        # the host's step is the rest of the timed wall (recording is 0 in these runs, which drop the recorders)
        split = {"engine_step": 1e6 * max(0.0, wall - calc) / steps, "learned_system": 1e6 * max(0.0, calc - predict) / steps,
                 "predictor": 1e6 * predict / steps}
        pairs = traj.costs.get("predict_pairs", 0) / steps
    else:
        split, pairs = {"engine_step": us, "learned_system": None, "predictor": None}, None
    finite = bool(np.all(np.isfinite(traj.p_WB[-1])) and np.all(np.isfinite(traj.q_WB[-1])))
    failed = bool(traj.error) or not finite
    keep = [i for i, name in enumerate(traj.names) if name != LOAD] if len(traj.names) else slice(None)
    return {"status": "diverged" if failed else "ok", "why": traj.error or ("" if finite else "non-finite state"),
            "simulated_s": float(traj.simulated_s), "steps": steps, "wall_s": wall,
            "wall_per_sim_s": wall / traj.simulated_s if traj.simulated_s > 0 else float("nan"),
            "real_time_factor": traj.simulated_s / wall if wall > 0 else float("inf"),
            "us_per_step": us, "split_us": split, "pairs_per_step": pairs,
            "p_final": np.asarray(traj.p_WB[-1])[keep].tolist(), "q_final": np.asarray(traj.q_WB[-1])[keep].tolist()}


def with_errors(rows: list[dict]) -> list[dict]:
    """The rows with 'final_position_error_m' (largest over the block's containers [m]) and
    'final_angle_error_deg' against the reference model's row of the same pass, N and yard (NaN
    where either run did not complete, or there is no reference), the final states dropped."""
    def key(r):
        return r.get("pass", 1), r["n"], r.get("yard", "settled")

    reference = {key(r): r for r in rows if r["model"] == REFERENCE and r["status"] == "ok"}
    out = []
    for r in rows:
        r = dict(r)
        ref = reference.get(key(r))
        pos = ang = float("nan")
        if ref is not None and r["status"] == "ok" and abs(r["simulated_s"] - ref["simulated_s"]) < 0.5 * r["time_step_s"]:
            p, q = np.asarray(r["p_final"]), np.asarray(r["q_final"])
            pos = float(np.linalg.norm(p - np.asarray(ref["p_final"]), axis=1).max())
            ang = float(angle_between_quaternions_deg(q, np.asarray(ref["q_final"])).max())
        r.update(final_position_error_m=pos, final_angle_error_deg=ang)
        r.pop("p_final", None)
        r.pop("q_final", None)
        out.append(r)
    return out
