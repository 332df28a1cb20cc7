"""simulate_bullet: steps a translated scene in Bullet and records Drake-shaped tables.

Tables (units and shapes as testbed/engines/mujoco/run.py's, i.e. contact_log's for Drake):
  steps     step (k,) int, time (k,) [s], p_WB (k, m, 3) [m] origin of each free container's
            frame C (the geometric centre) in W, q_WB (k, m, 4) quaternion wxyz of R_WC,
            V_WB (k, m, 6) [w_W (rad/s), v_W of C's origin (m/s)], kinetic_energy /
            potential_energy (k,) [J] (sums over free containers). Row i is the state at time
            i h. Bullet's base pose and velocity are its COM's: p_WC = p_Wcm - R_WC com_C,
            v_WC = v_Wcm - w_W x (R_WC com_C).
  contacts  one row per touching body pair per step (Bullet's manifold points reduced per pair):
            step, time (the state before the step), a, b (body_names indices, a < b,
            ground = 0), p_W_cop (n, 3) [m] normal-force-weighted centroid of the points
            (each the midpoint of its two witness points), n_W (n, 3) force-weighted unit normal
            a -> b, f_W (n, 3) [N] total contact force (normal and friction) on b, fn (n,) [N]
            f_W . n_W, phi (n,) [m] smallest signed distance (negative = penetration),
            n_points (n,). A point is touching when its distance is <= 0 or it carries force.
            Bullet reports each point's impulses over the step divided by h (forces [N]).
Wall time: only the stepSimulation calls are timed (`wall_time_s`).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from testbed.engines.bullet.loads import AppliedLoads
from testbed.engines.bullet.model import build_world, pybullet_version
from testbed.engines.mujoco.run import energies  # the same formulas as contact_log's
from testbed.geometry.rotations import rotation_from_quaternion
from testbed.scenario import Scenario
from testbed.simulation import Trajectory


@dataclasses.dataclass
class BulletRun:
    """A Bullet run: tables (module doc), summary, body_names (ground first), free_names, world (JSON text)."""

    tables: dict
    summary: dict
    body_names: list
    free_names: list
    world: str


def contact_rows(points, index: dict, step: int, t: float) -> dict | None:
    """One step's rows (module doc) from pybullet's getContactPoints() tuples; index: Bullet body
    id -> body_names index. None when no point touches."""
    keep = [c for c in points if c[8] <= 0.0 or c[9] > 0.0]
    if not keep:
        return None
    ia = np.array([index[c[1]] for c in keep])
    ib = np.array([index[c[2]] for c in keep])
    n_B = np.array([c[7] for c in keep], dtype=float).reshape(-1, 3)  # on B, pointing towards A
    fn = np.array([c[9] for c in keep], dtype=float)
    lateral = (np.array([c[10] for c in keep], dtype=float)[:, None] * np.array([c[11] for c in keep], dtype=float)
               + np.array([c[12] for c in keep], dtype=float)[:, None] * np.array([c[13] for c in keep], dtype=float))
    f_on_A = fn[:, None] * n_B + lateral  # Bullet's solver: +impulse on A, - on B
    sign = np.where(ia < ib, 1.0, -1.0)[:, None]  # a = the lower index
    f_on_b = -sign * f_on_A
    n_ab = -sign * n_B
    point = 0.5 * (np.array([c[5] for c in keep], dtype=float) + np.array([c[6] for c in keep], dtype=float))
    nb = len(index) + 1
    a, b = np.minimum(ia, ib), np.maximum(ia, ib)
    keys, inverse = np.unique(a * nb + b, return_inverse=True)
    inverse = inverse.ravel()
    n = len(keys)
    w = np.maximum(fn, 0.0)
    wsum = np.bincount(inverse, w, n)
    count = np.bincount(inverse, minlength=n)
    weight = np.where(wsum[inverse] > 0, w / np.where(wsum[inverse] > 0, wsum[inverse], 1.0), 1.0 / count[inverse])
    p, normal, force = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    np.add.at(p, inverse, weight[:, None] * point)
    np.add.at(normal, inverse, weight[:, None] * n_ab)
    np.add.at(force, inverse, f_on_b)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    phi = np.full(n, np.inf)
    np.minimum.at(phi, inverse, np.array([c[8] for c in keep], dtype=float))
    return {"step": np.full(n, step), "time": np.full(n, t), "a": keys // nb, "b": keys % nb, "p_W_cop": p,
            "n_W": normal, "f_W": force, "fn": np.einsum("ni,ni->n", force, normal), "phi": phi, "n_points": count}


def _table(rows: list) -> dict:
    if not rows:
        empty = {k: np.zeros((0, 3)) for k in ("p_W_cop", "n_W", "f_W")}
        empty.update({k: np.zeros(0) for k in ("time", "fn", "phi")})
        empty.update({k: np.zeros(0, dtype=int) for k in ("step", "a", "b", "n_points")})
        return empty
    return {key: np.concatenate([r[key] for r in rows]) for key in rows[0]}


def _state(pb, cid, ids, com_C) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(p_WC (m, 3), q wxyz (m, 4), V_WC (m, 6) [w, v of C]) of the free bodies `ids`."""
    p, q, V = [], [], []
    for bid in ids:
        p_cm, (x, y, z, w) = pb.getBasePositionAndOrientation(bid, physicsClientId=cid)
        v_cm, omega = pb.getBaseVelocity(bid, physicsClientId=cid)
        p.append(p_cm)
        q.append((w, x, y, z))
        V.append((*omega, *v_cm))
    p, q, V = np.array(p, float).reshape(-1, 3), np.array(q, float).reshape(-1, 4), np.array(V, float).reshape(-1, 6)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    r = np.einsum("mij,mj->mi", rotation_from_quaternion(q), com_C)  # (m, 3) COM from C in W
    return p - r, q, np.hstack([V[:, :3], V[:, 3:] - np.cross(V[:, :3], r)])


