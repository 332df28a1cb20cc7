"""`testbed study scale`: what a yard of N containers costs with each contact model.

For each size N (a yard block of rows x bays x tiers of one container type, laid out by the
scene's `yards:` field, testbed/bodies/yards.py) and each contact model:

  hydroelastic     Drake's hydroelastic contact (the scene's own model): the reference
  point            Drake's point contact
  learned          the Drake-hosted learned closed loop (the `learned` engine: learned_dynamics)
  mujoco           MuJoCo with its contact parameters matched to Drake's hydroelastic contact
  mujoco_learned   the MuJoCo-hosted learned loop, when an engine of that name is registered
                   (looked up in testbed.engines at run time: absent, its cells read "unavailable")

one run of the yard from rest (the dynamics alone: no recorder, observer or viewer) gives

  - the wall time per simulated second [s/s] and per step [us] (only the stepping is timed:
    Drake's AdvanceTo calls, MuJoCo's mj_step), and its real-time factor (simulated / wall);
  - the per-step split [us]: the host engine's step; the learned system (reading the state,
    the broad phase, the force law, writing the forces); the predictor's batched call. For a
    learned loop it comes from the system's own timers (testbed/compare/costs.py; the host's
    step is the remainder); Drake's and MuJoCo's own contact is inside their step;
  - the final position error [m] (largest over the containers) and final angle error [deg]
    against the Drake hydroelastic run of the same yard and duration.

Every run is at the learned law's modulus (testbed.engines.three_way.at_law_modulus, as
`compare --engine all`), so every model is judged against one truth. The big sizes run a
shorter time (ScaleConfig.big_duration above big_above containers); the report says so.
A curve's growth exponent is the least-squares slope of log(us per step) on log(N) over the
sizes from `fit_from` up (runs that completed). Real time at a step h is h of wall per step.

The cells are independent: run_cell(task) is a module-level function, so a caller may map
them over processes or a Ray cluster (`testbed study scale --executor local|ray`, through
validate's executors); timings of cells run side by side share the machine, so the
default runs them one after the other in this process.
"""

from __future__ import annotations

import dataclasses
import math
import os
import platform
import time
from pathlib import Path

import numpy as np
import yaml

from testbed.bodies.containers import CONTAINER_TYPES
from testbed.document import Figure, Section, Text, figures, png, pyplot, table, to_html, to_markdown
from testbed.drake_support import drake_version
from testbed.engines import engines
from testbed.engines.base import UnsupportedSceneError
from testbed.engines.comparison import engine_variant
from testbed.engines.three_way import at_law_modulus
from testbed.errors import OptionalDependencyError, TestbedError
from testbed.geometry.rotations import angle_between_quaternions_deg
from testbed.progress import progress as progress_bar
from testbed.records import write_atomic, write_json
from testbed.scenario import load_scenario

SCHEMA = "testbed.study.scale/1"
MUJOCO_LEARNED = "mujoco_learned"  # the MuJoCo-hosted learned engine's registry name (it may be absent)
# model -> (engine name in testbed.engines, its params; None: the engine's default, "predictor": the config's)
MODELS = {"hydroelastic": ("drake", None), "point": ("drake", "point"), "learned": ("learned", "predictor"),
          "mujoco": ("mujoco", "matched"), "mujoco_learned": (MUJOCO_LEARNED, "predictor")}
LABELS = {"hydroelastic": "Drake hydroelastic", "point": "Drake point", "learned": "learned loop (in Drake)",
          "mujoco": "MuJoCo (matched)", "mujoco_learned": "learned loop (in MuJoCo)"}
REFERENCE = "hydroelastic"
SPLIT = ("engine_step", "learned_system", "predictor")  # the per-step parts [us]


class ScaleConfigError(TestbedError):
    """A scale study setting that cannot run (one line: the option and what it expects)."""


