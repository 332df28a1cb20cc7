"""Runs a built scene: the one sampled-run loop, and the full run with its records.

`advance` is the project's one simulator loop: it advances a simulator through a list of
sample times, calling `on_sample` at each, and times only the stepping. Its failure
convention, the same for every caller: anything the simulator or a system raises (Drake's
solver, a predictor) or a plant state that turns non-finite ends the run at that sample;
the samples up to then are kept and the returned Failure says what happened (`simulate`
turns it into a SimulationError, `record_run` into Trajectory.error, the simulation study
into its row's status). Recorded runs sample every records.RECORD_PERIOD of simulated time.

`record_run` records, for the m free containers of a built scene, every `record_every`
plant steps: p_WB (m, 3) [m], q_WB (m, 4) (w, x, y, z), V_WB (m, 6) [rad/s, m/s]
(angular, linear; of the body origin, in W) and the mechanical energy (kinetic + gravity
potential) [J]; a learned run also keeps its system's cost counters over the timed steps.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator

from testbed.builder import BuiltScene, build_scene
from testbed.errors import SimulationError, TestbedError
from testbed.progress import progress as progress_bar
from testbed.records import atomic_directory, save_table, write_json
from testbed.scenario import Scenario, dump_scenario
from testbed.watchdog import run_watched


@dataclasses.dataclass
class Failure:
    """How a run ended early: status 'diverged' (something raised: `kind` is the exception's
    type name) or 'non-finite' (the plant's positions); message: one line; time [s]."""

    status: str
    message: str
    time: float
    kind: str = ""

    def describe(self) -> str:
        """'<Type>: <first line>' for a raise, 'non-finite state' for a non-finite state."""
        return f"{self.kind}: {self.message}" if self.status == "diverged" else "non-finite state"


def advance(simulator, times, on_sample, *, positions=None) -> tuple[float, Failure | None]:
    """The one loop: for each t of `times` [s], AdvanceTo(t), then (while `positions()`, the
    plant's generalized positions, are finite) on_sample(t). Returns (wall time [s] of the
    AdvanceTo calls alone, None | Failure); see the module doc for the failure convention.
    An input error (a TestbedError other than a SimulationError) is not a failure of the
    run: it propagates."""
    wall = 0.0
    for t in times:
        start = time.perf_counter()
        try:
            simulator.AdvanceTo(t)
        except Exception as e:  # noqa: BLE001 - Drake's solver or a system (a predictor): the run failed
            wall += time.perf_counter() - start
            if isinstance(e, TestbedError) and not isinstance(e, SimulationError):
                raise
            return wall, Failure("diverged", (str(e).strip().splitlines() or [""])[0],
                                 simulator.get_context().get_time(), type(e).__name__)
        wall += time.perf_counter() - start
        if positions is not None and not np.all(np.isfinite(positions())):
            return wall, Failure("non-finite", "the state turned non-finite", simulator.get_context().get_time())
        on_sample(t)
    return wall, None


RUN_EVENTS = ("crane_release_time_s",)  # the run summary's keys a Trajectory keeps (Trajectory.events)


@dataclasses.dataclass
class Trajectory:
    """Recorded states of one run (n records, m free containers; shapes in the module doc)."""

    time: np.ndarray  # (n,) [s]
    p_WB: np.ndarray  # (n, m, 3)
    q_WB: np.ndarray  # (n, m, 4)
    V_WB: np.ndarray  # (n, m, 6)
    energy: np.ndarray  # (n,) [J]
    potential: np.ndarray  # (n,) [J]
    wall_s: float  # wall time of the simulation alone
    simulated_s: float
    error: str = ""  # how a failed run ended (Failure.describe), else ""
    names: tuple = ()
    # a learned run's LearnedDynamics.costs() over the timed steps (testbed/compare/costs.py); else {}
    costs: dict = dataclasses.field(default_factory=dict)
    # what the run decided that its states do not hold, RUN_EVENTS keys: crane_release_time_s [s] when the
    # twistlocks released (None: held throughout); a key absent: not recorded (testbed/compare/external_work.py)
    events: dict = dataclasses.field(default_factory=dict)

    @classmethod
    def from_steps(cls, steps: dict, every: int, summary: dict, error: str, names) -> "Trajectory":
        """Another engine's per-step table `steps` (step, time [s], p_WB, q_WB, V_WB, kinetic_energy,
        potential_energy [J]) on the grid of every `every` steps; summary: its wall_time_s [s],
        steps and time_step_s [s]; error: how it failed ("" if it did not)."""
        keep = np.flatnonzero(steps["step"] % every == 0)
        energy = steps["kinetic_energy"] + steps["potential_energy"]
        return cls(time=steps["time"][keep], p_WB=steps["p_WB"][keep], q_WB=steps["q_WB"][keep],
                   V_WB=steps["V_WB"][keep], energy=energy[keep], potential=steps["potential_energy"][keep],
                   wall_s=summary["wall_time_s"], simulated_s=summary["steps"] * summary["time_step_s"], error=error,
                   names=tuple(names), events={k: summary[k] for k in RUN_EVENTS if k in summary})


def start(scene: BuiltScene):
    """(simulator, context, plant context) of a fresh run of `scene`, initialized."""
    context = scene.create_context()
    simulator = Simulator(scene.diagram, context)
    ApplySimulatorConfig(scene.scenario.simulator, simulator)
    simulator.Initialize()
    return simulator, context, scene.plant.GetMyContextFromRoot(context)


def record_run(scene: BuiltScene, duration: float, every: int) -> Trajectory:
    """Simulates a built `scene` for `duration` [s], recording every `every` plant steps
    (and at t = 0). A failing run ends early with `error` set; its records are kept."""
    plant = scene.plant
    simulator, context, plant_context = start(scene)
    learned = scene.effects.get("learned_dynamics")
    system = getattr(learned, "system", None)
    if system is not None:
        system.reset_costs()  # count only the timed steps below, not the build or Initialize
    bodies = [scene.bodies[n] for n in scene.free_names]
    h = scene.scenario.plant.time_step  # [s] the record grid (a continuous truth rung: its event period)
    rows = []

    def record(_t=None):
        poses = [plant.EvalBodyPoseInWorld(plant_context, b) for b in bodies]
        vels = [plant.EvalBodySpatialVelocityInWorld(plant_context, b) for b in bodies]
        potential = plant.CalcPotentialEnergy(plant_context)
        rows.append((context.get_time(), [X.translation() for X in poses],
                     [X.rotation().ToQuaternion().wxyz() for X in poses],
                     [np.concatenate([V.rotational(), V.translational()]) for V in vels],
                     plant.CalcKineticEnergy(plant_context) + potential, potential))

    record()
    times = [k * every * h for k in range(1, int(round(duration / h)) // every + 1)]
    wall, failure = advance(simulator, times, record, positions=lambda: plant.GetPositions(plant_context))
    t, p, q, V, E, PE = zip(*rows)
    m = len(bodies)
    return Trajectory(np.array(t), np.array(p).reshape(-1, m, 3), np.array(q).reshape(-1, m, 4),
                      np.array(V).reshape(-1, m, 6), np.array(E), np.array(PE), wall, t[-1],
                      failure.describe() if failure else "", tuple(scene.free_names),
                      system.costs() if system is not None else {},
                      {k: v for e in scene.effects.values() if hasattr(e, "run_events") for k, v in e.run_events(context).items()})


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
    """The full run, in this process: `advance` over up to 200 chunks (the progress bar's
    ticks). monitor: optional callable(time [s]) run after every simulator step (the
    watchdog's heartbeat). A Failure raises SimulationError."""
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
    t0 = context.get_time()

    def tick(target):
        if bar is not None:
            bar.n = round(target - t0, 9)
            bar.refresh()

    plant_context = scene.plant.GetMyContextFromRoot(context)
    wall, failure = advance(simulator, [t0 + duration * k / chunks for k in range(1, chunks + 1)], tick,
                            positions=lambda: scene.plant.GetPositions(plant_context))
    if bar is not None:
        bar.close()
    if failure is not None:
        raise SimulationError(f"scene '{scenario.name}': the simulation failed at t = {failure.time:.4f} s: "
                              f"{failure.message}")
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
                             and np.all(np.isfinite(scene.plant.GetPositions(plant_context)))),
    }
    for effect in scene.effects.values():
        summary.update(effect.summarize(tables))
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
