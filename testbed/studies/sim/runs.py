"""Simulation-level study: what whole simulations cost against how accurate they are.

In the manner of Erez, Tassa and Todorov (2015, "Simulation tools for model-based
robotics"): for a scene, sweep the time step, the contact model and the discrete
approximation; accuracy is the deviation of the trajectory from a fine-step
reference of the same model and approximation, plus the maximum penetration and the
energy drift; cost is wall time per simulated second. Each sweep point keeps the
scene's PHYSICS effects (testbed.effects.Role: contact, friction, wind, the crane, ...)
and drops its recorders, observers and viewers. `effect_costs` measures what each
effect costs: wall time with one effect switched on against the bare scene (its
`default_on` effects), the two runs made side by side in one process.

Trajectories are sampled every RECORD_PERIOD (testbed.simulation) by the one sampled-run
loop, `advance` (no logging system is added, so the timing is the bare simulation's).

Other engines' curves (`engines` naming registered engines besides "drake": testbed/engines,
e.g. MuJoCo with both its contact-parameter sets): the same scene simulated by that engine
over the same time-step sweep, its deviation measured against the fine-step Drake reference
of the scene's own contact model (the ground truth), so that every engine's curves sit on
one chart.
"""

import numpy as np

from testbed import variants
from testbed.builder import build_scene
from testbed.contact.extraction import near_distances
from testbed.effects import registry
from testbed.engines import engines as registered_engines
from testbed.errors import OptionalDependencyError, TestbedError
from testbed.progress import progress as progress_bar
from testbed.records import RECORD_PERIOD, steps_per_record
from testbed.scenario import Scenario, load_scenario
from testbed.simulation import advance, simulate, start

TIMING_REPEATS = 3  # other engines' sweep points: the fastest of this many identical runs is timed (ms each)


def configure(scenario: Scenario, *, model: str, approximation: str, time_step: float,
              duration: float, keep_effects=None) -> Scenario:
    """A copy of `scenario` with the given contact settings and only `keep_effects`
    (names; None: every PHYSICS effect the scene declares)."""
    keep = variants.physics_only() if keep_effects is None else variants.keep_effects(keep_effects)
    return variants.derive(scenario, variants.timing(time_step=time_step, duration=duration), keep,
                           variants.contact(model, approximation))


def sampled_run(scenario: Scenario) -> dict:
    """Simulates, sampling positions, penetration and energy every RECORD_PERIOD.

    Returns {'wall_s', 'ms_per_sim_second', 'times' (k,), 'p_WB' (k, m, 3) free-body
    origins [m], 'min_phi' (k,) [m] smallest signed distance among near pairs,
    'energy' (k,) [J], 'status': 'ok' | 'diverged' | 'non-finite', 'failure': str}.
    Sampling work is excluded from the wall time.
    """
    scene = build_scene(scenario)
    plant = scene.plant
    simulator, _, plant_context = start(scene)
    free = [scene.bodies[n] for n in scene.free_names]
    samples = {"times": [], "p_WB": [], "min_phi": [], "energy": []}

    def sample(t):
        samples["times"].append(t)
        samples["p_WB"].append([plant.EvalBodyPoseInWorld(plant_context, b).translation() for b in free])
        query = plant.get_geometry_query_input_port().Eval(plant_context)
        distances = list(near_distances(query).values())  # closed form: bounded time when boxes slide
        samples["min_phi"].append(min(distances) if distances else np.inf)
        samples["energy"].append(plant.EvalKineticEnergy(plant_context) + plant.EvalPotentialEnergy(plant_context))

    times = np.arange(0.0, scenario.duration + 1e-12, RECORD_PERIOD)
    wall, failure = advance(simulator, times, sample, positions=lambda: plant.GetPositions(plant_context))
    out = {k: np.asarray(v, dtype=float) for k, v in samples.items()}
    simulated = out["times"][-1] if len(out["times"]) else 0.0
    out.update(wall_s=wall, status=failure.status if failure else "ok", failure=failure.message if failure else "",
               ms_per_sim_second=1e3 * wall / simulated if simulated > 0 else float("nan"))
    return out


