"""The quantities the gates judge, read from one run's records (the contact log's `steps` and
`contacts` tables, testbed/effects/contact_log.py), so that every rung is measured alike.

Per free container <name> (scene order), at the run's last record:
  <name>.final_x_m, .final_y_m, .final_z_m   position of the body origin (the box's
                                             geometric centre) in W [m]
  <name>.final_angle_deg                     rotation from its initial orientation [deg]
    (the closed-loop gates' final position and final angle, testbed/gates/closed_loop.py)
Per scene:
  peak_tilt_deg        largest rotation of any free container from its initial orientation
                       over the run [deg] (what the outcome gate reads at the end)
  max_penetration_m    deepest penetration over the records [m]: container-container by the
                       separating-axis depth of the two boxes, container-ground by the lowest
                       corner below the ground's top face (as testbed.compare.metrics.penetrations,
                       from poses alone: the same on every rung, whatever its collision mesh)
  landing_peak_force_N only where a container lands (its first contact comes after
                       LANDING_AFTER_S): the largest total normal force [N] on a landing
                       container over the records from its first contact on
"""

from __future__ import annotations

import numpy as np

from testbed.gates.closed_loop import FINAL_ANGLE_TOL_DEG, FINAL_POSITION_TOL_M, MAX_PENETRATION_M
from testbed.geometry.boxes import box_box_signed_distance, pose_of_B_in_A
from testbed.geometry.rotations import angle_between_quaternions_deg, rotation_from_quaternion

LANDING_AFTER_S = 0.02  # [s] a container first touching later than this lands (one touching at t=0 rests)

# The resolution below which two rungs' values are not told apart (a floor under every
# uncertainty band): RESOLUTION_FRACTION of the closed-loop gate's bound on the quantity
# (testbed/gates/closed_loop.py: 2 cm final position -> 1 mm, 0.5 deg final angle -> 0.025 deg,
# 20 mm penetration -> 1 mm), and FORCE_RESOLUTION_REL of a force (no gate bounds it yet).
RESOLUTION_FRACTION = 0.05
FORCE_RESOLUTION_REL = 0.01


def resolution(name: str, value: float | None) -> float:
    """The resolution floor [unit of the quantity] of quantity `name` at `value`."""
    if name == "max_penetration_m":
        return RESOLUTION_FRACTION * MAX_PENETRATION_M
    if name.endswith("_N"):
        return FORCE_RESOLUTION_REL * abs(value or 0.0)
    return RESOLUTION_FRACTION * (FINAL_ANGLE_TOL_DEG if name.endswith("_deg") else FINAL_POSITION_TOL_M)


def _initial_quaternions(specs) -> np.ndarray:
    return np.array([s.pose().rotation().ToQuaternion().wxyz() for s in specs]).reshape(-1, 4)


def max_penetration(scenario, steps: dict) -> float:
    """Deepest penetration [m] over the records (see the module doc); 0 when nothing touches."""
    specs = scenario.containers
    n = len(steps["time"])
    p = np.zeros((n, len(specs), 3))
    R = np.zeros((n, len(specs), 3, 3))
    k = 0
    for i, spec in enumerate(specs):
        if spec.fixed:
            X = spec.pose()
            p[:, i], R[:, i] = X.translation(), X.rotation().matrix()
        else:
            p[:, i], R[:, i] = steps["p_WB"][:, k], rotation_from_quaternion(steps["q_WB"][:, k])
            k += 1
    half = np.array([s.container_type().half_size for s in specs]).reshape(-1, 3)  # (m, 3) [m]
    deepest = 0.0
    if scenario.ground:
        top = scenario.ground_surface.height if scenario.ground_surface is not None else 0.0  # [m] quay slab top: z = 0
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        lowest = (p[:, :, None, 2] + np.einsum("nmj,mkj->nmk", R[:, :, 2, :], half[:, None, :] * signs)).min()
        deepest = max(deepest, float(top - lowest))
    for a in range(len(specs)):
        for b in range(a + 1, len(specs)):
            if specs[a].fixed and specs[b].fixed:
                continue
            p_AB, R_AB = pose_of_B_in_A(p[:, a], R[:, a], p[:, b], R[:, b])
            d = box_box_signed_distance(p_AB, R_AB, half[a], half[b])
            deepest = max(deepest, float(-np.min(d)))
    return max(0.0, deepest)


def landing_peak_force(scenario, body_names, contacts: dict) -> float | None:
    """Largest total normal force [N] on a container that lands (module doc); None: none lands."""
    peak = None
    if not len(contacts["time"]):
        return None
    for spec in scenario.containers:
        if spec.fixed:
            continue
        body = body_names.index(spec.name)
        rows = (contacts["a"] == body) | (contacts["b"] == body)
        if not np.any(rows) or contacts["time"][rows].min() <= LANDING_AFTER_S:
            continue
        steps, inverse = np.unique(contacts["step"][rows], return_inverse=True)
        total = np.zeros(len(steps))
        np.add.at(total, inverse, np.abs(contacts["fn"][rows]))
        peak = max(peak or 0.0, float(total.max()))
    return peak


def quantities(scenario, body_names, tables: dict) -> dict[str, float]:
    """{quantity name: value} of one run (module doc for names, units and frames)."""
    steps, contacts = tables["steps"], tables["contacts"]
    free = [s for s in scenario.containers if not s.fixed]
    q0 = _initial_quaternions(free)  # (m, 4)
    out: dict[str, float] = {}
    tilt = angle_between_quaternions_deg(steps["q_WB"], q0[None])  # (n, m) [deg]
    for k, spec in enumerate(free):
        for axis, value in zip("xyz", steps["p_WB"][-1, k]):
            out[f"{spec.name}.final_{axis}_m"] = float(value)
        out[f"{spec.name}.final_angle_deg"] = float(tilt[-1, k])
    out["peak_tilt_deg"] = float(np.max(tilt)) if tilt.size else 0.0
    out["max_penetration_m"] = max_penetration(scenario, steps)
    force = landing_peak_force(scenario, body_names, contacts)
    if force is not None:
        out["landing_peak_force_N"] = force
    return out
