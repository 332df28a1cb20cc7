"""Validation of a scene's fields: `validate_scenario` (physical and semantic checks that need
no diagram; overlaps are checked by the builder), the physically meaningful BOUNDS, and the
expansion of yard blocks into containers. Every problem is one ScenarioError naming the
file, the field path and the value expected."""

import math

import numpy as np
from pydrake.common.schema import Transform

from testbed.bodies.boxes import BOX_TYPE, validate_box, validate_ground
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.bodies.models import GROUND_NAME
from testbed.bodies.yards import validate_yard, yard_slots
from testbed.effects import registry
from testbed.errors import ScenarioError, one_of
from testbed.scenario.spec import TRUTH_REFERENCES, ContainerSpec, Scenario


def validate_scenario(scenario: Scenario, source: object = "<scenario>") -> dict:
    """Physical and semantic checks that need no diagram (overlaps are checked by the builder).
    Returns the declared effects, constructed and checked: {name: Effect}, build order."""
    if not (scenario.duration > 0 and math.isfinite(scenario.duration)):
        raise ScenarioError(source, "duration", f"expected a positive number of seconds, got {scenario.duration}")
    if not scenario.plant.time_step > 0:
        raise ScenarioError(source, "plant.time_step", "expected a positive discrete time step [s] (continuous plants "
                                                       f"are not supported), got {scenario.plant.time_step}")
    if scenario.truth.reference not in TRUTH_REFERENCES:
        raise ScenarioError(source, "truth.reference", f"unknown {scenario.truth.reference!r}; expected one of: "
                                                       f"{', '.join(TRUTH_REFERENCES)}")
    if not 1e-8 <= scenario.truth.accuracy <= 0.1:
        raise ScenarioError(source, "truth.accuracy", f"expected an error-control accuracy in [1e-08, 0.1], got "
                                                      f"{scenario.truth.accuracy}")
    expand_yards(scenario, source)
    if not scenario.containers:
        raise ScenarioError(source, "containers", "expected at least one container")
    seen: set[str] = set()
    for i, c in enumerate(scenario.containers):
        where = f"containers[{i}]"
        if c.type not in CONTAINER_TYPES and c.type != BOX_TYPE:
            raise ScenarioError(source, f"{where}.type", f"unknown container type {c.type!r}; {one_of(c.type, [*CONTAINER_TYPES, BOX_TYPE])}")
        validate_box(c, where, source)
        if not c.name or not c.name.replace("_", "").isalnum():
            raise ScenarioError(source, f"{where}.name", f"expected a non-empty name of letters, digits and '_', got {c.name!r}")
        if c.name in seen or c.name == GROUND_NAME:
            raise ScenarioError(source, f"{where}.name", f"duplicate or reserved name {c.name!r}; names must be unique")
        seen.add(c.name)
        mass = c.total_mass()
        if not (math.isfinite(mass) and mass > 0):
            raise ScenarioError(source, f"{where}.mass", f"expected a positive mass [kg], got {mass}")
        if len(c.com_offset) != 3 or not np.all(np.isfinite(c.com_offset)):
            raise ScenarioError(source, f"{where}.com_offset", f"expected 3 finite numbers [m], got {c.com_offset}")
        half = c.container_type().half_size
        if np.any(np.abs(c.com_offset) >= half):
            raise ScenarioError(source, f"{where}.com_offset", f"centre of mass {c.com_offset} lies outside the {c.type} box (half extents {half.tolist()} m)")
        if len(c.V_WC) != 6 or not np.all(np.isfinite(c.V_WC)):
            raise ScenarioError(source, f"{where}.V_WC", f"expected 6 finite numbers [wx, wy, wz, vx, vy, vz], got {c.V_WC}")
        try:
            X = c.pose()
        except Exception as e:
            raise ScenarioError(source, f"{where}.X_WC", f"expected a fixed (deterministic) pose: {e}") from None
        if not np.all(np.isfinite(X.translation())):
            raise ScenarioError(source, f"{where}.X_WC", "expected a finite translation")
    _check_bounds(scenario, source)
    if scenario.ground_surface is not None:
        validate_ground(scenario.ground_surface, source)
    effects = {name: registry()[name](getattr(scenario.effects, name), scenario, source) for name in scenario.declared_effects()}
    for effect in effects.values():
        effect.check(effects)
    return effects


