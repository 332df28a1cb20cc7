"""`testbed validate`: a suite of cases run in worker processes, one report.

A case is a small JSON-able description (`Case`): a worker builds its own diagram
from it (pydrake objects do not pickle), runs it and returns a JSON-able result.
Each result is written to `<run>/cases/<id>.json` (atomically) as soon as it
arrives, so a killed run loses nothing: `--resume <run>` recomputes only the
missing cases, and the report is rebuilt from the case files. The local executor
uses a process pool; the Ray executor sends the same function to a Ray cluster.

Run directory layout:
  suite.json     the suite's cases and options (what --resume reads)
  cases/*.json   one result per case
  metrics.json   all results + gate verdicts (schema: testbed/report_schema.json)
  summary.md     for terminals and CI logs
  index.html     self-contained report (plots embedded)
"""

import dataclasses
import json
import os
import sys
import time
import traceback
from pathlib import Path

from testbed.errors import TestbedError
from testbed.records import json_default as _json_default

SCHEMA_VERSION = "testbed.validate/1"


@dataclasses.dataclass(frozen=True)
class Case:
    id: str  # unique and file-name safe
    kind: str  # one of CASE_KINDS
    params: dict

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


# ----------------------------------------------------------------------------- suites


def scene_cases(scenes, models, duration) -> list[Case]:
    """Scene x contact model cases; duration None = each scene's own."""
    return [Case(f"scene-{s}-{m}", "scene", {"scene": s, "model": m, "duration": duration})
            for s in scenes for m in models]


SUITES = ("default", "full", "smoke")


def suite(name: str) -> list[Case]:
    """The cases of a named suite: 'default' fits 10 minutes on 2 cores, 'full' is for
    bigger machines, 'smoke' is a tiny deterministic suite for tests of the machinery."""
    if name == "smoke":
        cases = scene_cases(["two_stack", "bridge"], ["hydroelastic", "point"], 0.05)
        cases += [Case("sim-two_stack-point-sap", "sim_sweep", {
            "scene": "two_stack", "models": ["point"], "approximations": ["sap"],
            "time_steps": [2e-3, 5e-3], "reference_step": 1e-3, "duration": 0.05})]
        return cases
    if name == "default":
        cases = scene_cases(["two_stack", "five_stack", "bridge", "single_drop", "windy_stack", "nine_mixed_stack",
                             "crane_misaligned", "crane_hard_landing"], ["hydroelastic", "point"], None)
        cases += [Case(f"sim-two_stack-{m}-{a}", "sim_sweep", {
            "scene": "two_stack", "models": [m], "approximations": [a],
            "time_steps": [3e-4, 1e-3, 3e-3, 1e-2], "reference_step": 1e-4, "duration": 0.5})
            for m in ("hydroelastic", "point") for a in ("sap", "tamsi")]
        cases += [Case("effect-costs-five_stack", "effect_costs", {"scene": "five_stack", "duration": 0.3})]
        cases += [Case("query-study", "query_study", {"quick": True, "seed": 0})]
        cases += [Case("learned-gates", "learned_gates", {"seed": 0})]
        cases += stability_cases(quick=True)
        return cases
    if name == "full":
        from testbed.scenario import shipped_scenes

        cases = scene_cases(sorted(shipped_scenes()), ["hydroelastic", "point", "hydroelastic_with_fallback"], None)
        cases += [Case(f"sim-{s}-{m}-{a}", "sim_sweep", {
            "scene": s, "models": [m], "approximations": [a],
            "time_steps": [2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2], "reference_step": 1e-4, "duration": 1.0})
            for s in ("two_stack", "five_stack") for m in ("hydroelastic", "point")
            for a in ("sap", "tamsi", "similar", "lagged")]
        cases += [Case(f"effect-costs-{s}", "effect_costs", {"scene": s, "duration": 1.0}) for s in ("two_stack", "five_stack")]
        cases += [Case("query-study", "query_study", {"quick": False, "seed": 0})]
        cases += [Case("learned-gates", "learned_gates", {"seed": 0})]
        cases += stability_cases(quick=False)
        return cases
    raise TestbedError(f"--suite: unknown suite {name!r}; expected one of: {', '.join(SUITES)}")


