"""The learned contact in a real-time engine: MuJoCo steps the bodies, a predictor decides
container-container contact.

Per step (h = plant.time_step, semi-implicit Euler, MuJoCo's default integrator):
  1. mj_step1: MuJoCo's position and velocity stages at the step's state (poses xpos/xmat,
     its own contacts with the quay);
  2-4. the learned contact step, the one the Drake-hosted loop calls
     (testbed/effects/learned_dynamics/step.py: the native core's step, native/src/step.c):
     candidate pairs (sort and sweep on the containers' world boxes, then bounding spheres and
     face axes within NEAR = 0.05 m), ONE batched predictor call (point_A and normal_A in A's
     frame for every candidate), the force law (the Winkler foundation normal force over the
     face overlap, Hunt-Crossley dissipation, the anchored stick friction and torsion, with
     the effect's config and kappa); its wrenches about each body origin C moved to the COM
     and written to xfrc_applied (plus wind and the crane's ropes);
  5. mj_step2: MuJoCo's constraint solve (quay contact) and integration.
The normal force is linearly implicit and friction explicit, as in the Drake-hosted loop (the
same step and held state: anchors, last normal forces, each body's last-step history), so the
same stability check applies (LearnedDynamicsEffect refuses a scene whose explicit part, the
tilt stiffness, is unstable).

What MuJoCo's own contact still does, and why: the quay. Container-quay contact is Drake's
hydroelastic in the Drake-hosted loop (the learned law covers box pairs only: the predictor
is trained on container size pairs, not on a box against a half-space); here it is MuJoCo's
implicit contact with the `matched` parameters (testbed/engines/mujoco/model.py: its static
penetration and one-step map equal Drake's discrete hydroelastic contact), at the learned
law's modulus like every container in the loop. It is also what keeps the heaviest loads
stable: the quay pair carries the whole column, and an implicit solve has no step limit.
The crane is applied forces (ropes, twistlocks: testbed/engines/mujoco/crane.py), whose
seated test asks the learned contact as well as MuJoCo's. Container pairs never touch
MuJoCo's solver: their geoms are out of its broad phase (contype = conaffinity = 0).

The containers run at the learned law's modulus (law_modulus: the scene's
effects.contact.hydroelastic_modulus, else 1e8 Pa) for the quay as for the law, as the
Drake-hosted loop does; compare judges it against Drake at that modulus.

Sleeping (sleep.py, on with the scene's learned_dynamics sleeping): rested islands sleep in MuJoCo
itself (mjENBL_SLEEP, +0.0 applied rows), and while every container sleeps the learned step is not
called; while some sleep it runs on the awake containers and their near neighbours alone (subset.py,
the held state remapped); summary['mujoco_sleep'] counts both (effects_s includes its bookkeeping).

Costs (summary['cost'], [s] over the timed steps): mujoco_s (mj_step1 + mj_step2), broad_s
(state extraction, broad phase, near pairs, gather), predict_s (the predictor's call),
law_s (force law, anchors, xfrc_applied), effects_s (wind, the crane's ropes). Recording (the
quay rows, and the learned pairs' records, read from the step only on recorded steps) is timed
apart.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from testbed import variants
from testbed.effects.deck_motion import build_law as deck_law
from testbed.effects.wind import WindLaw
from testbed.engines.base import UnsupportedSceneError
from testbed.engines.mujoco.crane import CraneRopes
from testbed.engines.mujoco.model import build_model, check_supported, mujoco_module
from testbed.engines.mujoco.run import MujocoRun, _ContactReducer, steps_table, trajectory_of
from testbed.engines.mujoco_learned.contact import MU_SDF, LearnedContact  # noqa: F401 - the loop's names
from testbed.engines.mujoco_learned.sleep import HostSleep
from testbed.errors import ScenarioError
from testbed.scenario import validate_scenario
from testbed.simulation import Trajectory

MAX_SPEED = 100.0  # [m/s, rad/s] a state past this has blown up (no container in a yard moves so fast)


class UnstableStepError(UnsupportedSceneError):
    """The explicit contact force would be unstable at the scene's time step (the learned loop's
    stability check): refused by `check`; a run at such a step (a time-step sweep) ends at once
    with that as its error instead (refused_run)."""


def refused_run(scenario, why: str):
    """A Trajectory of the initial state alone whose error is `why` (a run that cannot start)."""

    free = [c for c in scenario.containers if not c.fixed]
    p = np.array([[c.pose().translation() for c in free]]).reshape(1, -1, 3)
    q = np.array([[c.pose().rotation().ToQuaternion().wxyz() for c in free]]).reshape(1, -1, 4)
    zero = np.zeros(1)
    return Trajectory(time=zero, p_WB=p, q_WB=q, V_WB=np.zeros((1, len(free), 6)), energy=zero, potential=zero,
                      wall_s=0.0, simulated_s=0.0, error=why, names=tuple(c.name for c in free))


@dataclasses.dataclass
class Prepared:
    """A scene made ready for the MuJoCo-hosted loop: `learned` (the scene with the learned
    loop on, at the law's modulus), `effect` (its checked LearnedDynamicsEffect: predictor,
    kappa_by_type (T, T) [Pa/m], type_index (m,), stability) and `physics` (what MuJoCo
    translates: the PHYSICS effects without learned_dynamics)."""

    learned: object
    effect: object
    physics: object


def prepare(scenario, predictor: str | None, source: object = "<scenario>") -> Prepared:
    """The scene with the learned loop (predictor None: the scene's, else "improved") at the
    law's modulus, checked. Raises UnsupportedSceneError (one line: the field and why) for a
    scene the loop refuses (generic boxes, an explicit step that is unstable, a bad predictor)."""

    learned = variants.derive(scenario, variants.learned_loop(predictor), variants.modulus(None))
    try:
        effect = validate_scenario(learned, source)["learned_dynamics"]
    except ScenarioError as e:
        if isinstance(e, UnsupportedSceneError):
            raise
        unstable = e.field == "effects.learned_dynamics" and "is unstable at plant.time_step" in e.problem
        raise (UnstableStepError if unstable else UnsupportedSceneError)(
            scenario.name, e.field, f"{e.problem} (the MuJoCo-hosted learned loop)") from None
    physics = variants.derive(learned, variants.physics_only(learned=False))
    check_supported(physics)
    return Prepared(learned, effect, physics)


@dataclasses.dataclass
class LearnedRun:
    """trajectory: testbed.simulation.Trajectory (every record_every steps); contacts: the
    Engine protocol's rows (quay rows from MuJoCo, container rows from the learned law, every
    record_every steps); summary: figures and the cost split; mjcf: the translated model."""

    trajectory: object
    contacts: dict
    summary: dict
    mjcf: str


class _LearnedCrane(CraneRopes):
    """The crane's ropes; its load counts as seated when the learned contact touches it too."""

    def __init__(self, touching, *args):
        super().__init__(*args)
        self._touching = touching

    def _in_contact(self, data) -> bool:
        return self._touching() or super()._in_contact(data)