def expand_yards(scenario: Scenario, source: object = "<scenario>") -> None:
    """Validates `scenario.yards` and appends their containers to `scenario.containers`
    (after the listed ones, block by block), then empties `yards`: everything downstream,
    and a dumped scene, sees plain containers. Idempotent."""
    listed = {c.name for c in scenario.containers}
    for i, yard in enumerate(scenario.yards):
        validate_yard(yard, f"yards[{i}]", source)
        for slot in yard_slots(yard):
            if slot.name in listed or slot.name == GROUND_NAME:
                raise ScenarioError(source, f"yards[{i}].name", f"prefix {yard.name!r} makes the name {slot.name!r}, "
                                                                "which another container or yard already has; names must be unique")
            listed.add(slot.name)
            if max(abs(slot.p_WC[0]), abs(slot.p_WC[1])) > BOUNDS["position"]:
                raise ScenarioError(source, f"yards[{i}].origin", f"the block reaches {slot.p_WC[:2]} m, outside the supported "
                                                                  f"range |x|, |y| <= {BOUNDS['position']:g} m")
            X_WC = Transform(translation=list(slot.p_WC))
            if slot.yaw_deg:
                X_WC.set_rotation_rpy_deg([0.0, 0.0, slot.yaw_deg])
            scenario.containers.append(ContainerSpec(name=slot.name, type=slot.type, mass=slot.mass, X_WC=X_WC))
    scenario.yards = []


# Physically meaningful ranges. Values outside them are typos or unit mistakes, and they
# would otherwise reach the solver (a 1e9 m/s velocity, a 1e30 kg mass) and fail deep
# inside Drake or produce garbage. The ranges are wide on purpose: the stress suite puts a
# 32.5 kg box under a 32.5 t one, the calibration a 0.37 kg cube on a table.
BOUNDS = {
    "duration": (0.0, 3600.0),  # [s] an hour of simulated time at most
    "time_step": (1e-6, 0.1),  # [s]
    "mass": (1e-3, 1e6),  # [kg] 1 g to 1000 t (33x a fully loaded 40 ft container)
    "position": 1e3,  # [m] |p_WC| per axis; the quay slab is 400 m wide
    "speed": 100.0,  # [m/s] |v_WC|; a 500 m free fall reaches 99 m/s
    "spin": 100.0,  # [rad/s] |w_WC|
}


def _check_bounds(scenario: Scenario, source) -> None:
    """Raises ScenarioError for values outside BOUNDS (field path, value and range named)."""
    lo, hi = BOUNDS["duration"]
    if not scenario.duration <= hi:
        raise ScenarioError(source, "duration", f"{scenario.duration} s is outside the supported range (0, {hi:g}] s")
    lo, hi = BOUNDS["time_step"]
    if not lo <= scenario.plant.time_step <= hi:
        raise ScenarioError(source, "plant.time_step", f"{scenario.plant.time_step} s is outside the supported range [{lo:g}, {hi:g}] s")
    for i, c in enumerate(scenario.containers):
        where = f"containers[{i}]"
        lo, hi = BOUNDS["mass"]
        if not lo <= c.total_mass() <= hi:
            raise ScenarioError(source, f"{where}.mass", f"{c.total_mass():g} kg is outside the supported range [{lo:g}, {hi:g}] kg")
        p = np.asarray(c.pose().translation())
        if np.any(np.abs(p) > BOUNDS["position"]):
            raise ScenarioError(source, f"{where}.X_WC.translation", f"{p.tolist()} m is outside the supported range |x|, |y|, |z| <= {BOUNDS['position']:g} m")
        w, v = np.asarray(c.V_WC[:3], float), np.asarray(c.V_WC[3:], float)
        if np.linalg.norm(v) > BOUNDS["speed"]:
            raise ScenarioError(source, f"{where}.V_WC", f"speed {np.linalg.norm(v):g} m/s is above the supported {BOUNDS['speed']:g} m/s")
        if np.linalg.norm(w) > BOUNDS["spin"]:
            raise ScenarioError(source, f"{where}.V_WC", f"angular speed {np.linalg.norm(w):g} rad/s is above the supported {BOUNDS['spin']:g} rad/s")