def stability_cases(quick: bool, per_case: int = 6) -> list[Case]:
    """The stability matrix split into cases of `per_case` grid entries each."""
    from testbed.studies.stability import matrix_cases

    grid = [[name, kw] for name, kw in matrix_cases(quick=quick)]
    return [Case(f"stability-{i // per_case:02d}", "stability", {"entries": grid[i:i + per_case]})
            for i in range(0, len(grid), per_case)]


# ----------------------------------------------------------------------------- workers


def run_case(case: dict) -> dict:
    """Runs one case in the current process; never raises (errors become results)."""
    start = time.perf_counter()
    try:
        result = CASE_KINDS[case["kind"]](**case["params"])
        status = "ok"
    except Exception as e:  # reported per case; the suite goes on
        result = {"error": f"{type(e).__name__}: {e}".splitlines()[0], "traceback": traceback.format_exc()}
        status = "error"
    return {**case, "status": status, "result": result, "wall_s": time.perf_counter() - start}


def _scene_case(scene: str, model: str, duration: float) -> dict:
    import numpy as np

    from testbed.effects import registry
    from testbed.scenario import load_scenario
    from testbed.simulation import run_scenario

    scenario = load_scenario(scene, overrides=[f"effects.contact.model={model}", "effects.contact_log={}",
                                                "effects.shadow_contact={}"])
    learned_available = True
    try:
        import learned_contact  # noqa: F401  (numpy-only)

        scenario.effects.learned_contact = registry()["learned_contact"].Config()
    except Exception:
        learned_available = False
    result = run_scenario(scenario, duration=duration)
    summary = dict(result.summary)
    c = result.tables["contacts"]
    ground = result.body_names.index("quay_ground") if "quay_ground" in result.body_names else -1
    weight = sum(s.total_mass() for s in scenario.containers if not s.fixed) * 9.81
    late = (c["time"] >= c["time"].max() - REST_WINDOW_S) & (c["a"] == ground) if len(c["time"]) else np.zeros(0, bool)
    steps = np.unique(c["step"][late]).size
    summary["ground_force_over_weight"] = float(c["fn"][late].sum() / steps / weight) if steps else float("nan")
    resting = c["time"] >= c["time"].max() - REST_WINDOW_S if len(c["time"]) else np.zeros(0, bool)
    summary["resting_penetration_m"] = float(max(0.0, -np.nanmin(c["phi"][resting]))) if np.any(resting) else 0.0
    summary["learned_available"] = learned_available
    return summary


def _sim_sweep_case(scene, models, approximations, time_steps, reference_step, duration) -> dict:
    from testbed.studies.sim import sweep

    return {"rows": sweep(scene, models=models, approximations=approximations, time_steps=time_steps,
                          reference_step=reference_step, duration=duration)}


def _effect_costs_case(scene, duration) -> dict:
    from testbed.studies.sim import effect_costs

    return {"scene": scene, "rows": effect_costs(scene, duration=duration)}


def _query_study_case(quick, seed) -> dict:
    import tempfile

    from testbed.studies.query import run_query_study

    with tempfile.TemporaryDirectory() as tmp:
        metrics = run_query_study(Path(tmp), quick=quick, seed=seed, progress=False)
        png = Path(tmp) / "query_pareto.png"
        image = png.read_bytes().hex() if png.exists() else None
    return {"metrics": metrics, "pareto_png_hex": image}


def _learned_gates_case(seed) -> dict:
    from learned_contact.gates import evaluate_gates

    return evaluate_gates(seed=seed)