@dataclasses.dataclass(frozen=True)
class ScaleConfig:
    """The study's grid and its yards.

    sizes: containers per yard, each a multiple of `tiers` (N = rows x bays x tiers, the
    stacks laid out as square as N allows, rows <= bays); the yard's container type, gaps
    [m] and masses [kg] (drawn uniformly per container with `seed`, heaviest at the bottom
    of each stack) as testbed/bodies/yards.py; duration [s] simulated per run up to
    `big_above` containers, big_duration [s] above; time_step [s] of every engine; models:
    keys of MODELS; predictor: of both learned loops (None: each engine's default);
    fit_from: smallest N of the growth fits; repeats: a run shorter than repeat_below_s [s
    of wall] is repeated up to this many times and the fastest kept (the runs are
    deterministic; a short one is the most disturbed by other work on a shared machine)."""

    sizes: tuple[int, ...] = (4, 16, 48, 96, 192)
    tiers: int = 4
    container_type: str = "1AA"
    row_gap: float = 0.4  # [m]
    bay_gap: float = 0.6  # [m]
    mass_range: tuple[float, float] = (8000.0, 28000.0)  # [kg]
    seed: int = 29
    duration: float = 0.2  # [s]
    big_duration: float = 0.1  # [s]
    big_above: int = 96  # containers
    time_step: float = 1e-3  # [s]
    models: tuple[str, ...] = tuple(MODELS)
    predictor: str | None = None
    fit_from: int = 16
    repeats: int = 3
    repeat_below_s: float = 1.0  # [s]

    def duration_for(self, n: int) -> float:
        """[s] simulated in the runs of the N-container yard."""
        return self.big_duration if n > self.big_above else self.duration

    def validate(self) -> None:
        """Raises ScaleConfigError naming the setting for anything that cannot run."""
        if not self.sizes:
            raise ScaleConfigError("--sizes: expected at least one yard size")
        if not 1 <= self.tiers <= 12:
            raise ScaleConfigError(f"--tiers: expected 1 to 12 tiers, got {self.tiers}")
        bad = [n for n in self.sizes if not (isinstance(n, int) and n >= self.tiers and n % self.tiers == 0)]
        if bad:
            raise ScaleConfigError(f"--sizes: expected multiples of the {self.tiers} tiers (N = rows x bays x tiers), got {bad}")
        if max(self.sizes) > 1000:
            raise ScaleConfigError(f"--sizes: at most 1000 containers per yard, got {max(self.sizes)}")
        if len(set(self.sizes)) != len(self.sizes):
            raise ScaleConfigError(f"--sizes: a size is listed twice in {list(self.sizes)}")
        unknown = [m for m in self.models if m not in MODELS]
        if unknown or not self.models:
            raise ScaleConfigError(f"--models: unknown {unknown}; expected some of: {', '.join(MODELS)}")
        for name in ("duration", "big_duration", "time_step"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ScaleConfigError(f"--{name.replace('_', '-')}: expected a positive number of seconds, got {value}")
        if self.time_step > min(self.duration, self.big_duration):
            raise ScaleConfigError(f"--time-step: {self.time_step:g} s is longer than a run ({min(self.duration, self.big_duration):g} s)")
        if self.container_type not in CONTAINER_TYPES:
            raise ScaleConfigError(f"container type: unknown {self.container_type!r}; expected one of: {', '.join(CONTAINER_TYPES)}")
        if self.repeats < 1:
            raise ScaleConfigError(f"--repeats: expected at least 1, got {self.repeats}")


QUICK = ScaleConfig(sizes=(4, 8, 16), duration=0.03, big_duration=0.03, fit_from=4, repeats=1)


def layout(n: int, tiers: int) -> tuple[int, int, int]:
    """(rows, bays, tiers) of an N-container block: N / tiers stacks, rows the largest divisor
    of the stack count not above its square root (4 x 6 for 24 stacks, 1 x 7 for 7)."""
    stacks = n // tiers
    rows = max(d for d in range(1, math.isqrt(stacks) + 1) if stacks % d == 0)
    return rows, stacks // rows, tiers


def yard_scenario(n: int, config: ScaleConfig):
    """The N-container yard as a loaded Scenario (validated like a scene file), at the learned
    law's modulus, with the dynamics alone (every recorder, observer and viewer off), run for
    config.duration_for(n) [s] at config.time_step [s]."""
    rows, bays, tiers = layout(n, config.tiers)
    scene = {"name": f"yard_{rows}x{bays}x{tiers}", "description": f"{n} containers: {rows} rows x {bays} bays x {tiers} tiers",
             "duration": config.duration_for(n), "plant": {"time_step": config.time_step},
             "yards": [{"name": "blk", "type": config.container_type, "rows": rows, "bays": bays, "tiers": tiers,
                        "row_gap": config.row_gap, "bay_gap": config.bay_gap,
                        "mass_range": [float(m) for m in config.mass_range], "seed": config.seed}],
             "effects": {"contact": {"model": "hydroelastic_with_fallback", "approximation": "auto"}, "friction": {}}}
    return engine_variant(at_law_modulus(load_scenario(text=yaml.safe_dump(scene, sort_keys=False))), "truth")


def tasks(config: ScaleConfig) -> list[dict]:
    """The cells, smallest yard first, the models in config order: picklable dicts for run_cell."""
    asdict = dataclasses.asdict(config)
    return [{"config": asdict, "n": n, "model": m} for n in sorted(config.sizes) for m in config.models]


def _config(raw: dict) -> ScaleConfig:
    """A ScaleConfig from dataclasses.asdict (lists back to tuples, as after a JSON or Ray trip)."""
    fields = {f.name: f for f in dataclasses.fields(ScaleConfig)}
    return ScaleConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in raw.items() if k in fields})