def simulate(scenario, *, duration: float | None = None, predictor: str | None = None, record_every: int = 1,
             source: object = "<scenario>", contact: type | None = None, sleep: bool | None = None,
             subset: bool | None = None) -> LearnedRun:
    """Runs `scenario` for `duration` [s] (None: the scene's) with MuJoCo stepping the bodies
    and `predictor` deciding container contact (see the module docstring); records every
    `record_every` steps. contact: the class that applies the learned contact (None:
    LearnedContact; a subclass may watch the run from inside: its `apply` is called once a
    warm-up step, then once a step after mj_step1: the scale study's window clock). Raises
    UnsupportedSceneError before anything runs; a run whose state turns non-finite stops there
    (trajectory.error set). sleep: resting islands asleep in MuJoCo (sleep.py; None: the scene's
    learned_dynamics sleeping, enabled and mujoco_trees; False: always awake, MuJoCo's sleeping off).
    subset: with sleeping, the learned step on the awake containers and their near neighbours alone
    (subset.py; None: the contact class's `subset` flag, True unless set; False: on every container)."""

    mj = mujoco_module()
    prepared = prepare(scenario, predictor, source)
    s = prepared.learned
    model, data, tr = build_model(prepared.physics, container_contact=False)
    h = tr.time_step
    duration = s.duration if duration is None else float(duration)
    n_steps, every = int(round(duration / h)), max(1, int(record_every))
    specs = {c.name: c for c in s.containers}
    free_specs = [specs[n] for n in tr.free_names]
    body_ids = np.array([model.body(n).id for n in tr.free_names], dtype=int)
    qadr = np.array([model.jnt_qposadr[model.body_jntadr[b]] for b in body_ids], dtype=int)
    vadr = np.array([model.jnt_dofadr[model.body_jntadr[b]] for b in body_ids], dtype=int)
    qidx, vidx = qadr[:, None] + np.arange(7), vadr[:, None] + np.arange(6)
    law = (contact or LearnedContact)(prepared, model)
    offset = 1 if s.ground else 0
    wind = None if s.effects.wind is None else WindLaw(
        s.effects.wind, np.array([c.container_type().size for c in free_specs], dtype=float).reshape(-1, 3))
    com_B = np.array([c.com_offset for c in free_specs], dtype=float).reshape(-1, 3)
    deck = None if s.effects.deck_motion is None else deck_law(
        s.effects.deck_motion, s, free_specs, np.array(model.opt.gravity, dtype=float))
    crane = None
    if s.effects.crane is not None:
        j = tr.free_names.index(s.effects.crane.container)
        scene_index = [c.name for c in s.containers].index(s.effects.crane.container)
        crane = _LearnedCrane(lambda: law.touching(scene_index), s.effects.crane, free_specs[j], model,
                              int(body_ids[j]), model.geom(tr.free_names[j]).id, int(qadr[j]), int(vadr[j]))
        j_crane = j
    reducer = _ContactReducer(model, tr.body_names)
    cfg = law.step.sleeping
    sleeper = HostSleep(mj, model, body_ids, [list(specs).index(n) for n in tr.free_names], law.n, cfg, h,
                        reducer, [tr.body_names.index(n) for n in tr.free_names]) if (
        (cfg.enabled and cfg.mujoco_trees) if sleep is None else sleep) else None
    if sleeper is not None and (subset if subset is not None else law.subset):
        law.subset = True
        law.attach(sleeper.awake_scene)  # the learned step on the awake containers and their neighbours (subset.py)
    # the predictor's first call (a Python model's imports, caches) outside the timed steps
    mj.mj_step1(model, data)
    law.apply(data)
    law.costs[:] = 0.0
    law.reset()
    if model.nkey:
        mj.mj_resetDataKeyframe(model, data, 0)
    else:
        mj.mj_resetData(model, data)
    mj.mj_forward(model, data)
    qpos, qvel, index = [data.qpos[qidx].copy()], [data.qvel[vidx].copy()], [0]
    mujoco_s, effects_s, record_s, steps_done, diverged = 0.0, 0.0, 0.0, 0, False
    badqacc = int(mj.mjtWarning.mjWARN_BADQACC)
    for i in range(n_steps):
        t0 = time.perf_counter()
        mj.mj_step1(model, data)
        t1 = time.perf_counter()
        skip = law.idle = sleeper is not None and sleeper.skip_learned(data)
        law.apply(data)
        learned = None if sleeper is None else (sleeper.no_rows if skip else data.xfrc_applied[body_ids])
        t2 = time.perf_counter()
        if wind is not None:
            data.xfrc_applied[body_ids] += wind.mujoco_rows(data.xmat[body_ids].reshape(-1, 3, 3), com_B, data.time)
        if deck is not None:  # the deck's inertial loads and twistlocks (testbed/effects/deck_motion.py)
            data.xfrc_applied[body_ids] += deck.mujoco_rows(data.qpos[qidx], data.qvel[vidx], data.time)
        if crane is not None:
            crane.apply(data, data.xmat[body_ids[j_crane]].reshape(3, 3).copy())
        if sleeper is not None:
            sleeper.settle(data, learned, None if skip else law.candidates)
        t3 = time.perf_counter()
        mj.mj_step2(model, data)
        t4 = time.perf_counter()
        mujoco_s += (t1 - t0) + (t4 - t3)
        effects_s += t3 - t2
        steps_done = i + 1
        if (data.warning[badqacc].number > 0 or not np.all(np.isfinite(data.qpos))
                or np.abs(data.qvel).max(initial=0.0) > MAX_SPEED):
            diverged = True
            break
        if (i + 1) % every == 0:  # the rows of state i (Drake's contact_log logs steps every - 1, 2 every - 1, ...)
            t5 = time.perf_counter()
            (reducer if sleeper is None else sleeper).add(i, i * h, data)  # a sleeping tree's quay rows: held
            learned_rows = law.rows(i, i * h, offset)
            if learned_rows is not None:
                reducer.rows.append(learned_rows)
            record_s += time.perf_counter() - t5
        if steps_done % every == 0:
            qpos.append(data.qpos[qidx].copy())
            qvel.append(data.qvel[vidx].copy())
            index.append(steps_done)
    if index[-1] != steps_done:
        qpos.append(data.qpos[qidx].copy())
        qvel.append(data.qvel[vidx].copy())
        index.append(steps_done)
    broad_s, predict_s, law_s = (float(x) for x in law.costs[:3])
    wall = mujoco_s + broad_s + predict_s + law_s + effects_s
    steps = steps_table(model, body_ids, free_specs, np.array(qpos), np.array(qvel), np.array(index), h)
    contacts = reducer.table()
    sim_time = steps_done * h
    per_step = 1e3 / max(steps_done, 1)
    summary = {
        "scene": s.name, "engine": "mujoco_learned", "version": mj.__version__, "mujoco_version": mj.__version__,
        "predictor": prepared.effect.config.predictor,
        "hydroelastic_modulus_Pa": float(s.effects.contact.hydroelastic_modulus),
        "time_step_s": h, "duration_s": duration, "steps": steps_done, "diverged": diverged,
        "wall_time_s": wall, "wall_per_sim_s": wall / sim_time if sim_time > 0 else float("nan"),
        "real_time_factor": sim_time / wall if wall > 0 else float("inf"), "record_s": record_s,
        "cost": {"mujoco_s": mujoco_s, "broad_s": broad_s, "predict_s": predict_s, "law_s": law_s,
                 "effects_s": effects_s,
                 "ms_per_step": {"mujoco": mujoco_s * per_step, "broad_phase": broad_s * per_step,
                                 "predictor": predict_s * per_step, "force_law": law_s * per_step,
                                 "wind_crane": effects_s * per_step, "total": wall * per_step},
                 "predict_calls": int(law.costs[4]), "predict_pairs": int(law.costs[5])},
        "max_penetration_m": float(max(0.0, -contacts["phi"].min())) if len(contacts["phi"]) else 0.0,
        "stability_max": max((r["explicit"] for r in prepared.effect.stability), default=0.0),
        "crane_release_time_s": None if crane is None else crane.release_time,
        "mujoco_sleep": None if sleeper is None else {**sleeper.summary(), "trees_asleep_at_end": int(
            sleeper.asleep(data).sum()), "trees": len(body_ids), **law.subset_summary()},
    }
    run = MujocoRun(tables={"steps": steps, "contacts": contacts}, summary=summary, body_names=tr.body_names,
                    free_names=tr.free_names, mjcf=tr.mjcf)
    trajectory = trajectory_of(run, every)
    trajectory.error = (f"the MuJoCo-hosted learned loop blew up at t = {steps_done * h:g} s (state non-finite or "
                        f"faster than {MAX_SPEED:g} m/s)" if diverged else "")
    trajectory.costs = {"calc_s": broad_s + predict_s + law_s + effects_s, "predict_s": predict_s, "record_s": record_s,
                        "calc_calls": steps_done, "predict_calls": int(law.costs[4]),
                        "predict_pairs": int(law.costs[5])}
    return LearnedRun(trajectory, contacts, summary, tr.mjcf)
