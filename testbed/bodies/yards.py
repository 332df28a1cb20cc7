"""Yard blocks in a scene: rows x bays x tiers of one container type in a few lines.

A scene's `yards:` list lays out blocks that the loader expands into ordinary containers
(testbed.scenario.validate_scenario appends them to `containers:` and empties `yards:`), so
the builder, the effects, the MuJoCo engine and compare see plain containers:

    yards:
    - name: blk                        # name prefix: blk_r1_b1_t1 ... (row, bay, tier; 1-based)
      type: 1AA                        # 1CC | 1AA | 1AAA (testbed/bodies/containers.py)
      origin: [0.0, 0.0]               # (x, y) of the block's footprint centre in W [m]
      yaw_deg: 0.0                     # block frame Y about +z from W [deg]
      rows: 4                          # along Y's y (the containers' width)
      bays: 6                          # along Y's x (the containers' length)
      tiers: 4                         # along z
      row_gap: 0.4                     # [m] clear space between neighbouring rows
      bay_gap: 0.6                     # [m] clear space between neighbouring bays
      masses: [28000, 24000, 20000, 16000]   # [kg] per tier, bottom first; or:
      mass_range: [8000, 28000]        # [kg] drawn uniformly per container with `seed`,
      seed: 1                          #   each stack sorted heaviest at the bottom
      empty: [{row: 2, bay: 3}]        # slots left without a stack (1-based)
      base_z: 0.0                      # [m] z of the bottom tier's bottom face in W

Neither masses nor mass_range: every container at its type's tare. Frames: the block frame Y
has its origin at (origin, base_z), x along the bays, y along the rows, z up; every container's
frame C is aligned with Y (its length along Y's x). Containers are placed exactly touching,
face on face (each tier's centre at base_z + (tier - 1/2) height), as the shipped stack scenes
place theirs: zero initial overlap, so overlap_tolerance is never used up; the stack settles by
its static compression in the first steps.
"""


import dataclasses
import math
import typing

import numpy as np

from testbed.bodies.containers import CONTAINER_TYPES
from testbed.errors import ScenarioError

MAX_YARD_CONTAINERS = 1000  # per block; a scene file holds at most about 1,700 listed containers
MAX_TIERS = 12  # the highest container stacks on ships are 11-12 high


@dataclasses.dataclass
class StackRef:
    """One stack's place in a block: its row and bay, 1-based."""

    row: int = 1
    bay: int = 1


@dataclasses.dataclass
class YardSpec:
    """One yard block (see the module docstring for the YAML form and the frames)."""

    name: str = "yard"  # prefix of the containers' names
    type: str = "1AA"
    origin: typing.List[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0])  # (x, y) in W [m]
    yaw_deg: float = 0.0  # [deg] about +z
    rows: int = 1
    bays: int = 1
    tiers: int = 1
    row_gap: float = 0.4  # [m]
    bay_gap: float = 0.6  # [m]
    masses: typing.List[float] = dataclasses.field(default_factory=list)  # [kg] per tier, bottom first
    mass_range: typing.List[float] = dataclasses.field(default_factory=list)  # [kg] [low, high]
    seed: int = 0
    empty: typing.List[StackRef] = dataclasses.field(default_factory=list)  # slots left without a stack
    base_z: float = 0.0  # [m]


@dataclasses.dataclass(frozen=True)
class YardSlot:
    """One container of an expanded block: name, type, total mass [kg], centre p_WC (3,) [m]
    and yaw [deg] of C about +z in W."""

    name: str
    type: str
    mass: float
    p_WC: tuple[float, float, float]
    yaw_deg: float