def run_cell(task: dict) -> dict:
    """One (N, model) cell of `tasks`; never raises (a failure is the row's status).

    Returns {'n', 'layout' 'RxBxT', 'model', 'label', 'engine', 'params', 'status': 'ok' |
    'diverged' | 'refused' | 'unavailable' | 'error', 'why', 'duration_s', 'simulated_s',
    'steps', 'wall_s' (stepping only), 'wall_per_sim_s', 'real_time_factor', 'us_per_step',
    'split_us' {engine_step, learned_system, predictor: [us per step]; the last two None
    where the engine's own contact is inside its step}, 'pairs_per_step' (pairs the predictor
    answered, per step; None without one), 'runs' (timed repeats), 'version', and for the
    error against the reference 'p_final' (m, 3) [m] and 'q_final' (m, 4) wxyz of the free
    containers at the run's end}."""
    config = _config(task["config"])
    n, model = int(task["n"]), task["model"]
    engine_name, params = MODELS[model]
    params = config.predictor if params == "predictor" else params
    rows, bays, tiers = layout(n, config.tiers)
    row = {"n": n, "layout": f"{rows}x{bays}x{tiers}", "model": model, "label": LABELS[model], "engine": engine_name,
           "params": params, "duration_s": config.duration_for(n), "time_step_s": config.time_step, "why": ""}
    engine = engines().get(engine_name)
    if engine is None:
        return {**row, "status": "unavailable", "why": f"no engine named {engine_name!r} is registered"}
    try:
        why = engine.unavailable()
        if why is not None:
            return {**row, "status": "unavailable", "why": why}
        scenario = yard_scenario(n, config)
        engine.check(scenario)
        every = max(1, round(config.duration_for(n) / config.time_step))  # the start and the end: one record each
        runs = []
        while not runs or (len(runs) < config.repeats and runs[-1].trajectory.wall_s < config.repeat_below_s):
            runs.append(engine.run(scenario, record_every=every, params=params))
        best = min(runs, key=lambda r: r.trajectory.wall_s)
        version = best.summary.get("version") or (drake_version() if engine_name in ("drake", "learned") else "")
    except (UnsupportedSceneError, OptionalDependencyError, ImportError) as e:
        return {**row, "status": "unavailable", "why": _line(e)}
    except TestbedError as e:  # the build refused the yard (the learned loop's stability check, ...)
        return {**row, "status": "refused", "why": _line(e)}
    except Exception as e:  # noqa: BLE001 - a crashed cell is a result too
        return {**row, "status": "error", "why": f"{type(e).__name__}: {_line(e)}"}
    return {**row, **_figures(best.trajectory, config.time_step), "runs": len(runs), "version": version}


def _line(e: Exception) -> str:
    return (str(e).strip().splitlines() or [type(e).__name__])[0][:300]


