"""simulate_mujoco: steps a translated scene and records Drake-shaped tables.

Tables (units and shapes as testbed/effects/contact_log.py writes them for Drake):
  steps     step (k,) int, time (k,) [s], p_WB (k, m, 3) [m] origin of each free container's
            frame C in W, q_WB (k, m, 4) quaternion wxyz of R_WC, V_WB (k, m, 6) [w_W (rad/s),
            v_W of C's origin (m/s)], kinetic_energy / potential_energy (k,) [J] (sums over
            free containers; same formulas as contact_log). Row i is the state at time i h,
            i = 0..N (N = duration / h steps).
  contacts  one row per touching body pair per step (MuJoCo's contacts reduced per pair):
            step, time (the state the contacts were computed from), a, b (body_names
            indices, a < b, ground = 0), p_W_cop (n, 3) [m] normal-force-weighted centroid of
            MuJoCo's contact points (equals the centre of pressure of the normal forces
            for coplanar points), n_W (n, 3) force-weighted unit normal a -> b, f_W (n, 3) [N]
            total contact force on b, fn (n,) [N] f_W . n_W, phi (n,) [m] smallest signed
            distance (negative = penetration), n_points (n,) contacts reduced.
Wall time: only the mj_step calls are timed (`wall_time_s`); recording is timed apart.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from testbed.effects.deck_motion import build_law as deck_law
from testbed.effects.wind import WindLaw
from testbed.engines.mujoco.crane import CraneRopes
from testbed.engines.mujoco.model import build_model, mujoco_module
from testbed.geometry.rotations import rotation_from_quaternion
from testbed.physics import GRAVITY
from testbed.scenario import Scenario
from testbed.simulation import Trajectory


@dataclasses.dataclass
class MujocoRun:
    """A MuJoCo run: tables (see module), summary, body_names (ground first), free_names, mjcf."""

    tables: dict
    summary: dict
    body_names: list
    free_names: list
    mjcf: str


def wind_force_W(config, size, R_WC, t: float) -> np.ndarray:
    """(3,) [N] wind force on one container at time t [s]: testbed/effects/wind.py's WindLaw."""
    return WindLaw(config, np.asarray(size, float).reshape(1, 3)).forces_W(np.asarray(R_WC, float).reshape(1, 3, 3), t)[0]


def _rotations(q: np.ndarray) -> np.ndarray:
    """(..., 4) wxyz, normalised here (MuJoCo's qpos drifts from unit length) -> (..., 3, 3)."""
    return rotation_from_quaternion(q / np.linalg.norm(q, axis=-1, keepdims=True))