def _stability_case(entries) -> dict:
    from testbed.studies.stability import run_matrix_entry

    return {"rows": [run_matrix_entry(name, kw) for name, kw in entries]}


CASE_KINDS = {
    "stability": _stability_case,
    "scene": _scene_case,
    "sim_sweep": _sim_sweep_case,
    "effect_costs": _effect_costs_case,
    "query_study": _query_study_case,
    "learned_gates": _learned_gates_case,
}

# Rest figures of scene cases (force balance, resting penetration) are averaged over the
# last REST_WINDOW_S of the run: point contact hops between corners step to step, and
# 0.5 s holds several hops (the same window as tests/test_physics_rest.py).
REST_WINDOW_S = 0.5

# Cases run in the main process, after the others: effect costs measure Meshcat,
# which must not start in a worker, and time ratios that parallel cases would disturb.
MAIN_PROCESS_KINDS = ("effect_costs",)

# Result fields that measure time: they differ between runs, everything else is
# deterministic (the resume test compares reports without them).
TIMING_KEYS = ("wall_s", "wall_time_s", "real_time_factor", "ms_per_sim_second", "bare_wall_s", "effect_wall_s",
               "ratio", "recording_cost_ratio", "pareto_png_hex", "pareto", "markdown", "throughput_us_per_pair",
               "created")
_TIMING_FRAGMENTS = ("time_us", "_ms", "_us", "wall")


def is_timing_key(key: str) -> bool:
    """Whether a result field measures time (so may differ between two identical runs)."""
    return key in TIMING_KEYS or any(fragment in key for fragment in _TIMING_FRAGMENTS)


# ----------------------------------------------------------------------------- executors


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.partial-{os.getpid()}")
    tmp.write_text(text)
    os.replace(tmp, path)


def _case_path(run_dir: Path, case_id: str) -> Path:
    return run_dir / "cases" / f"{case_id}.json"


def execute(cases: list[Case], run_dir: Path, *, executor: str = "local", workers: int = 2,
            address: str | None = None, progress: bool = True) -> None:
    """Runs the cases without a result file in run_dir/cases/, writing each as it finishes."""
    (run_dir / "cases").mkdir(parents=True, exist_ok=True)
    pending = [c for c in cases if not _case_path(run_dir, c.id).exists()]
    if not pending:
        return
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(cases), initial=len(cases) - len(pending), desc="validate", unit="case")

    def done(result: dict) -> None:
        _write_atomic(_case_path(run_dir, result["id"]), json.dumps(result, indent=1, default=_json_default))
        if bar is not None:
            bar.set_postfix_str(result["id"])
            bar.update(1)

    if executor not in ("local", "ray"):
        raise TestbedError(f"--executor: unknown executor {executor!r}; expected one of: local, ray")
    here = [c for c in pending if c.kind in MAIN_PROCESS_KINDS]
    pooled = [c for c in pending if c.kind not in MAIN_PROCESS_KINDS]
    if executor == "local":
        _execute_local(pooled, workers, done)
    else:
        _execute_ray(pooled, address, done)
    for case in here:  # after the pool, alone on the machine: their timings are not disturbed
        done(run_case(case.to_dict()))
    if bar is not None:
        bar.close()


def _execute_local(cases, workers, done) -> None:
    if workers <= 1:
        for case in cases:
            done(run_case(case.to_dict()))
        return
    import concurrent.futures
    import multiprocessing

    context = multiprocessing.get_context("spawn")  # no fork of a process holding Drake state
    with concurrent.futures.ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        futures = [pool.submit(run_case, case.to_dict()) for case in cases]
        for future in concurrent.futures.as_completed(futures):
            done(future.result())