def engine_sampled_run(engine, scenario: Scenario, params: str | None = None) -> dict:
    """sampled_run's keys for a registered `engine` (testbed/engines) other than Drake's
    truth: its run recorded every RECORD_PERIOD in whole steps, 'min_phi' from its contact
    rows, status 'ok' | 'diverged' (the run's error is 'failure'), the wall time its own.
    Time step and duration are the scenario's (`configure` sets them)."""
    h = scenario.plant.time_step
    run = engine.run(scenario, record_every=steps_per_record(h), params=params, contacts=True)
    traj, contacts = run.trajectory, run.contacts
    steps = np.rint(traj.time / h).astype(int)
    min_phi = np.full(int(max(steps.max(initial=0), contacts["step"].max(initial=0))) + 1, np.inf)
    np.minimum.at(min_phi, contacts["step"], contacts["phi"])
    simulated = traj.simulated_s
    return {"times": traj.time, "p_WB": traj.p_WB, "min_phi": min_phi[steps], "energy": traj.energy,
            "wall_s": traj.wall_s, "ms_per_sim_second": 1e3 * traj.wall_s / simulated if simulated > 0 else float("nan"),
            "status": "diverged" if traj.error else "ok", "failure": traj.error}


def deviation(run: dict, reference: dict) -> float:
    """RMS over common samples and bodies of the position difference [m] (inf if diverged).
    Samples are matched by time: a run sampled on another grid (MuJoCo keeps every
    round(RECORD_PERIOD / h)-th step) is interpolated linearly onto the reference's times
    within its own time span."""
    if run["status"] != "ok" or len(run["times"]) == 0 or len(reference["times"]) == 0:
        return float("inf")
    k = min(len(run["times"]), len(reference["times"]))
    if np.allclose(run["times"][:k], reference["times"][:k], atol=1e-9):
        diff = run["p_WB"][:k] - reference["p_WB"][:k]
    else:
        t = reference["times"][reference["times"] <= run["times"][-1] + 1e-12]
        flat = run["p_WB"].reshape(len(run["times"]), -1)  # (k_run, 3 m) [m]
        moved = np.stack([np.interp(t, run["times"], flat[:, j]) for j in range(flat.shape[1])], axis=1)
        diff = moved.reshape(len(t), -1, 3) - reference["p_WB"][:len(t)]
    return float(np.sqrt(np.mean(np.sum(diff**2, axis=-1))))


def summarize_run(run: dict, reference: dict | None) -> dict:
    """JSON-able figures of one sweep point."""
    energy = run["energy"]
    contact_energy = energy[0] if len(energy) else np.nan
    return {
        "status": run["status"], "failure": run["failure"],
        "ms_per_sim_second": run["ms_per_sim_second"],
        "deviation_m": deviation(run, reference) if reference is not None else 0.0,
        "max_penetration_m": float(max(0.0, -np.min(run["min_phi"]))) if len(run["min_phi"]) else float("nan"),
        "energy_gain_J": float(np.max(energy - contact_energy)) if len(energy) else float("nan"),
        "energy_drift_J": float(energy[-1] - energy[0]) if len(energy) else float("nan"),
    }


def sweep(scene: str, *, models, approximations, time_steps, reference_step: float, duration: float,
          progress: bool = False, engines=("drake",), params=None) -> list[dict]:
    """Runs the grid; each row is one (engine, model, approximation, time_step) with its figures.

    engines: names of registered engines (testbed/engines). "drake" sweeps every (model,
    approximation) against its own fine-step reference; any other sweeps that engine with
    each of `params` (None: its param_sets; rows: model = the engine's name, approximation
    = the parameter set) against the fine-step Drake reference of the scene's own contact
    model and approximation. An engine that is not installed or a scene it cannot
    translate gives rows with status "unavailable: <why>"."""
    known = registered_engines()
    unknown = set(engines) - set(known)
    if unknown:
        raise TestbedError(f"engines: unknown {sorted(unknown)}; expected some of: {', '.join(known)}")
    base = load_scenario(scene)
    rows, references = [], {}

    def reference_of(model, approximation):
        if (model, approximation) not in references:
            references[model, approximation] = sampled_run(configure(
                base, model=model, approximation=approximation, time_step=reference_step, duration=duration))
        return references[model, approximation]

    combos = [(m, a) for m in models for a in approximations] if "drake" in engines else []
    iterator = combos
    if progress:

        iterator = progress_bar(combos, desc=f"sim study {scene}", leave=False)
    for model, approximation in iterator:
        reference = reference_of(model, approximation)
        for h in time_steps:
            run = sampled_run(configure(base, model=model, approximation=approximation, time_step=h, duration=duration))
            rows.append({"scene": scene, "engine": "drake", "model": model, "approximation": approximation,
                         "time_step": h, "reference_step": reference_step, **summarize_run(run, reference)})
    for name, engine in known.items():
        if name in engines and not engine.reference:
            rows += _engine_rows(engine, base, scene, time_steps, duration, reference_step, params, reference_of)
    return rows


