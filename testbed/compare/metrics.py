"""Figures of a twin run: how far the learned trajectory strays from the truth's.

Inputs are testbed.simulation.Trajectory records on the same time grid (the learned run may end
early when it failed). Positions are of the body origins (the containers' geometric
centres) [m]; angles are the rotation between the two runs' orientations [deg].
"""

from __future__ import annotations

import numpy as np

from testbed.compare.costs import real_time_factor
from testbed.gates import format_value
from testbed.geometry.rotations import angle_between_quaternions_deg, rotation_from_quaternion

# The learned run diverged (blew up) when it failed, went non-finite, sank one container
# this far into another or the quay [m] (the shipped scenes' deepest Drake contact is a
# 40 mm edge landing; 0.1 m of steel box in steel box is a blow-up, not a soft contact),
# or created energy: E(t) - E(0) above the truth's by more than this fraction of the
# containers' potential energy above the quay at t = 0.
DIVERGED_PENETRATION_M = 0.1
DIVERGED_ENERGY_FRACTION = 0.01
# A physically plausible run may still leave the truth's path (a box tipping off a stack):
# `departed` flags a container this far from the truth's at some time [m].
DEPARTED_M = 0.5


def with_fixed(traj, containers):
    """traj's free containers plus the welded ones (constant poses), in scene order:
    (p_WB (n, m_all, 3) [m], q_WB (n, m_all, 4)); traj's own where it holds every container."""
    if len(containers) == traj.p_WB.shape[1]:
        return traj.p_WB, traj.q_WB
    n = len(traj.time)
    p, q, k = np.zeros((n, len(containers), 3)), np.zeros((n, len(containers), 4)), 0
    for i, c in enumerate(containers):
        if c.fixed:
            X = c.pose()
            p[:, i], q[:, i] = X.translation(), X.rotation().ToQuaternion().wxyz()
        else:
            p[:, i], q[:, i] = traj.p_WB[:, k], traj.q_WB[:, k]
            k += 1
    return p, q


def penetrations(p_WB, R_WB, containers, predictor) -> tuple[np.ndarray, np.ndarray]:
    """((n,) deepest container-container penetration [m] by separating-axis depth,
    (n,) deepest container-quay penetration [m] (lowest corner below z = 0)) per record, of
    every container's pose: p_WB (n, m, 3) [m] and R_WB (n, m, 3, 3), welded ones at their
    fixed poses (with_fixed); containers: all the scene's ContainerSpecs, in that order. A record
    with a non-finite pose (a failed run's last) is infinitely deep."""
    n, m = p_WB.shape[:2]
    finite = np.all(np.isfinite(p_WB), axis=(1, 2)) & np.all(np.isfinite(R_WB), axis=(1, 2, 3))
    deepest, ground = np.full(n, np.inf), np.full(n, np.inf)
    p, R = p_WB[finite], R_WB[finite]  # (k, m, 3) [m], (k, m, 3, 3)
    k = len(p)
    sizes = np.array([c.container_type().size for c in containers]).reshape(-1, 3)  # (m, 3) [m]
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])  # (8, 3)
    corners = p[:, :, None, :] + np.einsum("nmij,mkj->nmki", R, 0.5 * sizes[:, None, :] * signs)
    ground[finite] = np.maximum(0.0, -corners[..., 2].min(axis=(1, 2))) if k else []
    deepest[finite] = 0.0
    pairs = [(i, j) for i in range(m) for j in range(i + 1, m)]
    if k and pairs and predictor is not None:
        ia, ib = np.array(pairs).T
        R_AW = np.swapaxes(R[:, ia], -1, -2)  # (k, P, 3, 3)
        p_AB = np.einsum("npij,npj->npi", R_AW, p[:, ib] - p[:, ia]).reshape(-1, 3)
        R_AB = (R_AW @ R[:, ib]).reshape(-1, 3, 3)
        size_A, size_B = np.tile(sizes[ia], (k, 1)), np.tile(sizes[ib], (k, 1))
        depth = np.asarray(predictor.depth(p_AB, R_AB, size_A=size_A, size_B=size_B)).reshape(k, len(pairs))
        deepest[finite] = np.maximum(0.0, depth.max(axis=1))
    return deepest, ground


