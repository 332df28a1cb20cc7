"""Runs a built scene and returns its records; writes a run directory on request."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator

from testbed.builder import BuiltScene, build_scene
from testbed.errors import SimulationError
from testbed.progress import progress as progress_bar
from testbed.records import atomic_directory, save_table, write_json
from testbed.scenario import Scenario, dump_scenario
from testbed.watchdog import run_watched


@dataclasses.dataclass
class RunResult:
    """What a run produced: tables (name -> columns), a summary, the final plant state."""

    scenario: Scenario
    tables: dict[str, dict[str, np.ndarray]]
    summary: dict
    final_positions: np.ndarray  # (nq,) plant generalized positions at the end
    body_names: list[str]
    files: dict = dataclasses.field(default_factory=dict)  # extra run files, name -> str | bytes
    out_dir: Path | None = None


def simulate(scene: BuiltScene, *, duration: float | None = None, progress: bool = False,
             stall_timeout: float | None = None) -> RunResult:
    """Simulates `scene` for `duration` [s] (default: the scenario's) and collects records.

    stall_timeout [s of wall time]: None runs here, in this process. A number runs the
    simulation under the watchdog (testbed/watchdog.py): in a forked child process that
    reports its simulated time after every step; if that time does not advance for
    `stall_timeout` seconds the child is stopped and StallError (a SimulationError) names
    the simulated time and the last system that ran. The child's effects hold the
    records, so this process's `scene.effects` stay empty; use the returned tables.
    """
    if stall_timeout is None:
        return _simulate_here(scene, duration=duration, progress=progress)

    duration = scene.scenario.duration if duration is None else duration
    payload = run_watched(scene, lambda report: _payload(_simulate_here(scene, duration=duration, monitor=report)),
                          stall_timeout=stall_timeout, duration=duration, progress=progress)
    return RunResult(scenario=scene.scenario, body_names=scene.body_names, **payload)


def _payload(result: RunResult) -> dict:
    """The parts of a RunResult a child process sends back (all picklable)."""
    return {"tables": result.tables, "summary": result.summary, "final_positions": result.final_positions,
            "files": result.files}


def _simulate_here(scene: BuiltScene, *, duration: float | None = None, progress: bool = False,
                   monitor=None) -> RunResult:
    """The run loop, in this process. monitor: optional callable(time [s]) run after
    every simulator step (the watchdog's heartbeat)."""
    scenario = scene.scenario
    duration = scenario.duration if duration is None else duration
    context = scene.create_context()
    simulator = Simulator(scene.diagram, context)
    ApplySimulatorConfig(scenario.simulator, simulator)
    if monitor is not None:
        simulator.set_monitor(lambda c: monitor(c.get_time()))
    simulator.Initialize()
    h = scenario.plant.time_step
    chunks = max(1, min(200, int(round(duration / h))))
    bar = None
    if progress:

        bar = progress_bar(total=round(duration, 9), unit="sim s", desc=scenario.name, leave=False,
                   bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} sim s [{elapsed}<{remaining}]")
    start = time.perf_counter()
    t0 = context.get_time()
    for k in range(1, chunks + 1):
        target = t0 + duration * k / chunks
        try:
            simulator.AdvanceTo(target)
        except RuntimeError as e:
            if bar is not None:
                bar.close()
            first_line = str(e).strip().splitlines()[0]
            raise SimulationError(
                f"scene '{scenario.name}': the simulation failed at t = {context.get_time():.4f} s: {first_line}"
            ) from e
        if bar is not None:
            bar.n = round(target - t0, 9)
            bar.refresh()
    wall = time.perf_counter() - start
    if bar is not None:
        bar.close()
    tables: dict[str, dict] = {}
    for effect in scene.effects.values():
        effect.collect(tables)
    steps = int(round(duration / h))
    summary = {
        "scene": scenario.name,
        "effects": list(scene.effects),
        "contact_model": scene.effects["contact"].config.model if "contact" in scene.effects else None,
        "approximation": scene.effects["contact"].config.approximation if "contact" in scene.effects else None,
        "time_step_s": h,
        "duration_s": duration,
        "steps": steps,
        "wall_time_s": wall,
        "real_time_factor": duration / wall if wall > 0 else float("inf"),
        "ms_per_sim_second": 1e3 * wall / duration,
        "finite_state": bool(np.all(np.isfinite(context.get_continuous_state_vector().CopyToVector()))
                             and np.all(np.isfinite(scene.plant.GetPositions(scene.plant.GetMyContextFromRoot(context))))),
    }
    for effect in scene.effects.values():
        summary.update(effect.summarize(tables))
    plant_context = scene.plant.GetMyContextFromRoot(context)
    files = {name: content for effect in scene.effects.values() for name, content in effect.files().items()}
    return RunResult(
        scenario=scenario, tables=tables, summary=summary,
        final_positions=scene.plant.GetPositions(plant_context).copy(), body_names=scene.body_names, files=files,
    )


def write_run(result: RunResult, out_dir: str | Path) -> Path:
    """Writes scenario.yaml, one .npz per table and summary.json; atomic (see records.py)."""
    with atomic_directory(out_dir) as tmp:
        (tmp / "scenario.yaml").write_text(dump_scenario(result.scenario))
        for name, table in result.tables.items():
            save_table(tmp / f"{name}.npz", table)
        write_json(tmp / "summary.json", {**result.summary, "body_names": result.body_names})
        for name, content in result.files.items():
            if isinstance(content, bytes):
                (tmp / name).write_bytes(content)
            else:
                (tmp / name).write_text(content)
    result.out_dir = Path(out_dir)
    return result.out_dir


def run_scenario(scenario: Scenario, *, out_dir=None, duration=None, progress=False, source="<scenario>",
                 stall_timeout: float | None = None) -> RunResult:
    """build -> simulate -> (write). The one-call entry point used by the CLI and studies.
    stall_timeout: see `simulate` (a stalled run raises before anything is written)."""
    scene = build_scene(scenario, source)
    result = simulate(scene, duration=duration, progress=progress, stall_timeout=stall_timeout)
    if out_dir is not None:
        write_run(result, out_dir)
    return result