def _engine_rows(engine, base, scene, time_steps, duration, reference_step, params, reference_of) -> list[dict]:
    """One engine's sweep rows (see sweep); the reference is Drake's, of the scene's own model."""
    model, approximation = base.effects.contact.model, base.effects.contact.approximation
    params_sets = params or engine.param_sets or (None,)
    head = {"scene": scene, "engine": engine.name, "model": engine.name, "reference_step": reference_step,
            "reference": f"drake {model} {approximation} h={reference_step:g}"}
    try:
        why = engine.unavailable()
        if why is None:
            engine.check(base)
    except (ImportError, OptionalDependencyError, ValueError) as e:  # UnsupportedSceneError is a ValueError
        why = str(e).strip().splitlines()[0]
    if why is not None:
        return [{**head, "approximation": p, "time_step": h, "status": f"unavailable: {why}", "failure": why,
                 "ms_per_sim_second": float("nan"), "deviation_m": float("nan"), "max_penetration_m": float("nan"),
                 "energy_gain_J": float("nan"), "energy_drift_J": float("nan")}
                for p in params_sets for h in time_steps]
    reference = reference_of(model, approximation)
    rows = []
    for p in params_sets:
        for h in time_steps:
            s = configure(base, model=model, approximation=approximation, time_step=h, duration=duration)
            # a run of another engine lasts milliseconds, so one preemption on a shared machine can
            # triple the time: the fastest of TIMING_REPEATS identical (deterministic) runs is kept.
            run = min((engine_sampled_run(engine, s, p) for _ in range(TIMING_REPEATS)), key=lambda r: r["wall_s"])
            rows.append({**head, "approximation": p, "time_step": h, **summarize_run(run, reference)})
    return rows


def effect_costs(scene: str, *, effects=None, duration: float = 0.5, repeats: int = 2) -> list[dict]:
    """Wall-time ratio (scene + one effect) / (bare scene), measured side by side.

    effects: names; None: every registered effect that is not `default_on` and is
    `measured_alone` (recorders, observers, viewers, wind). "Bare" keeps only the
    `default_on` effects (contact and friction). Effects that need others
    (learned_contact needs contact_log) are measured with what they need, and the row
    says so. Each effect is switched on with its `study_config()`. The minimum over
    `repeats` alternating runs of each is used (least disturbed by noise).
    """
    if effects is None:
        effects = [n for n, cls in registry().items() if not cls.default_on and cls.measured_alone]
    base = load_scenario(scene)
    bare = configure(base, model=base.effects.contact.model, approximation=base.effects.contact.approximation,
                     time_step=base.plant.time_step, duration=duration,
                     keep_effects=[n for n, cls in registry().items() if cls.default_on])
    rows = []
    for name in effects:
        if name not in registry():
            rows.append({"effect": name, "status": "not available"})
            continue
        cls = registry()[name]
        needed = [n for n in cls.requires if getattr(bare.effects, n) is None]
        variant = variants.derive(bare, variants.effects_on(needed + [name]))
        times = {"bare": [], "effect": []}
        try:
            for _ in range(repeats):
                for key, s in (("bare", bare), ("effect", variant)):
                    times[key].append(_wall(s))
        except Exception as e:  # an optional dependency missing, for example
            rows.append({"effect": name, "status": f"failed: {str(e).splitlines()[0]}"})
            continue
        rows.append({"effect": name, "status": "ok", "with": needed, "bare_wall_s": min(times["bare"]),
                     "effect_wall_s": min(times["effect"]), "ratio": min(times["effect"]) / min(times["bare"])})
    return rows


def _wall(scenario: Scenario) -> float:
    scene = build_scene(scenario)
    result = simulate(scene)
    return result.summary["wall_time_s"]