def drift_rate(traj) -> float:
    """[m per simulated minute] the fastest steady motion of a container over the second half
    of the run: the largest |slope| of a least-squares line through its position there (a
    fit, so that a jitter of a tenth of a millimetre is not read as a drift)."""
    n = len(traj.time)
    if n < 4 or traj.time[-1] <= 0:
        return float("nan")
    t = traj.time[n // 2:]
    p = traj.p_WB[n // 2:].reshape(len(t), -1)  # (k, 3 m)
    tc = t - t.mean()
    if not np.any(tc):
        return float("nan")
    slope = (tc @ (p - p.mean(axis=0))) / (tc @ tc)  # (3 m,) [m/s]
    speed = np.linalg.norm(slope.reshape(-1, 3), axis=1)
    return float(60.0 * speed.max())


def compare_figures(truth, learned, containers, predictor) -> dict:
    """The compare.json figures of a learned run against the truth (same record times);
    containers: all the scene's ContainerSpecs."""
    n = len(learned.time)
    err = np.linalg.norm(learned.p_WB - truth.p_WB[:n], axis=2)  # (n, m) [m]
    (p_learned, q_learned), (p_truth, q_truth) = with_fixed(learned, containers), with_fixed(truth, containers)
    angle = angle_between_quaternions_deg(learned.q_WB, truth.q_WB[:n])  # (n, m) [deg]
    R_learned, R_truth = rotation_from_quaternion(q_learned), rotation_from_quaternion(q_truth)  # (n, m_all, 3, 3)
    depth, ground = penetrations(p_learned, R_learned, containers, predictor)
    depth_truth, ground_truth = penetrations(p_truth, R_truth, containers, predictor)
    gain = learned.energy - learned.energy[0]
    finite = bool(np.all(np.isfinite(learned.p_WB)) and np.all(np.isfinite(learned.q_WB)))
    completed = not learned.error and n == len(truth.time)
    figures = {
        "position_error_max_m": float(np.nanmax(err)),
        "final_position_error_max_m": float(err[-1].max()),
        "final_angle_error_max_deg": float(angle[-1].max()),
        "angle_error_max_deg": float(np.nanmax(angle)),
        "max_penetration_m": float(max(depth.max(), ground.max())),
        "max_container_penetration_m": float(depth.max()),
        "max_ground_penetration_m": float(ground.max()),
        "max_container_penetration_truth_m": float(depth_truth.max()),
        "max_penetration_truth_m": float(max(depth_truth.max(), ground_truth.max())),
        "energy_gain_max_J": float(np.nanmax(gain)),
        "energy_gain_max_truth_J": float(np.max(truth.energy - truth.energy[0])),
        "potential_drop_max_J": float(np.max(truth.potential[0] - truth.potential)),
        "drift_m_per_min_learned": drift_rate(learned),
        "drift_m_per_min_truth": drift_rate(truth),
        "simulated_s_learned": float(learned.simulated_s),
        "learned_error": learned.error,
    }
    excess = figures["energy_gain_max_J"] - figures["energy_gain_max_truth_J"]
    figures["energy_excess_J"] = float(excess)
    figures["diverged"] = bool(not finite or not completed
                               or not figures["max_penetration_m"] <= DIVERGED_PENETRATION_M
                               or not excess <= DIVERGED_ENERGY_FRACTION * abs(truth.potential[0]))
    figures["departed"] = bool(not figures["position_error_max_m"] <= DEPARTED_M)
    worst = np.unravel_index(np.nanargmax(err), err.shape)
    figures["worst_container"] = learned.names[worst[1]] if learned.names else int(worst[1])
    figures["worst_time_s"] = float(learned.time[worst[0]])
    return figures


def joules(value) -> str:
    """An energy [J] as the gates write theirs (testbed.gates.format_value: 4 significant digits),
    so that one figure reads the same in the printed lines, the table, the gates and the report;
    '-' for None (not measured)."""
    return "-" if value is None else format_value(float(value), "J")


def energy_text(f: dict) -> str:
    """'energy gain max 4201 J raw, 0 J net of external work (...)' of compare.json figures `f`:
    the raw E(t) - E(0) and, where measured (external_work.energy_figures), the energy net of the
    external actors' work beyond the truth's, the energy gate's figure."""
    raw = f"energy gain max {joules(f['energy_gain_max_J'])} J raw"
    if f.get("energy_created_J") is None:
        return raw
    if not f.get("external_work_counted"):
        work = "the records cannot give the external work: W = 0"
    elif f.get("external_work_max_J"):
        work = f"external work max |W| {joules(f['external_work_max_J'])} J"
    else:
        work = "no external actor"
    return f"{raw}, {joules(f['energy_created_J'])} J net of external work (the energy gate's figure; {work})"


def error_lines(f: dict, engine_label: str, engine_wall: float) -> list[str]:
    """The error and speed lines `testbed compare` prints for figures `f` (compare.json
    keys) of the run under test, labelled `engine_label`, costing `engine_wall` [s per s]."""
    point = f", Drake point {f['wall_per_sim_s_point']:.3f} s" if "wall_per_sim_s_point" in f else ""
    return [
        f"  position error max {f['position_error_max_m'] * 1e3:.3f} mm (final {f['final_position_error_max_m'] * 1e3:.3f} mm, "
        f"angle {f['final_angle_error_max_deg']:.4f} deg); max penetration {f['max_penetration_m'] * 1e3:.3f} mm; "
        f"{energy_text(f)}",
        f"  wall per simulated second: {engine_label} {engine_wall:.4f} s (real-time factor "
        f"{real_time_factor(engine_wall):.3g}x over t = 0-{f['simulated_s_learned']:g} s), Drake hydroelastic "
        f"{f['wall_per_sim_s_truth']:.3f} s{point}",
    ]