def _figures(traj, h: float) -> dict:
    """run_cell's timing and final-state figures of a Trajectory (testbed.simulation)."""
    steps = int(round(traj.simulated_s / h))
    wall = float(traj.wall_s)
    us = 1e6 * wall / steps if steps else float("nan")
    if traj.costs and steps:  # a learned loop's own timers (testbed/compare/costs.py's calc_s, predict_s)
        calc, predict = traj.costs["calc_s"], traj.costs["predict_s"]
        # the host's step is the rest of the timed wall: recording is left out of it (it is 0 in
        # these runs, which drop the recorders; an engine may time its recording apart from wall_s)
        split = {"engine_step": 1e6 * max(0.0, wall - calc) / steps, "learned_system": 1e6 * max(0.0, calc - predict) / steps,
                 "predictor": 1e6 * predict / steps}
        pairs = traj.costs.get("predict_pairs", 0) / steps
    else:
        split, pairs = {"engine_step": us, "learned_system": None, "predictor": None}, None
    finite = bool(np.all(np.isfinite(traj.p_WB[-1])) and np.all(np.isfinite(traj.q_WB[-1])))
    failed = bool(traj.error) or not finite
    return {"status": "diverged" if failed else "ok", "why": traj.error or ("" if finite else "non-finite state"),
            "simulated_s": float(traj.simulated_s), "steps": steps, "wall_s": wall,
            "wall_per_sim_s": wall / traj.simulated_s if traj.simulated_s > 0 else float("nan"),
            "real_time_factor": traj.simulated_s / wall if wall > 0 else float("inf"),
            "us_per_step": us, "split_us": split, "pairs_per_step": pairs,
            "p_final": traj.p_WB[-1].tolist(), "q_final": traj.q_WB[-1].tolist()}


def with_errors(rows: list[dict]) -> list[dict]:
    """The rows with 'final_position_error_m' (largest over the containers [m]) and
    'final_angle_error_deg' against the reference model's row of the same N (NaN where either
    run did not complete, or there is no reference), the final states dropped."""
    reference = {r["n"]: r for r in rows if r["model"] == REFERENCE and r["status"] == "ok"}
    out = []
    for r in rows:
        r = dict(r)
        ref = reference.get(r["n"])
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


def growth_fits(rows: list[dict], models, fit_from: int) -> dict:
    """model -> {'exponent' b, 'prefactor_us' a of us_per_step ~ a N^b (least squares on
    log-log over the completed runs with N >= fit_from), 'sizes' used}; exponent NaN with
    fewer than two sizes."""
    out = {}
    for m in models:
        pts = sorted((r["n"], r["us_per_step"]) for r in rows
                     if r["model"] == m and r["status"] == "ok" and r["n"] >= fit_from and r["us_per_step"] > 0)
        if len({n for n, _ in pts}) < 2:
            out[m] = {"exponent": float("nan"), "prefactor_us": float("nan"), "sizes": [n for n, _ in pts]}
            continue
        x, y = np.log([n for n, _ in pts]), np.log([u for _, u in pts])
        b, log_a = np.polyfit(x, y, 1)
        out[m] = {"exponent": float(b), "prefactor_us": float(np.exp(log_a)), "sizes": [n for n, _ in pts]}
    return out


def run_study(config: ScaleConfig, *, map_cells=None, progress: bool = False, executor: str = "sequential") -> dict:
    """Runs every cell and returns the study's record (JSON-able): {'schema', 'config',
    'rows' (run_cell's, with errors: with_errors), 'fits' (growth_fits), 'environment',
    'executor', 'wall_s'}.

    map_cells: None runs the cells here one after the other; else a callable
    (fn, items, done) that calls done(fn(item)) for every item, in any order (e.g.
    testbed.validation.executors.map_calls), named by `executor` in the report."""
    config.validate()
    start = time.perf_counter()
    todo, results = tasks(config), []
    if map_cells is None:
        cells = progress_bar(todo, desc="scale study", unit="cell") if progress else todo
        results = [run_cell(t) for t in cells]
    else:
        map_cells(run_cell, todo, results.append)
    order = {(t["n"], t["model"]): i for i, t in enumerate(todo)}
    rows = with_errors(sorted(results, key=lambda r: order[r["n"], r["model"]]))
    versions = {r["engine"]: r["version"] for r in rows if r.get("version")}
    return {"schema": SCHEMA, "config": dataclasses.asdict(config), "rows": rows,
            "fits": growth_fits(rows, config.models, config.fit_from),
            "environment": {"python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count(),
                            "drake": drake_version(), "engines": versions},
            "executor": executor, "wall_s": time.perf_counter() - start}