def validate_yard(yard: YardSpec, where: str, source) -> None:
    """Raises ScenarioError (field path under `where`, e.g. 'yards[0]') for any bad field."""
    if not yard.name or not yard.name.replace("_", "").isalnum():
        raise ScenarioError(source, f"{where}.name", f"expected a non-empty name prefix of letters, digits and '_', got {yard.name!r}")
    if yard.type not in CONTAINER_TYPES:
        raise ScenarioError(source, f"{where}.type", f"unknown container type {yard.type!r}; expected one of: {', '.join(CONTAINER_TYPES)}")
    if len(yard.origin) != 2 or not all(math.isfinite(v) for v in yard.origin):
        raise ScenarioError(source, f"{where}.origin", f"expected 2 finite numbers (x, y) [m], got {yard.origin}")
    for field in ("yaw_deg", "base_z"):
        if not math.isfinite(getattr(yard, field)):
            raise ScenarioError(source, f"{where}.{field}", f"expected a finite number, got {getattr(yard, field)}")
    for field in ("rows", "bays", "tiers"):
        value = getattr(yard, field)
        if not value >= 1:
            raise ScenarioError(source, f"{where}.{field}", f"expected a whole number >= 1, got {value}")
    if yard.tiers > MAX_TIERS:
        raise ScenarioError(source, f"{where}.tiers", f"{yard.tiers} tiers is above the supported {MAX_TIERS}")
    if yard.rows * yard.bays * yard.tiers > MAX_YARD_CONTAINERS:
        raise ScenarioError(source, where, f"{yard.rows} rows x {yard.bays} bays x {yard.tiers} tiers = "
                                           f"{yard.rows * yard.bays * yard.tiers} containers; expected at most {MAX_YARD_CONTAINERS} per block")
    for field in ("row_gap", "bay_gap"):
        value = getattr(yard, field)
        if not (math.isfinite(value) and 0 <= value <= 100):
            raise ScenarioError(source, f"{where}.{field}", f"expected a clear gap in [0, 100] m, got {value}")
    kind = CONTAINER_TYPES[yard.type]
    lo, hi = kind.tare_mass, kind.max_gross_mass
    if yard.masses and yard.mass_range:
        raise ScenarioError(source, f"{where}.mass_range", "give either masses (per tier) or mass_range (drawn), not both")
    if yard.masses:
        if len(yard.masses) != yard.tiers:
            raise ScenarioError(source, f"{where}.masses", f"expected one mass per tier ({yard.tiers}, bottom first) [kg], got {len(yard.masses)}")
        for t, m in enumerate(yard.masses):
            if not (math.isfinite(m) and lo <= m <= hi):
                raise ScenarioError(source, f"{where}.masses[{t}]", f"expected a {yard.type} mass between its tare {lo:g} kg "
                                                                    f"and its maximum gross {hi:g} kg, got {m}")
    if yard.mass_range:
        r = yard.mass_range
        if len(r) != 2 or not all(math.isfinite(v) and lo <= v <= hi for v in r) or r[0] > r[1]:
            raise ScenarioError(source, f"{where}.mass_range", f"expected [low, high] [kg] with {lo:g} <= low <= high <= {hi:g} "
                                                               f"(the {yard.type}'s tare and maximum gross), got {r}")
    if not 0 <= yard.seed < 2**63:
        raise ScenarioError(source, f"{where}.seed", f"expected a non-negative integer seed, got {yard.seed}")
    seen = set()
    for k, slot in enumerate(yard.empty):
        for field, count in (("row", yard.rows), ("bay", yard.bays)):
            if not 1 <= getattr(slot, field) <= count:
                raise ScenarioError(source, f"{where}.empty[{k}].{field}", f"expected 1 <= {field} <= {count}, got {getattr(slot, field)}")
        if (slot.row, slot.bay) in seen:
            raise ScenarioError(source, f"{where}.empty[{k}]", f"slot row {slot.row}, bay {slot.bay} is listed twice")
        seen.add((slot.row, slot.bay))
    if len(seen) == yard.rows * yard.bays:
        raise ScenarioError(source, f"{where}.empty", "leaves every slot empty; expected at least one stack")


def yard_slots(yard: YardSpec) -> list[YardSlot]:
    """The block's containers (validated `yard`), row by row, bay by bay, bottom tier first."""
    kind = CONTAINER_TYPES[yard.type]
    length, width, height = kind.size
    pitch_x, pitch_y = length + yard.bay_gap, width + yard.row_gap  # [m] centre to centre
    yaw = math.radians(yard.yaw_deg)
    R = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])  # R_WY in the plane
    masses = np.full((yard.rows, yard.bays, yard.tiers), kind.tare_mass)
    if yard.masses:
        masses[:] = np.asarray(yard.masses, float)
    elif yard.mass_range:
        drawn = np.random.default_rng(yard.seed).uniform(yard.mass_range[0], yard.mass_range[1], masses.shape)
        masses = -np.sort(-drawn, axis=2)  # heaviest at the bottom of each stack
    empty = {(s.row, s.bay) for s in yard.empty}
    out = []
    for r in range(yard.rows):
        for b in range(yard.bays):
            if (r + 1, b + 1) in empty:
                continue
            p_Y = np.array([(b - 0.5 * (yard.bays - 1)) * pitch_x, (r - 0.5 * (yard.rows - 1)) * pitch_y])
            x, y = R @ p_Y + np.asarray(yard.origin, float)
            for t in range(yard.tiers):
                z = yard.base_z + (t + 0.5) * height
                out.append(YardSlot(name=f"{yard.name}_r{r + 1}_b{b + 1}_t{t + 1}", type=yard.type,
                                    mass=round(float(masses[r, b, t]), 3), p_WC=(round(float(x), 9) + 0.0, round(float(y), 9) + 0.0, round(float(z), 9)),
                                    yaw_deg=float(yard.yaw_deg)))
    return out