def _execute_ray(cases, address, done) -> None:
    try:
        import ray
    except ImportError:
        from testbed.errors import OptionalDependencyError

        raise OptionalDependencyError("ray", "--executor ray", "ray") from None
    started_here = not ray.is_initialized()
    if started_here:
        ray.init(address=address, include_dashboard=False, log_to_driver=False, ignore_reinit_error=True)
    try:
        remote = ray.remote(num_cpus=1)(run_case)
        futures = [remote.remote(case.to_dict()) for case in cases]
        while futures:
            ready, futures = ray.wait(futures, num_returns=1)
            done(ray.get(ready[0]))
    finally:
        if started_here:
            ray.shutdown()


# ----------------------------------------------------------------------------- entry


def validate(*, suite_name: str = "default", workers: int = 2, executor: str = "local", address=None,
             resume: str | Path | None = None, out_root: str | Path = "reports", progress: bool = True,
             cases: list[Case] | None = None, replays: int = 2) -> tuple[Path, dict]:
    """Runs (or resumes) a suite and writes the report, with Meshcat replays of the
    `replays` worst learned cases. Returns (run_dir, metrics)."""
    from testbed.report import write_report

    if resume is not None:
        run_dir = Path(resume)
        spec_path = run_dir / "suite.json"
        if not spec_path.is_file():
            raise TestbedError(f"--resume {run_dir}: no suite.json there; expected a run directory made by testbed validate")
        spec = json.loads(spec_path.read_text())
        cases = [Case(**c) for c in spec["cases"]]
    else:
        cases = cases if cases is not None else suite(suite_name)
        stamp = time.strftime("%Y%m%d-%H%M%S")
        run_dir = Path(out_root) / stamp
        suffix = 1
        while run_dir.exists():
            run_dir = Path(out_root) / f"{stamp}-{suffix}"
            suffix += 1
        run_dir.mkdir(parents=True)
        spec = {"schema": SCHEMA_VERSION, "suite": suite_name, "cases": [c.to_dict() for c in cases]}
        _write_atomic(run_dir / "suite.json", json.dumps(spec, indent=1))
    if workers < 1:
        raise TestbedError(f"--workers: expected at least 1, got {workers}")
    execute(cases, run_dir, executor=executor, workers=workers, address=address, progress=progress)
    results = [json.loads(_case_path(run_dir, c.id).read_text()) for c in cases]
    write_worst_replays(run_dir, results, replays)
    metrics = write_report(run_dir, spec, results)
    return run_dir, metrics


def worst_learned_cases(results: list[dict], n: int) -> list[dict]:
    """The n scene cases with the largest learned point error (against the hydroelastic answer)."""
    scored = [r for r in results if r["kind"] == "scene" and r["status"] == "ok"
              and r["result"].get("learned_vs_hydro_point_error_max_m") is not None]
    scored.sort(key=lambda r: -r["result"]["learned_vs_hydro_point_error_max_m"])
    return scored[:n]


def write_worst_replays(run_dir: Path, results: list[dict], n: int) -> None:
    """Re-runs the n worst learned cases in this process with the Meshcat recording and
    writes replays/<case id>/replay.html (a replay that exists is kept, so --resume
    does not redo it). Failures are written to replays/<case id>/error.txt."""
    for r in worst_learned_cases(results, n):
        out = run_dir / "replays" / r["id"]
        if (out / "replay.html").exists():
            continue
        try:
            from testbed.viewer import view

            p = r["params"]
            overrides = [f"effects.contact.model={p['model']}", "effects.contact_log={}", "effects.shadow_contact={}",
                         "effects.learned_contact={}", "effects.meshcat={port: 0, record: true}"]
            view(p["scene"], port=0, rate=0, overrides=overrides, duration=p["duration"], out=out, serve=False,
                 stream=open(os.devnull, "w"))
        except Exception as e:  # the report says why instead of losing the run
            out.mkdir(parents=True, exist_ok=True)
            (out / "error.txt").write_text(f"{type(e).__name__}: {e}\n")


if __name__ == "__main__":  # python -m testbed.validate: a convenience for debugging
    from testbed.cli import main

    sys.exit(main(["validate", *sys.argv[1:]]))
