"""Seeded pose distributions for a container pair (A, B) in contact.

A sample here is a *proposal*: the container types, B's orientation R_AB, a base
point and a unit direction u (both in A's frame) and a target penetration depth.
The labeller (labels.py) moves B from the base along u, bisecting with Drake's signed
distance until the penetration equals the target, so p_AB = base + s u.

Distributions
- "stacking": B above A as a crane lands it. Yaw uniform in [-pi, pi); roll and pitch
  uniform in +-5 deg; 30 % of samples are near-parallel (roll, pitch within +-0.05 deg)
  and half of those also have yaw within +-0.5 deg of a multiple of 90 deg (aligned
  stacking, the case the paper calls worst); 20 % of the horizontal offsets are
  within +-0.1 m of centred, the rest uniform over offsets whose footprints overlap by
  at least 0.1 m (2-D separating-axis test). u = +z of A.
- "general": any relative orientation (uniform on SO(3)) and any approach direction
  (uniform on the sphere), base = A's centre. Covers vertex-face, edge-face, edge-edge
  and face-face contact in the proportions that uniform sampling gives; 15 % of the
  orientations are snapped to within +-1 deg of one of the 24 axis-aligned rotations
  so that face-face and edge-face contact are well represented.
Penetration depth is uniform in [0, 3 cm] in both.
- "resting": where shipped stacks sit at the 1e9 Pa modulus: B stacked on A,
  penetration log-uniform in [RESTING_DEPTH] (5 um to 0.5 mm), roll and pitch uniform
  within +-0.05 deg, yaw uniform within +-2 deg, horizontal offset of B's centre
  uniform in +-0.4 m along each of A's x and y axes. u = +z of A. Its ranges are fixed
  (max_depth and max_tilt_deg are refused for it).
- "resting_wide": the same with every range widened to the resting expert's margin
  (RESTING_RANGES: 5 um to 1 mm, 0.1 deg, 3 deg, 0.5 m), so that the expert is trained
  wherever its gate (learned_contact.model.expert) lets it answer, ramps included.
- "resting_level": "resting" with the tilt of B's z axis from A's log-uniform in
  RESTING_LEVEL_TILT (1e-9 to 1e-3 rad, any direction) instead of roll and pitch uniform
  within 0.05 deg, where tilts below 1e-5 rad are rare: stacks settled under a centred
  load sit that level, and there the tilt across the patch is a fraction of the overlap.
- "resting_wider": where landings and overhangs leave a box resting (RESTING_WIDER):
  "resting" with yaw uniform within +-6 deg, B's centre offset uniformly up to 3 m along
  A's x (its length: a 40 ft box bridging two 20 ft ones sits 3 m off each) and 0.6 m
  along A's y, and half of the poses exactly level (roll = pitch = 0: B's z is A's z to
  the last bit), the others with roll and pitch uniform within +-0.05 deg.
- "resting_support": the resting expert's per-axis gate (RESTING_SUPPORT): B resting
  on A with B's centre offset along A's x by u_x e_x and along A's y by u_y e_y, where
  e_i = max(h_A,i, h_B,i) is the edge of support along axis i (beyond it neither box's centre
  of mass lies over the other's face, so neither can rest on the other alone) and u_x, u_y are
  uniform within +-1 and +-0.5: overhangs out to the edge, a 20 ft box at either end of a 40 ft
  one, a 40 ft box across two 20 ft ones (u_x = 0.5). Yaw uniform within +-6 deg, overlap
  log-uniform in 5 um-1 mm; tilt of B's z from A's log-uniform in 1e-9 rad to sin(0.1 deg) in
  half of the poses (as "resting_level"), roll and pitch uniform within +-0.07 deg in the rest,
  so that the gate's tilt and depth ramps are trained too.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np

from learned_contact.errors import DatasetError
from learned_contact.interface import SIZE_TOLERANCE
from testbed.bodies.containers import CONTAINER_TYPES, container_type
from testbed.errors import TestbedError
from testbed.geometry.rotations import random_rotations, rotation_from_rpy

DISTRIBUTIONS = ("stacking", "general", "resting", "resting_wide", "resting_level", "resting_wider",
                 "resting_support")  # append only: the index seeds the stream
DEFAULT_TYPES = ("1CC", "1AA", "1AAA")
MAX_DEPTH = 0.03  # [m]
RESTING_DEPTH = (5e-6, 5e-4)  # [m] log-uniform penetration of the "resting" distribution
RESTING_TILT_DEG, RESTING_YAW_DEG, RESTING_OFFSET = 0.05, 2.0, 0.4  # [deg], [deg], [m]
# distribution -> (depth range [m] log-uniform, roll/pitch bound [deg], yaw bound [deg], offset bound [m])
RESTING_RANGES = {"resting": (RESTING_DEPTH, RESTING_TILT_DEG, RESTING_YAW_DEG, RESTING_OFFSET),
                  "resting_wide": ((5e-6, 1e-3), 0.1, 3.0, 0.5),
                  "resting_level": (RESTING_DEPTH, None, RESTING_YAW_DEG, RESTING_OFFSET)}
RESTING_LEVEL_TILT = (1e-9, 1e-3)  # [rad] log-uniform tilt of "resting_level"
# "resting_wider": depth range [m] log-uniform, roll/pitch bound [deg], yaw bound [deg], offset bounds
# along A's x and y [m], fraction of exactly level poses
RESTING_WIDER = {"depth": RESTING_DEPTH, "tilt_deg": RESTING_TILT_DEG, "yaw_deg": 6.0, "offset": (3.0, 0.6),
                 "level_fraction": 0.5}
# "resting_support": depth range [m] log-uniform, roll/pitch bound [deg], log-uniform tilt range [rad] and
# the fraction of poses drawn so, yaw bound [deg], offset bounds along A's x and y as fractions of the edge of
# support max(h_A,i, h_B,i)
RESTING_SUPPORT = {"depth": (5e-6, 1e-3), "tilt_deg": 0.07, "level_tilt": (1e-9, float(np.sin(np.radians(0.1)))),
                   "level_fraction": 0.5, "yaw_deg": 6.0, "support": (1.0, 0.5)}
FIXED_RANGES = (*RESTING_RANGES, "resting_wider", "resting_support")  # distributions that refuse max_depth / max_tilt_deg


@dataclasses.dataclass(frozen=True)
class Proposals:
    """n pose proposals (see module docstring). Arrays in A's frame.

    type_a, type_b (n,) int indices into `types`; R_AB (n, 3, 3); base (n, 3) [m];
    direction (n, 3) unit; depth (n,) [m] target penetration.
    """

    types: tuple[str, ...]
    type_a: np.ndarray
    type_b: np.ndarray
    R_AB: np.ndarray
    base: np.ndarray
    direction: np.ndarray
    depth: np.ndarray

    def __len__(self) -> int:
        return len(self.depth)

    def sizes(self) -> tuple[np.ndarray, np.ndarray]:
        """(size_A (n, 3), size_B (n, 3)) full extents [m]."""
        table = np.array([container_type(t).size for t in self.types])
        return table[self.type_a], table[self.type_b]


def _known_type(code: str) -> bool:
    """An ISO type of the catalogue or a generic box's code ("box:<l>,<w>,<h>")."""
    try:
        container_type(code)
    except TestbedError:
        return False
    return True