# ----------------------------------------------------------------------------- report


def _f(value, spec: str, scale: float = 1.0) -> str:
    return "-" if value is None or not math.isfinite(value) else format(value * scale, spec)


TARGET_SIZES = (16, 96)  # the issue's exponent range [containers]
TARGET_EXPONENT = 1.2  # the learned loops' per-step growth from 16 to 96 containers, at most
TARGET_N = 96  # the yard of the real-time targets
TARGET_REAL_TIME = 2.0  # the MuJoCo-hosted learned loop's real-time factor there, at least
TARGET_VS_POINT = 10.0  # ... and its speed-up over Drake point contact there, at least
TARGET_POSITION_M, TARGET_ANGLE_DEG = 0.02, 0.5  # ... within these final errors against Drake hydroelastic


def targets(study: dict) -> list[dict]:
    """Issue 29's cost targets as measured in this study: [{'target', 'measured', 'met': True |
    False | None (not measured: a size or model missing)}]."""
    rows = {(r["n"], r["model"]): r for r in study["rows"] if r["status"] == "ok"}
    lo, hi = TARGET_SIZES
    out = []
    for m in ("learned", "mujoco_learned"):
        fit = growth_fits([r for r in study["rows"] if lo <= r["n"] <= hi], (m,), lo)[m]
        ok = math.isfinite(fit["exponent"]) and min(fit["sizes"]) == lo and max(fit["sizes"]) == hi
        out.append({"target": f"{LABELS[m]}: per-step growth exponent from N={lo} to {hi} <= {TARGET_EXPONENT:g}",
                    "measured": f"{fit['exponent']:.2f}" if ok else "not measured",
                    "met": (fit["exponent"] <= TARGET_EXPONENT) if ok else None})
    ml, pt = rows.get((TARGET_N, "mujoco_learned")), rows.get((TARGET_N, "point"))
    out.append({"target": f"{LABELS['mujoco_learned']} at N={TARGET_N}: >= {TARGET_REAL_TIME:g}x real time",
                "measured": f"{ml['real_time_factor']:.2f}x" if ml else "not measured",
                "met": (ml["real_time_factor"] >= TARGET_REAL_TIME) if ml else None})
    out.append({"target": f"{LABELS['mujoco_learned']} at N={TARGET_N}: >= {TARGET_VS_POINT:g}x faster than Drake point",
                "measured": f"{pt['us_per_step'] / ml['us_per_step']:.1f}x" if ml and pt else "not measured",
                "met": (pt["us_per_step"] / ml["us_per_step"] >= TARGET_VS_POINT) if ml and pt else None})
    ok = ml is not None and math.isfinite(ml["final_position_error_m"])
    out.append({"target": f"{LABELS['mujoco_learned']} at N={TARGET_N}: final position <= {TARGET_POSITION_M * 100:g} cm, "
                          f"angle <= {TARGET_ANGLE_DEG:g} deg from Drake hydroelastic",
                "measured": f"{ml['final_position_error_m'] * 1e3:.2f} mm, {ml['final_angle_error_deg']:.3f} deg" if ok else "not measured",
                "met": (ml["final_position_error_m"] <= TARGET_POSITION_M and ml["final_angle_error_deg"] <= TARGET_ANGLE_DEG)
                if ok else None})
    both = sorted(n for (n, m) in rows if m == "learned" and (n, "point") in rows)
    slower = [n for n in both if rows[n, "learned"]["us_per_step"] > rows[n, "point"]["us_per_step"]]
    out.append({"target": f"{LABELS['learned']}: no slower than Drake point at any size",
                "measured": ("slower at N = " + ", ".join(f"{n} ({rows[n, 'learned']['us_per_step'] / rows[n, 'point']['us_per_step']:.2f}x)"
                                                          for n in slower)) if slower else
                            (f"at most {max(rows[n, 'learned']['us_per_step'] / rows[n, 'point']['us_per_step'] for n in both):.2f}x point's "
                             "cost per step" if both else "not measured"),
                "met": (not slower) if both else None})
    return out