def energies(p_WB, q_WB, V_WB, mass, com_B, I_B) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic and potential energy [J] (k,) of m free bodies: p (k, m, 3), q (k, m, 4),
    V (k, m, 6) [w, v of the origin], mass (m,), com_B (m, 3), I_B (m, 3) principal moments at the COM."""
    R = _rotations(q_WB)  # (k, m, 3, 3)
    w, v = V_WB[..., :3], V_WB[..., 3:]
    p_com = np.einsum("kmij,mj->kmi", R, com_B)
    v_cm = v + np.cross(w, p_com)
    w_B = np.einsum("kmji,kmj->kmi", R, w)
    kinetic = 0.5 * np.einsum("m,kmi,kmi->k", mass, v_cm, v_cm) + 0.5 * np.einsum("mi,kmi,kmi->k", I_B, w_B, w_B)
    potential = GRAVITY * np.einsum("m,km->k", mass, p_WB[..., 2] + p_com[..., 2])
    return kinetic, potential


class _ContactReducer:
    """Reduces MuJoCo's contacts of one step to one row per body pair (see module)."""

    def __init__(self, model, body_names):
        self.nb = len(body_names)
        self.index = np.array([body_names.index(model.geom(g).name) for g in range(model.ngeom)])
        self.rows: list[dict] = []

    def add(self, step: int, t: float, data) -> None:
        con = data.contact
        live = np.flatnonzero(np.array(con.efc_address[:data.ncon]) >= 0)  # contacts in the solver
        k = len(live)
        if k == 0:
            return
        g1, g2 = self.index[con.geom1[live]], self.index[con.geom2[live]]
        frame = np.array(con.frame[live]).reshape(k, 3, 3)  # rows: normal (geom1 -> geom2), t1, t2
        adr, dim = np.array(con.efc_address[live]), np.array(con.dim[live])
        f_c = np.zeros((k, 3))
        f_c[:, 0] = data.efc_force[adr]
        friction = dim >= 3
        f_c[friction, 1] = data.efc_force[adr[friction] + 1]
        f_c[friction, 2] = data.efc_force[adr[friction] + 2]
        sign = np.where(g1 < g2, 1.0, -1.0)[:, None]
        f_on_b = sign * np.einsum("ki,kij->kj", f_c, frame)  # (k, 3) [N]
        n_ab = sign * frame[:, 0]
        a, b = np.minimum(g1, g2), np.maximum(g1, g2)
        keys, inverse = np.unique(a * self.nb + b, return_inverse=True)
        n = len(keys)
        w = np.maximum(f_c[:, 0], 0.0)
        wsum = np.bincount(inverse, w, n)
        count = np.bincount(inverse, minlength=n)
        weight = np.where(wsum[inverse] > 0, w / np.where(wsum[inverse] > 0, wsum[inverse], 1.0), 1.0 / count[inverse])
        point, normal, force = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        np.add.at(point, inverse, weight[:, None] * np.array(con.pos[live]))
        np.add.at(normal, inverse, weight[:, None] * n_ab)
        np.add.at(force, inverse, f_on_b)
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        phi = np.full(n, np.inf)
        np.minimum.at(phi, inverse, np.array(con.dist[live]))
        self.rows.append({"step": np.full(n, step), "time": np.full(n, t), "a": keys // self.nb, "b": keys % self.nb,
                          "p_W_cop": point, "n_W": normal, "f_W": force, "fn": np.einsum("ni,ni->n", force, normal),
                          "phi": phi, "n_points": count})

    def table(self) -> dict:
        if not self.rows:
            empty = {k: np.zeros((0, 3)) for k in ("p_W_cop", "n_W", "f_W")}
            empty.update({k: np.zeros(0) for k in ("time", "fn", "phi")})
            empty.update({k: np.zeros(0, dtype=int) for k in ("step", "a", "b", "n_points")})
            return empty
        return {key: np.concatenate([r[key] for r in self.rows]) for key in self.rows[0]}


def steps_table(model, body_ids, free_specs, qpos: np.ndarray, qvel: np.ndarray, step: np.ndarray, h: float) -> dict:
    """The `steps` table (module docstring) from MuJoCo's free-joint states qpos (k, m, 7)
    [p, wxyz] and qvel (k, m, 6) [v_W, w_C] of the free bodies body_ids (m,) (free_specs:
    their ContainerSpecs) recorded at plant steps step (k,), time step h [s]."""
    p, q = qpos[..., :3], qpos[..., 3:]
    R = _rotations(q)
    V = np.concatenate([np.einsum("kmij,kmj->kmi", R, qvel[..., 3:]), qvel[..., :3]], axis=-1)
    mass = np.array([c.total_mass() for c in free_specs])
    com_B = np.array([c.com_offset for c in free_specs], dtype=float).reshape(-1, 3)
    I_B = np.array(model.body_inertia[body_ids]).reshape(-1, 3)  # principal moments at the COM (frame unrotated)
    kinetic, potential = energies(p, q, V, mass, com_B, I_B)
    return {"step": step, "time": step * h, "p_WB": p, "q_WB": q, "V_WB": V,
            "kinetic_energy": kinetic, "potential_energy": potential}


