"""The query study's pose sets: B's pose in A's frame, labelled with Drake's answer.

Pose sets (A at the origin; container types 1CC, 1AA, 1AAA)
- "stacking", "general": learned_contact.data.sampling's distributions, labelled by
  learned_contact.data.labels.make_dataset (sampling seed 10 * seed + 7, disjoint from the
  training seeds 10 * seed + 1 and + 2);
- "near_parallel": the paper's worst case (its Figure 4): B of the same type stacked
  on A, yaw a multiple of pi, centred within +-0.1 m, tilted about a random horizontal
  axis by angles log-spaced from 1e-5 to 1e-1 rad, penetration 0.1 to 5 mm.
The reference answer of every pose is Drake's static hydroelastic centre of pressure
and pressure-weighted normal (compliant-compliant, E as shipped: 1e9 Pa; the point and
normal do not change when both moduli scale together; learned_contact/data/labels.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from learned_contact.data import cache
from learned_contact.data.labels import LABEL_FIELDS, LABEL_VERSION, Dataset, label_proposals, make_dataset
from learned_contact.data.sampling import Proposals
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.drake_support import drake_version
from testbed.geometry.rotations import rotation_from_rpy

POSE_SETS = ("stacking", "general", "near_parallel")
TYPES = ("1CC", "1AA", "1AAA")
TILT_RANGE = (1e-5, 1e-1)  # [rad] near-parallel set
NEAR_DEPTH = (1e-4, 5e-3)  # [m] near-parallel penetration
STUDY_SEED_OFFSET = 7  # sampling seed = 10 * seed + 7
NEAR_VERSION = 1  # bump when the near-parallel set changes meaning


@dataclasses.dataclass(frozen=True)
class PoseSet:
    """Labelled poses of one set. Arrays in A's frame.

    p_AB (n, 3) [m]; R_AB (n, 3, 3); size_A, size_B (n, 3) full extents [m];
    type_a, type_b (n,) ISO codes; cop (n, 3) [m] and normal (n, 3) unit A->B: the
    reference; depth (n,) [m]; tilt (n,) [rad] (near_parallel only, else NaN).
    """

    name: str
    p_AB: np.ndarray
    R_AB: np.ndarray
    size_A: np.ndarray
    size_B: np.ndarray
    type_a: np.ndarray
    type_b: np.ndarray
    cop: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    tilt: np.ndarray
    n_dropped: int = 0

    def __len__(self) -> int:
        return len(self.depth)

def _type_codes(sizes) -> np.ndarray:
    table = {tuple(np.round(t.size, 6)): code for code, t in CONTAINER_TYPES.items()}
    return np.array([table[tuple(np.round(s, 6))] for s in sizes])


def _from_dataset(name: str, ds, tilt=None) -> PoseSet:
    n = len(ds)
    return PoseSet(name, ds.p_AB, ds.R_AB, ds.size_A, ds.size_B, _type_codes(ds.size_A), _type_codes(ds.size_B),
                   ds.cop, ds.normal, ds.depth, np.full(n, np.nan) if tilt is None else tilt, ds.n_dropped)


def near_parallel_proposals(n: int, seed: int):
    """n proposals (learned_contact.data.sampling.Proposals) of the near-parallel worst case
    and their tilts (n,) [rad] (see the module docstring)."""
    rng = np.random.default_rng([seed, 99])
    kind = rng.integers(len(TYPES), size=n)
    tilt = np.geomspace(*TILT_RANGE, n) if n > 1 else np.array([TILT_RANGE[0]])
    axis = rng.uniform(-np.pi, np.pi, size=n)  # tilt axis azimuth in A's xy plane
    yaw = np.pi * rng.integers(2, size=n)
    R_tilt = rotation_from_rpy(np.stack([tilt * np.cos(axis), tilt * np.sin(axis), np.zeros(n)], 1))
    R_yaw = rotation_from_rpy(np.stack([np.zeros(n), np.zeros(n), yaw], 1))
    base = np.concatenate([rng.uniform(-0.1, 0.1, size=(n, 2)), np.zeros((n, 1))], 1)
    props = Proposals(TYPES, kind, kind.copy(), R_tilt @ R_yaw, base, np.tile([0.0, 0.0, 1.0], (n, 1)),
                      rng.uniform(*NEAR_DEPTH, size=n))
    return props, tilt


def make_pose_sets(n_poses: int, seed: int, *, progress: bool = True, use_cache: bool = True) -> dict:
    """{name: PoseSet} for POSE_SETS, n_poses proposals each (poses without a contact
    surface are dropped and counted). Labels are cached (learned_contact.data.cache)."""
    s = 10 * seed + STUDY_SEED_OFFSET
    out = {}
    for dist in ("stacking", "general"):
        ds = make_dataset(dist, n_poses, s, types=TYPES, workers=1, progress=progress, use_cache=use_cache)
        out[dist] = _from_dataset(dist, ds)
    props, tilt = near_parallel_proposals(n_poses, s)
    key = cache.key("study-near-parallel", n_poses, s, TYPES, LABEL_VERSION, NEAR_VERSION, drake_version())  # Drake's labels
    rows = cache.load(key) if use_cache else None
    if rows is None:
        rows = label_proposals(props, workers=1, progress=progress)
        if use_cache:
            cache.save(key, rows)
    ok = np.isfinite(rows[:, 4]) & np.isfinite(rows[:, 7])
    size_A, size_B = props.sizes()
    get = lambda f: rows[:, LABEL_FIELDS[f]]  # noqa: E731
    ds = Dataset("near_parallel", get("p_AB"), props.R_AB, size_A, size_B, get("cop"), get("normal"),
                 get("depth")[:, 0], get("area")[:, 0], np.zeros(len(rows), int), get("pp_point"),
                 get("pp_normal"), get("pp_depth")[:, 0], get("cop_one_point"), 0)
    ds = dataclasses.replace(ds.subset(ok), n_dropped=int((~ok).sum()))
    out["near_parallel"] = _from_dataset("near_parallel", ds, tilt[ok])
    return out


def pooled(sets: dict, n: int) -> PoseSet:
    """One PoseSet of n poses: the poses of every non-empty set, concatenated and repeated."""
    parts = [v for v in sets.values() if len(v)]
    idx = np.resize(np.arange(sum(len(v) for v in parts)), n)
    cat = lambda f: np.concatenate([getattr(v, f) for v in parts])[idx]  # noqa: E731
    return PoseSet("pooled", cat("p_AB"), cat("R_AB"), cat("size_A"), cat("size_B"), cat("type_a"), cat("type_b"),
                   cat("cop"), cat("normal"), cat("depth"), cat("tilt"))