def simulate_bullet(scenario: Scenario, *, duration: float | None = None, params: str = "matched",
                    time_step: float | None = None, contacts: bool = True) -> BulletRun:
    """Simulates `scenario` in Bullet for `duration` [s] (default: the scene's) at `time_step`
    [s] (default: plant.time_step) with the `params` contact set ('matched' | 'default');
    contacts False skips the contact rows. Raises UnsupportedSceneError, PybulletMissingError.
    A run whose state turns non-finite stops there with summary['diverged'] True."""
    pb, cid, ids, tr = build_world(scenario, params=params, time_step=time_step)
    try:
        h = tr.time_step
        duration = scenario.duration if duration is None else float(duration)
        n_steps = int(round(duration / h))
        specs = {c.name: c for c in scenario.containers}
        free = [specs[n] for n in tr.free_names]
        params_of = {b.name: b for b in tr.bodies}
        free_ids = [ids[tr.body_names.index(n)] for n in tr.free_names]
        com_C = np.array([c.com_offset for c in free], dtype=float).reshape(-1, 3)
        index = {bid: i for i, bid in enumerate(ids)}
        inertia = np.array([params_of[c.name].inertia for c in free], dtype=float).reshape(-1, 3)
        loads = AppliedLoads(scenario, free, free_ids, com_C, inertia, h, pb, cid)  # wind, deck, crane (loads.py)
        states, rows, stepping, diverged, steps_done = [_state(pb, cid, free_ids, com_C)], [], 0.0, False, 0
        for i in range(n_steps):
            if loads.active:  # from the step's start state; pybullet clears them after each step
                loads.apply(i * h, *states[-1])
            t0 = time.perf_counter()
            pb.stepSimulation(physicsClientId=cid)
            stepping += time.perf_counter() - t0
            steps_done = i + 1
            states.append(_state(pb, cid, free_ids, com_C))
            if not all(np.all(np.isfinite(x)) for x in states[-1]):
                diverged = True
                break
            if contacts:
                row = contact_rows(pb.getContactPoints(physicsClientId=cid), index, i, i * h)
                if row is not None:
                    rows.append(row)
    finally:
        pb.disconnect(physicsClientId=cid)
    p, q, V = (np.array([s[j] for s in states]) for j in range(3))
    mass = np.array([c.total_mass() for c in free], dtype=float)
    I_B = np.array([params_of[c.name].inertia for c in free], dtype=float).reshape(-1, 3)
    kinetic, potential = energies(p, q, V, mass, com_C, I_B)
    k = np.arange(len(states))
    table = _table(rows)
    sim_time = steps_done * h
    energy = kinetic + potential
    summary = {
        "scene": scenario.name, "engine": "bullet", "version": pybullet_version(), "params": params,
        "time_step_s": h, "duration_s": duration, "steps": steps_done, "diverged": diverged,
        "wall_time_s": stepping, "wall_per_sim_s": stepping / sim_time if sim_time > 0 else float("nan"),
        "max_penetration_m": float(max(0.0, -table["phi"].min())) if len(table["phi"]) else 0.0,
        "energy_drift_J": float(energy[-1] - energy[0]),
        "crane_release_time_s": loads.release_time,
    }
    steps = {"step": k, "time": k * h, "p_WB": p, "q_WB": q, "V_WB": V, "kinetic_energy": kinetic,
             "potential_energy": potential}
    return BulletRun(tables={"steps": steps, "contacts": table}, summary=summary, body_names=tr.body_names,
                     free_names=tr.free_names, world=tr.describe())


def trajectory_of(run: BulletRun, every: int) -> Trajectory:
    """The Bullet run as a testbed.simulation.Trajectory on the grid of every `every` steps."""
    error = "Bullet's state turned non-finite" if run.summary["diverged"] else ""
    return Trajectory.from_steps(run.tables["steps"], every, run.summary, error, run.free_names)
