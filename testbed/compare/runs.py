"""Variants of one scene (truth, learned, point) and their recorded trajectories.

A variant keeps the scene's PHYSICS effects (testbed.effects.Role; contact, friction,
wind, crane, ...) and drops every recorder, observer and viewer, so its wall time is the
cost of the dynamics alone. Every `record_every` steps the run
records, for the m free containers: p_WB (m, 3) [m], q_WB (m, 4) (w, x, y, z),
V_WB (m, 6) [rad/s, m/s] (angular, linear; of the body origin, in W) and the
mechanical energy (kinetic + gravity potential) [J]. A learned run also keeps its
system's cost counters over the timed steps (Trajectory.costs; testbed/compare/costs.py).
"""

from __future__ import annotations

import copy
import dataclasses
import time

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator

from testbed.builder import build_scene
from testbed.effects import Role, registry
from testbed.effects.learned_dynamics import LearnedDynamicsConfig
from testbed.learned_force_law import law_modulus


def variant(scenario, kind: str, predictor: str | None = None):
    """A copy of `scenario` for kind 'truth' (the scene's own contact model), 'point'
    (Drake point contact) or 'learned' (learned_dynamics with `predictor`; None: the
    scene's own learned_dynamics config if it declares one, else "improved"). Every kind
    runs the containers at the learned law's modulus (law_modulus: 1e8 Pa unless the scene
    sets one), not the SDF's 1e9 Pa."""
    out = copy.deepcopy(scenario)
    if out.effects.contact is not None and out.effects.contact.hydroelastic_modulus is None:
        # every twin at the learned law's modulus (learned_force_law.KAPPA_MODULUS: its fit, and
        # the stiffest its explicit step takes at 1 ms), not the SDF's: like is compared with like
        out.effects.contact = dataclasses.replace(out.effects.contact, hydroelastic_modulus=law_modulus(out))
    for name, cls in registry().items():
        if cls.role is not Role.PHYSICS and hasattr(out.effects, name):
            setattr(out.effects, name, None)
    out.effects.learned_dynamics = None  # the 'learned' kind puts its own back
    if kind == "point":
        out.effects.contact = dataclasses.replace(out.effects.contact, model="point")
        out.plant.contact_model = "point"
    elif kind == "learned":
        given = scenario.effects.learned_dynamics
        config = dataclasses.replace(given) if given is not None else LearnedDynamicsConfig()
        out.effects.learned_dynamics = dataclasses.replace(config, predictor=predictor or config.predictor,
                                                           shadow_truth=False)
    elif kind != "truth":
        raise ValueError(f"unknown variant {kind!r}")
    return out


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
    error: str = ""  # the simulator's error when it failed, else ""
    names: tuple = ()
    # a learned run's LearnedDynamics.costs() over the timed steps (testbed/compare/costs.py); else {}
    costs: dict = dataclasses.field(default_factory=dict)


def run_variant(scenario, duration: float, record_every: int, source="<scenario>", scene=None) -> Trajectory:
    """Simulates a built `scene` (or builds `scenario`) for `duration` [s], recording every
    `record_every` plant steps. A failing run (the simulator or the predictor raising, or
    a non-finite state) ends early with `error` set; the records up to then are kept."""
    scene = scene or build_scene(scenario, source)
    plant = scene.plant
    context = scene.create_context()
    plant_context = plant.GetMyContextFromRoot(context)
    simulator = Simulator(scene.diagram, context)
    ApplySimulatorConfig(scene.scenario.simulator, simulator)
    simulator.Initialize()
    learned = scene.effects.get("learned_dynamics")
    system = getattr(learned, "system", None)
    if system is not None:
        system.reset_costs()  # count only the timed steps below, not the build or Initialize
    bodies = [scene.bodies[n] for n in scene.free_names]
    h = plant.time_step()
    n_rec = int(round(duration / h)) // record_every
    rows, wall, error = [], 0.0, ""

    def record():
        poses = [plant.EvalBodyPoseInWorld(plant_context, b) for b in bodies]
        vels = [plant.EvalBodySpatialVelocityInWorld(plant_context, b) for b in bodies]
        rows.append((context.get_time(), [X.translation() for X in poses],
                     [X.rotation().ToQuaternion().wxyz() for X in poses],
                     [np.concatenate([V.rotational(), V.translational()]) for V in vels],
                     plant.CalcKineticEnergy(plant_context) + plant.CalcPotentialEnergy(plant_context),
                     plant.CalcPotentialEnergy(plant_context)))

    record()
    for k in range(1, n_rec + 1):
        start = time.perf_counter()
        try:
            simulator.AdvanceTo(k * record_every * h)
        except Exception as e:  # noqa: BLE001 - Drake's solver or the predictor (NaN poses): the run failed
            wall += time.perf_counter() - start
            error = f"{type(e).__name__}: {str(e).strip().splitlines()[0]}"
            break
        wall += time.perf_counter() - start
        record()
        if not np.all(np.isfinite(rows[-1][1])):
            error = "non-finite state"
            break
    t, p, q, V, E, PE = zip(*rows)
    m = len(bodies)
    return Trajectory(np.array(t), np.array(p).reshape(-1, m, 3), np.array(q).reshape(-1, m, 4),
                      np.array(V).reshape(-1, m, 6), np.array(E), np.array(PE), wall, t[-1], error,
                      tuple(scene.free_names), system.costs() if system is not None else {})