def simulate_mujoco(scenario: Scenario, *, duration: float | None = None, params: str = "matched",
                    time_step: float | None = None, record: bool = True) -> MujocoRun:
    """Simulates `scenario` in MuJoCo for `duration` [s] (default: the scene's) at `time_step`
    [s] (default: plant.time_step) with the `params` contact set ('matched' | 'default').

    record False keeps only the first and last state (for timing). Raises
    UnsupportedSceneError (crane scenes), OptionalDependencyError (no mujoco).
    A run whose state turns non-finite (or that MuJoCo flags as unstable) stops there with
    summary['diverged'] True.
    """
    mj = mujoco_module()
    model, data, tr = build_model(scenario, params=params, time_step=time_step)
    h = tr.time_step
    duration = scenario.duration if duration is None else float(duration)
    n_steps = int(round(duration / h))
    specs = {c.name: c for c in scenario.containers}
    free = [specs[n] for n in tr.free_names]
    body_ids = np.array([model.body(n).id for n in tr.free_names], dtype=int)
    qadr = np.array([model.jnt_qposadr[model.body_jntadr[b]] for b in body_ids], dtype=int)
    vadr = np.array([model.jnt_dofadr[model.body_jntadr[b]] for b in body_ids], dtype=int)
    qidx, vidx = qadr[:, None] + np.arange(7), vadr[:, None] + np.arange(6)
    wind = None if scenario.effects.wind is None else WindLaw(
        scenario.effects.wind, np.array([c.container_type().size for c in free], dtype=float).reshape(-1, 3))
    com_B = np.array([c.com_offset for c in free], dtype=float).reshape(-1, 3)
    deck = None if scenario.effects.deck_motion is None else deck_law(
        scenario.effects.deck_motion, scenario, free, np.array(model.opt.gravity, dtype=float))
    reducer = _ContactReducer(model, tr.body_names)
    qpos, qvel, steps_done = [data.qpos[qidx].copy()], [data.qvel[vidx].copy()], 0
    stepping, diverged = 0.0, False
    start_total = time.perf_counter()
    crane = None
    if scenario.effects.crane is not None:
        j_crane = tr.free_names.index(scenario.effects.crane.container)
        crane = CraneRopes(scenario.effects.crane, free[j_crane], model, int(body_ids[j_crane]),
                           model.geom(tr.free_names[j_crane]).id, int(qadr[j_crane]), int(vadr[j_crane]))
    for i in range(n_steps):
        if wind is not None or crane is not None or deck is not None:
            data.xfrc_applied[:] = 0.0
        if wind is not None:
            R = _rotations(data.qpos[qidx[:, 3:]])  # the current poses (xmat lags one step)
            data.xfrc_applied[body_ids] = wind.mujoco_rows(R, com_B, data.time)  # applied at C, not the COM
        if deck is not None:  # the deck's inertial loads and twistlocks (testbed/effects/deck_motion.py)
            data.xfrc_applied[body_ids] += deck.mujoco_rows(data.qpos[qidx], data.qvel[vidx], data.time)
        if crane is not None:
            crane.apply(data, _rotations(data.qpos[qidx[j_crane, 3:]]))
        t0 = time.perf_counter()
        mj.mj_step(model, data)
        stepping += time.perf_counter() - t0
        steps_done = i + 1
        bad = data.warning[int(mj.mjtWarning.mjWARN_BADQACC)].number > 0
        if bad or not np.all(np.isfinite(data.qpos)):
            diverged = True
            break
        if record:
            reducer.add(i, i * h, data)
            qpos.append(data.qpos[qidx].copy())
            qvel.append(data.qvel[vidx].copy())
    total = time.perf_counter() - start_total
    if not record:
        qpos.append(data.qpos[qidx].copy())
        qvel.append(data.qvel[vidx].copy())
    k = np.arange(len(qpos)) if record else np.array([0, steps_done])
    steps = steps_table(model, body_ids, free, np.array(qpos), np.array(qvel), k, h)
    qpos, qvel = np.array(qpos), np.array(qvel)
    kinetic, potential = steps["kinetic_energy"], steps["potential_energy"]
    contacts = reducer.table()
    sim_time = steps_done * h
    energy = kinetic + potential
    summary = {
        "scene": scenario.name, "engine": "mujoco", "mujoco_version": mj.__version__, "params": params,
        "time_step_s": h, "duration_s": duration, "steps": steps_done, "diverged": diverged,
        "wall_time_s": stepping, "wall_total_s": total,
        "wall_per_sim_s": stepping / sim_time if sim_time > 0 else float("nan"),
        "ms_per_sim_second": 1e3 * stepping / sim_time if sim_time > 0 else float("nan"),
        "real_time_factor": sim_time / stepping if stepping > 0 else float("inf"),
        "finite_state": bool(np.all(np.isfinite(qpos)) and np.all(np.isfinite(qvel))),
        "max_penetration_m": float(max(0.0, -contacts["phi"].min())) if len(contacts["phi"]) else 0.0,
        "energy_drift_J": float(energy[-1] - energy[0]),
        "crane_release_time_s": None if crane is None else crane.release_time,
        "matched_mass_factor_max": max((p.mass_factor for p in tr.pairs), default=float("nan")),
    }
    return MujocoRun(tables={"steps": steps, "contacts": contacts}, summary=summary,
                     body_names=tr.body_names, free_names=tr.free_names, mjcf=tr.mjcf)


def trajectory_of(run: MujocoRun, every: int) -> Trajectory:
    """The MuJoCo run as a testbed.simulation.Trajectory on the grid of every `every` steps."""
    error = "MuJoCo reported an unstable state" if run.summary["diverged"] else ""
    return Trajectory.from_steps(run.tables["steps"], every, run.summary, error, run.free_names)
