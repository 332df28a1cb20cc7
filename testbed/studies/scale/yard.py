"""The scale study's yards: an N-container block laid out for N, settled or with one crane.

layout(n, tiers): N / tiers stacks as square as N allows. yard_scenario(n, config, kind, state):
the block as a loaded Scenario (validated like a scene file) at the learned law's modulus, with
the dynamics alone (every recorder, observer and viewer off):

- 'settled': the block alone;
- 'crane': the block and one load (config.crane_type, crane_mass) hanging at rest on the crane
  effect's four ropes (testbed/effects/crane.py) config.crane_gap [m] above the top of the
  middle stack (row (rows + 1) // 2, bay (bays + 1) // 2), the hoist paying out from t = 0 at
  config.crane_speed and crane_acceleration: the load lands on that stack and settles there.

`hold` [s]: the crane's hoist waits this long (a pause move): the yard that continues its
settling run into the timed window (window.py) starts from rest with the load hanging
crane_gap above the top of its stack, which sags by its contacts' compression while settling
(about 1 mm: the load is that much higher when the hoist starts; the row says by how much).

`state` (SettledState: the end of a settling run) places every block container where that run
left it, with its velocity, so that a timed window starts past the settling transient; the
crane's load is then placed crane_gap above the settled top of its stack.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import yaml
from pydrake.common.eigen_geometry import Quaternion
from pydrake.common.schema import Transform
from pydrake.math import RigidTransform

from testbed.bodies.containers import CONTAINER_TYPES
from testbed.engines.comparison import engine_variant
from testbed.engines.three_way import at_law_modulus
from testbed.scenario import load_scenario
from testbed.studies.scale.settings import YARD_CONTACT, ScaleConfig

LOAD = "load"  # the crane's container
ROPE_LENGTH = 8.0  # [m] from the sheaves to the load's top at t = 0


@dataclasses.dataclass
class SettledState:
    """Every free container at the end of a settling run: names (m,), p_WB (m, 3) [m], q_WB
    (m, 4) wxyz, V_WB (m, 6) [wx wy wz vx vy vz] in W [rad/s, m/s]; time [s] simulated."""

    names: list
    p_WB: np.ndarray
    q_WB: np.ndarray
    V_WB: np.ndarray
    time: float


def layout(n: int, tiers: int) -> tuple[int, int, int]:
    """(rows, bays, tiers) of an N-container block: N / tiers stacks, rows the largest divisor
    of the stack count not above its square root (4 x 6 for 24 stacks, 1 x 7 for 7)."""
    stacks = n // tiers
    rows = max(d for d in range(1, math.isqrt(stacks) + 1) if stacks % d == 0)
    return rows, stacks // rows, tiers


def crane_stack(n: int, config: ScaleConfig) -> tuple[int, int]:
    """(row, bay), 1-based, of the stack the crane's load lands on: the block's middle one."""
    rows, bays, _ = layout(n, config.tiers)
    return (rows + 1) // 2, (bays + 1) // 2


def top_name(n: int, config: ScaleConfig) -> str:
    """The name of the top container of the crane's stack."""
    row, bay = crane_stack(n, config)
    return f"blk_r{row}_b{bay}_t{config.tiers}"


def _load_z(top_z: float, config: ScaleConfig) -> float:
    """[m] the load's centre height crane_gap above a top container whose centre is at top_z."""
    return top_z + 0.5 * CONTAINER_TYPES[config.container_type].size[2] + config.crane_gap + \
        0.5 * CONTAINER_TYPES[config.crane_type].size[2]


def yard_scene(n: int, config: ScaleConfig, kind: str = "settled", duration: float | None = None,
               hold: float = 0.0) -> dict:
    """The scene (a dict, as a scene file's YAML) of the N-container yard of `kind`, run for
    `duration` [s] (None: config.duration_for(n)) at config.time_step [s]; the crane pauses
    `hold` [s] before its hoist (a window that continues the settling run starts then)."""
    rows, bays, tiers = layout(n, config.tiers)
    scene = {"name": f"yard_{rows}x{bays}x{tiers}" + ("_crane" if kind == "crane" else ""),
             "description": f"{n} containers: {rows} rows x {bays} bays x {tiers} tiers"
                            + (", one load landing on the middle stack" if kind == "crane" else ""),
             "duration": config.duration_for(n) if duration is None else duration, "plant": {"time_step": config.time_step},
             "yards": [{"name": "blk", "type": config.container_type, "rows": rows, "bays": bays, "tiers": tiers,
                        "row_gap": config.row_gap, "bay_gap": config.bay_gap,
                        "mass_range": [float(m) for m in config.mass_range], "seed": config.seed}],
             "effects": {"contact": {"model": YARD_CONTACT, "approximation": "auto"}, "friction": {}}}
    if kind == "crane":
        row, bay = crane_stack(n, config)
        size = CONTAINER_TYPES[config.container_type].size
        x = (bay - 1 - 0.5 * (bays - 1)) * (size[0] + config.bay_gap)  # the block frame is W (origin 0, yaw 0)
        y = (row - 1 - 0.5 * (rows - 1)) * (size[1] + config.row_gap)
        z = _load_z((tiers - 0.5) * size[2], config)
        scene["containers"] = [{"name": LOAD, "type": config.crane_type, "mass": float(config.crane_mass),
                                "X_WC": {"translation": [x, y, z]}}]
        scene["effects"]["crane"] = {
            "container": LOAD, "trolley_height": z + 0.5 * CONTAINER_TYPES[config.crane_type].size[2] + ROPE_LENGTH,
            "moves": [{"kind": "pause", "duration": float(hold)}] * (hold > 0) + [
                {"kind": "hoist", "target": config.crane_gap + 0.05, "speed": config.crane_speed,
                 "acceleration": config.crane_acceleration}]}
    return scene


def yard_scenario(n: int, config: ScaleConfig, kind: str = "settled", state: SettledState | None = None,
                  duration: float | None = None, hold: float = 0.0):
    """The yard of `kind` as a loaded Scenario (module doc), from rest or from `state`; the
    crane pauses `hold` [s] before its hoist."""
    scene = yard_scene(n, config, kind, duration, hold)
    scenario = engine_variant(at_law_modulus(load_scenario(text=yaml.safe_dump(scene, sort_keys=False))), "truth")
    if state is not None:
        apply_state(scenario, state)
        if kind == "crane":
            top = next(c for c in scenario.containers if c.name == top_name(n, config))
            load = next(c for c in scenario.containers if c.name == LOAD)
            p = np.array(load.X_WC.translation, float)
            p[2] = _load_z(float(np.asarray(top.X_WC.translation)[2]), config)
            load.X_WC = Transform(RigidTransform(p))
            scenario.effects.crane.trolley_height = p[2] + 0.5 * CONTAINER_TYPES[config.crane_type].size[2] + ROPE_LENGTH
    return scenario


def apply_state(scenario, state: SettledState) -> None:
    """Places every container of `scenario` named in `state` at its pose and velocity there."""
    index = {name: i for i, name in enumerate(state.names)}
    for c in scenario.containers:
        i = index.get(c.name)
        if i is None:
            continue
        q = np.asarray(state.q_WB[i], float)
        X = RigidTransform(Quaternion(q / np.linalg.norm(q)), np.asarray(state.p_WB[i], float))
        c.X_WC = Transform(X)
        c.V_WC = [float(v) for v in state.V_WB[i]]