def report_sections(study: dict) -> list[Section]:
    """The study as document sections: key, the growth summary, the chart, the full table."""
    config, rows, fits = _config(study["config"]), study["rows"], study["fits"]
    h_us = 1e6 * config.time_step
    shorter = sorted(n for n in config.sizes if n > config.big_above)
    key = (f"Yard blocks of {config.container_type} containers, {config.tiers} tiers, {config.row_gap:g} m between rows, "
           f"{config.bay_gap:g} m between bays, masses drawn from {config.mass_range[0]:g}-{config.mass_range[1]:g} kg "
           f"(seed {config.seed}), from rest on the quay (they settle under their own weight: the errors measure "
           f"settling, not a landing or a push), at a {config.time_step * 1e3:g} ms step; every model at the "
           f"learned law's modulus, judged against the Drake hydroelastic run of the same yard and duration. "
           f"Runs of {config.duration:g} s simulated"
           + (f"; SHORTER at the big sizes: {config.big_duration:g} s at N = {', '.join(map(str, shorter))}" if shorter else "")
           + ". Wall time is the stepping alone (no recording). Split per step: the host engine's step (Drake's or MuJoCo's "
           "own contact is inside it), the learned system (state, broad phase, force law, forces) and the predictor's batched "
           f"call, from the learned system's own timers. Real time: {config.time_step * 1e3:g} ms of wall per "
           f"{config.time_step * 1e3:g} ms step ({h_us:g} us). Growth exponent: least-squares slope of log(us per step) "
           f"on log(N) over N >= {config.fit_from}.")
    how = ("one after the other in one process" if study["executor"] == "sequential" else
           f"through {study['executor']} (cells side by side share the machine: timings are disturbed)")
    runs = (f"Cells run {how}; "
            f"study wall time {study['wall_s']:.0f} s; {study['environment']['cpus']} CPUs, Drake {study['environment']['drake']}"
            + "".join(f", {k} {v}" for k, v in study["environment"]["engines"].items() if k not in ("drake", "learned")) + ".")
    largest = {m: max((r for r in rows if r["model"] == m and r["status"] == "ok"), key=lambda r: r["n"], default=None)
               for m in config.models}
    summary = []
    for m in config.models:
        big = largest[m]
        realtime = [r["n"] for r in rows if r["model"] == m and r["status"] == "ok" and r["us_per_step"] <= h_us]
        statuses = sorted({r["status"] + (f" ({r['why']})" if r["why"] else "") for r in rows if r["model"] == m and r["status"] != "ok"})
        summary.append([LABELS[m], _f(fits[m]["exponent"], ".2f"),
                        f"{_f(big['us_per_step'], '.0f')} us at N={big['n']}" if big else "-",
                        _f(big["real_time_factor"], ".2f") + "x" if big else "-",
                        str(max(realtime)) if realtime else "none",
                        _f(big["final_position_error_m"], ".3f", 1e3) if big else "-",
                        "; ".join(statuses)[:300] or "all ok"])
    full = []
    for r in rows:
        ok = r["status"] == "ok"
        s = r.get("split_us") or {}
        full.append([r["n"], r["layout"], LABELS[r["model"]], _f(r.get("simulated_s"), "g"),
                     _f(r.get("wall_per_sim_s"), ".3f") if ok else "-", _f(r.get("real_time_factor"), ".2f") if ok else "-",
                     _f(r.get("us_per_step"), ".0f") if ok else "-", *(_f(s.get(p), ".0f") if ok else "-" for p in SPLIT),
                     _f(r.get("pairs_per_step"), ".1f"), _f(r.get("final_position_error_m"), ".3f", 1e3),
                     _f(r.get("final_angle_error_deg"), ".4f"), r["status"] + (f": {r['why']}" if r["why"] else "")])
    return [
        Section("What a yard of N containers costs", [Text(key), Text(runs), table(
            ["model", f"growth exponent (N >= {config.fit_from})", "per step at the largest N", "real-time factor there",
             "largest N in real time", "final position error there [mm]", "not ok"], summary)], order=10),
        Section("Targets", [Text("Measured in this run, on this machine (timings are ratios within one run: "
                                            "other work on a shared machine slows every cell)."),
                                       table(["target", "measured", "met"],
                                             [[x["target"], x["measured"], {True: "yes", False: "NO", None: "-"}[x["met"]]]
                                              for x in targets(study)])], order=15),
        Section("Cost per step against N", [Figure("scale_cost.png", "cost per step against yard size, log-log",
                                                   cost_chart(rows, fits, config))], order=20),
        Section("Every cell", [table(["N", "rows x bays x tiers", "model", "simulated [s]", "wall / sim s [s]",
                                      "real-time factor", "us / step", "engine step [us]", "learned system [us]",
                                      "predictor [us]", "pairs / step", "final pos. error [mm]",
                                      "final angle error [deg]", "status"], full)], order=30),
    ]