def _axis_aligned_rotations() -> np.ndarray:
    """(24, 3, 3) proper rotations that permute and flip the coordinate axes."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((-1.0, 1.0), repeat=3):
            M = np.zeros((3, 3))
            M[range(3), perm] = signs
            if np.linalg.det(M) > 0:
                out.append(M)
    return np.array(out)


def _footprint_overlap(x, y, yaw, half_a, half_b) -> np.ndarray:
    """(n,) smallest 2-D separating-axis overlap [m] of A's and B's footprints
    (rectangles of half extents half_a, half_b (n, 2)) with B at (x, y, yaw)."""
    c, s = np.cos(yaw), np.sin(yaw)
    ax = np.stack([np.ones_like(c), np.zeros_like(c)], 1)
    ay = np.stack([np.zeros_like(c), np.ones_like(c)], 1)
    bx, by = np.stack([c, s], 1), np.stack([-s, c], 1)
    p = np.stack([x, y], 1)
    overlaps = []
    for axis in (ax, ay, bx, by):
        ra = np.abs(axis[:, 0]) * half_a[:, 0] + np.abs(axis[:, 1]) * half_a[:, 1]
        rb = half_b[:, 0] * np.abs(np.sum(axis * bx, 1)) + half_b[:, 1] * np.abs(np.sum(axis * by, 1))
        overlaps.append(ra + rb - np.abs(np.sum(axis * p, 1)))
    return np.min(overlaps, axis=0)


def sample(distribution: str, n: int, seed: int, types=DEFAULT_TYPES, *, max_depth: float | None = None,
           max_tilt_deg: float | None = None) -> Proposals:
    """n seeded proposals of `distribution` (DISTRIBUTIONS) for
    ordered type pairs drawn uniformly from `types` x `types`.

    max_depth [m] (default MAX_DEPTH) and max_tilt_deg (stacking roll and pitch bound,
    default 5 deg) widen the ranges for held-out poses outside the training distribution
    (learned_contact/evaluation/gates.py); the defaults are the training ranges and draw exactly the
    same random stream. "resting" has fixed ranges (module docstring) and refuses both."""
    if distribution in FIXED_RANGES and (max_depth is not None or max_tilt_deg is not None):
        raise DatasetError(f"the {distribution!r} distribution has fixed ranges; max_depth and max_tilt_deg are "
                           "not accepted")
    max_depth = MAX_DEPTH if max_depth is None else max_depth
    max_tilt_deg = 5.0 if max_tilt_deg is None else max_tilt_deg
    if distribution not in DISTRIBUTIONS:
        raise DatasetError(f"unknown distribution {distribution!r}; expected one of: {', '.join(DISTRIBUTIONS)}")
    if n < 1:
        raise DatasetError(f"need n >= 1 samples, got {n}")
    types = tuple(types)
    unknown = [t for t in types if not _known_type(t)]
    if unknown:
        raise DatasetError(f"unknown container types {unknown}; expected some of: {', '.join(CONTAINER_TYPES)}")
    rng = np.random.default_rng([seed, DISTRIBUTIONS.index(distribution)])
    type_a = rng.integers(len(types), size=n)
    type_b = rng.integers(len(types), size=n)
    depth = rng.uniform(0.0, max_depth, size=n)
    size_table = np.array([container_type(t).size for t in types])
    half_a, half_b = 0.5 * size_table[type_a], 0.5 * size_table[type_b]
    if distribution == "stacking":
        rpy = np.empty((n, 3))
        rpy[:, :2] = rng.uniform(-np.radians(max_tilt_deg), np.radians(max_tilt_deg), size=(n, 2))
        rpy[:, 2] = rng.uniform(-np.pi, np.pi, size=n)
        parallel = rng.random(n) < 0.3
        rpy[parallel, :2] = rng.uniform(-np.radians(0.05), np.radians(0.05), size=(parallel.sum(), 2))
        aligned = parallel & (rng.random(n) < 0.5)
        k = rng.integers(-1, 3, size=n)
        yaw_aligned = k * np.pi / 2 + rng.uniform(-np.radians(0.5), np.radians(0.5), size=n)
        rpy[aligned, 2] = yaw_aligned[aligned]
        R_AB = rotation_from_rpy(rpy)
        xy = np.zeros((n, 2))
        centred = rng.random(n) < 0.2
        xy[centred] = rng.uniform(-0.1, 0.1, size=(centred.sum(), 2))
        todo = np.flatnonzero(~centred)
        while len(todo):  # rejection sampling of overlapping footprints
            reach = half_a[todo, :2] + np.max(half_b[todo, :2], axis=1, keepdims=True)
            trial = rng.uniform(-reach, reach)
            ok = _footprint_overlap(trial[:, 0], trial[:, 1], rpy[todo, 2], half_a[todo, :2], half_b[todo, :2]) >= 0.1
            xy[todo[ok]] = trial[ok]
            todo = todo[~ok]
        base = np.concatenate([xy, np.zeros((n, 1))], axis=1)
        direction = np.tile([0.0, 0.0, 1.0], (n, 1))
    elif distribution in RESTING_RANGES:
        depths, tilt, yaw, offset = RESTING_RANGES[distribution]
        depth = np.exp(rng.uniform(*np.log(depths), size=n))
        rpy = np.empty((n, 3))
        if tilt is None:  # "resting_level": tilt log-uniform, in a uniform direction
            angle = np.exp(rng.uniform(*np.log(RESTING_LEVEL_TILT), size=n))
            heading = rng.uniform(0.0, 2.0 * np.pi, size=n)
            rpy[:, 0], rpy[:, 1] = angle * np.cos(heading), angle * np.sin(heading)
        else:
            rpy[:, :2] = rng.uniform(-np.radians(tilt), np.radians(tilt), size=(n, 2))
        rpy[:, 2] = rng.uniform(-np.radians(yaw), np.radians(yaw), size=n)
        R_AB = rotation_from_rpy(rpy)
        xy = rng.uniform(-offset, offset, size=(n, 2))
        base = np.concatenate([xy, np.zeros((n, 1))], axis=1)
        direction = np.tile([0.0, 0.0, 1.0], (n, 1))
    elif distribution == "resting_wider":
        w = RESTING_WIDER
        depth = np.exp(rng.uniform(*np.log(w["depth"]), size=n))
        rpy = np.zeros((n, 3))
        tilted = rng.random(n) >= w["level_fraction"]
        rpy[tilted, :2] = rng.uniform(-np.radians(w["tilt_deg"]), np.radians(w["tilt_deg"]), size=(tilted.sum(), 2))
        rpy[:, 2] = rng.uniform(-np.radians(w["yaw_deg"]), np.radians(w["yaw_deg"]), size=n)
        R_AB = rotation_from_rpy(rpy)
        xy = rng.uniform(-np.array(w["offset"]), np.array(w["offset"]), size=(n, 2))
        base = np.concatenate([xy, np.zeros((n, 1))], axis=1)
        direction = np.tile([0.0, 0.0, 1.0], (n, 1))
    elif distribution == "resting_support":
        w = RESTING_SUPPORT
        depth = np.exp(rng.uniform(*np.log(w["depth"]), size=n))
        rpy = np.empty((n, 3))
        rpy[:, :2] = rng.uniform(-np.radians(w["tilt_deg"]), np.radians(w["tilt_deg"]), size=(n, 2))
        near_level = rng.random(n) < w["level_fraction"]
        angle = np.exp(rng.uniform(*np.log(w["level_tilt"]), size=n))
        heading = rng.uniform(0.0, 2.0 * np.pi, size=n)
        rpy[near_level, 0] = (angle * np.cos(heading))[near_level]
        rpy[near_level, 1] = (angle * np.sin(heading))[near_level]
        rpy[:, 2] = rng.uniform(-np.radians(w["yaw_deg"]), np.radians(w["yaw_deg"]), size=n)
        R_AB = rotation_from_rpy(rpy)
        edge = np.maximum(half_a[:, :2], half_b[:, :2])  # (n, 2) [m] the edge of support along A's x and y
        u = rng.uniform(-np.array(w["support"]), np.array(w["support"]), size=(n, 2))
        base = np.concatenate([u * edge, np.zeros((n, 1))], axis=1)
        direction = np.tile([0.0, 0.0, 1.0], (n, 1))
    else:
        R_AB = random_rotations(rng, n)
        snap = rng.random(n) < 0.15
        aligned = _axis_aligned_rotations()[rng.integers(24, size=n)]
        jitter = rotation_from_rpy(rng.uniform(-np.radians(1.0), np.radians(1.0), size=(n, 3)))
        R_AB[snap] = (aligned @ jitter)[snap]
        direction = rng.normal(size=(n, 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        base = np.zeros((n, 3))
    return Proposals(types, type_a, type_b, R_AB, base, direction, depth)


def types_of_sizes(sizes, types=DEFAULT_TYPES, tolerance: float | None = None) -> tuple[str, ...]:
    """The container types of `types` whose full extents are among `sizes` ((k, 3) or (3,) [m],
    e.g. a predictor's supported_sizes), each axis within `tolerance` [m] (default
    learned_contact.interface.SIZE_TOLERANCE), in the order of `types`. Passed as `sample`'s
    (and labels.make_dataset's) `types`, the ordered pairs are drawn uniformly from these types
    alone: poses a model declaring only these sizes answers, as many as for every type."""
    tol = SIZE_TOLERANCE if tolerance is None else float(tolerance)
    given = np.asarray(sizes, dtype=float).reshape(-1, 3)
    return tuple(t for t in types
                 if len(given) and np.abs(given - np.asarray(CONTAINER_TYPES[t].size)).max(axis=1).min() <= tol)