def cost_chart(rows: list[dict], fits: dict, config: ScaleConfig) -> bytes:
    """PNG: us per step against N (log-log), a curve per model with its fitted growth
    exponent (dashed over the fitted sizes), and the real-time line (one step's length)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for i, m in enumerate(config.models):
        pts = sorted((r["n"], r["us_per_step"]) for r in rows if r["model"] == m and r["status"] == "ok")
        if not pts:
            continue
        fit = fits[m]
        label = LABELS[m] + (f" (N^{fit['exponent']:.2f})" if math.isfinite(fit["exponent"]) else "")
        line, = ax.plot(*zip(*pts), "o-", label=label, color=f"C{i}")
        if math.isfinite(fit["exponent"]):
            n = np.array([min(fit["sizes"]), max(fit["sizes"])], float)
            ax.plot(n, fit["prefactor_us"] * n ** fit["exponent"], "--", color=line.get_color(), alpha=0.6)
    h_us = 1e6 * config.time_step
    ax.axhline(h_us, color="k", lw=1, ls=":", label=f"real time ({config.time_step * 1e3:g} ms wall per {config.time_step * 1e3:g} ms step)")
    ax.set(xscale="log", yscale="log", xlabel="containers N", ylabel="wall time per step [us]",
           title="What a yard costs per step (dashed: least-squares fits)")
    sizes = sorted({r["n"] for r in rows})
    ax.set_xticks(sizes, [str(n) for n in sizes])
    ax.minorticks_off()
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8)
    return png(fig)


def write_report(study: dict, out) -> list[Path]:
    """Writes scale.json (the record), scale.md, scale.html (self-contained) and the chart
    scale_cost.png into directory `out` (made), each atomically; returns their paths."""
    out = Path(out)
    sections = report_sections(study)
    title = "Scale study: what a yard of N containers costs"
    paths = [write_atomic(out / f.file, f.png) for f in figures(sections)]
    write_json(out / "scale.json", study)
    paths += [out / "scale.json", write_atomic(out / "scale.md", to_markdown(title, sections)),
              write_atomic(out / "scale.html", to_html(title, sections))]
    return paths


def summary_lines(study: dict) -> list[str]:
    """The lines `testbed study scale` prints: one per model (exponent, cost at the largest N)."""
    config, h_us = _config(study["config"]), 1e6 * study["config"]["time_step"]
    lines = []
    for m in config.models:
        done = [r for r in study["rows"] if r["model"] == m and r["status"] == "ok"]
        if not done:
            why = next((r["why"] for r in study["rows"] if r["model"] == m), "")
            lines.append(f"{LABELS[m]:26s} no completed run ({why})")
            continue
        big = max(done, key=lambda r: r["n"])
        lines.append(f"{LABELS[m]:26s} N^{_f(study['fits'][m]['exponent'], '.2f'):5s} {big['us_per_step']:9.0f} us/step at "
                     f"N={big['n']:<4d} ({big['real_time_factor']:.2f}x real time, {h_us:g} us budget), final position "
                     f"error {_f(big['final_position_error_m'], '.3f', 1e3)} mm")
    return lines
