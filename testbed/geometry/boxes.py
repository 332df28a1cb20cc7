"""Exact, fixed-cost box geometry in numpy: separating axes, box-box and box-slab
signed distances, batched over pairs. Nothing here imports Drake.

Why this module exists: Drake's generic `ComputeSignedDistancePairwiseClosestPoints`
(FCL's GJK/EPA, libccd) hangs or raises between a container and the 400 m quay slab
once the container has slid off the slab's centre (DESIGN.md section 3). Every
collision shape of the testbed is a box, and box-box and box-slab distances have
closed forms whose cost is a fixed number of floating-point operations.

Frames: A is the first box's frame (origin at its centre, axes along its edges), B
likewise; a pose of B in A is p_AB (n, 3) [m] and R_AB (n, 3, 3). Half extents h_A,
h_B are (n, 3) or (3,) [m]. Signed distances are [m], negative = penetration.

Exactness:
- box vs slab (`box_slab_signed_distance`): the slab S is a box whose top face (+z
  of S) faces the other box. While B's corners lie over the top face's footprint the
  distance is exact: separated, the closest slab point is straight below B's lowest
  corner; penetrating by d, the lowest corner lies inside the slab with margin >= d
  on every side (the `valid` test), so no translation shorter than d separates them.
- box vs box (`box_box_signed_distance`): overlapping boxes get the exact penetration
  depth (the 15 SAT axes are all face normals of the Minkowski difference, so the
  minimum overlap over them is the minimum translation that separates). Separated
  boxes get the largest gap over the 15 axes, a LOWER BOUND on the distance (exact
  when the closest features are face-face, face-edge, face-vertex or edge-edge; below
  the truth for vertex-edge and vertex-vertex closest pairs). For a near-distance
  threshold this is safe: a pair is never missed, at worst a pair slightly farther
  than the threshold is reported with a distance that is still positive.

Bounded time: every function here does a fixed number of floating-point operations per
pair (8 corners, 15 axes; no iteration to a tolerance, unlike GJK/EPA), so a call costs
the same on any pose. `QueryBoxes.near` (testbed.contact.extraction.near_distances) runs
the compiled twin of `pairwise_signed_distances` (native/geometry/pairwise.c).
"""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np

try:  # native/geometry/pairwise.c, built at install; None where the install had no C compiler
    _PAIRWISE: Any = importlib.import_module("testbed.geometry._pairwise")
except ImportError:  # pragma: no cover (the vectorised numpy reference answers instead)
    _PAIRWISE = None

# (8, 3) corner signs of a box, in a fixed order.
CORNER_SIGNS = np.array(
    [[sx, sy, sz] for sx in (-1.0, 1.0) for sy in (-1.0, 1.0) for sz in (-1.0, 1.0)]
)


def corners_of_B_in_A(p_AB, R_AB, h_B) -> np.ndarray:
    """(n, 8, 3) B's corners in A's frame [m]."""
    local = CORNER_SIGNS[None] * np.asarray(h_B).reshape(-1, 1, 3)  # (n|1, 8, 3)
    return p_AB[:, None, :] + np.einsum("nij,nkj->nki", R_AB, local)


def sat_axes(R_AB) -> np.ndarray:
    """(n, 15, 3) candidate separating axes in A's frame: A's 3 face normals, B's 3,
    and the 9 edge cross products (unit length; near-parallel edge pairs give a zero
    vector, which sat_overlap treats as uninformative)."""
    n = len(R_AB)
    b = np.swapaxes(R_AB, 1, 2)  # rows: B's axes in A
    bx, by, bz = b[:, :, 0], b[:, :, 1], b[:, :, 2]  # (n, 3) components of B's 3 axes
    zero = np.zeros_like(bx)
    cross = np.empty((n, 3, 3, 3))  # [n, A axis i, B axis j, xyz] = e_i x b_j
    cross[:, 0] = np.stack([zero, -bz, by], axis=-1)
    cross[:, 1] = np.stack([bz, zero, -bx], axis=-1)
    cross[:, 2] = np.stack([-by, bx, zero], axis=-1)
    flat = cross.reshape(n, 9, 3)  # (n, 9, 3) the 9 edge-edge axes
    norm = np.sqrt(np.einsum("nkj,nkj->nk", flat, flat))[:, :, None]
    flat = np.where(norm > 1e-6, flat / np.maximum(norm, 1e-12), 0.0)
    return np.concatenate([np.broadcast_to(np.eye(3), (n, 3, 3)), b, flat], axis=1)


def sat_overlap(p_AB, R_AB, h_A, h_B):
    """Separating-axis test of two boxes.

    Returns (overlap (n, 15) [m] along each axis of sat_axes, positive = overlapping;
    axes (n, 15, 3)). Degenerate (zero) axes get +inf overlap.
    """
    axes = sat_axes(R_AB)
    h_A = np.broadcast_to(np.asarray(h_A, dtype=float), p_AB.shape)
    h_B = np.broadcast_to(np.asarray(h_B, dtype=float), p_AB.shape)
    rA = (np.abs(axes) @ h_A[:, :, None])[:, :, 0]  # (n, 15)
    axes_in_B = axes @ R_AB  # axes expressed in B
    rB = (np.abs(axes_in_B) @ h_B[:, :, None])[:, :, 0]
    dist = np.abs((axes @ p_AB[:, :, None])[:, :, 0])
    overlap = rA + rB - dist
    degenerate = (axes * axes).sum(axis=2) < 0.25
    return np.where(degenerate, np.inf, overlap), axes


def sat_normal(p_AB, R_AB, h_A, h_B, precomputed=None):
    """Minimum-overlap axis (the geometric contact normal, A towards B) and its overlap.

    Returns (normal (n, 3) unit in A, depth (n,) [m], axis index (n,) in 0..14).
    Face axes are preferred over edge axes within 1 mm to avoid flicker on faces.
    """
    overlap, axes = precomputed if precomputed is not None else sat_overlap(p_AB, R_AB, h_A, h_B)
    bias = np.zeros(15)
    bias[6:] = 1e-3
    k = np.argmin(overlap + bias, axis=1)
    idx = np.arange(len(k))
    normal = axes[idx, k]
    sign = np.sign(np.einsum("nj,nj->n", normal, p_AB))
    normal = normal * np.where(sign == 0, 1.0, sign)[:, None]
    return normal, overlap[idx, k], k


def box_box_signed_distance(p_AB, R_AB, h_A, h_B) -> np.ndarray:
    """(n,) signed distance [m] between boxes A and B by the separating-axis test.

    Overlapping (every axis overlaps): minus the exact penetration depth, the smallest
    overlap over the 15 axes. Separated: the largest gap over the axes, a lower bound
    on the true distance (see the module docstring for when it is exact).
    """
    p_AB = np.asarray(p_AB, dtype=float).reshape(-1, 3)
    R_AB = np.asarray(R_AB, dtype=float).reshape(-1, 3, 3)
    overlap, _ = sat_overlap(p_AB, R_AB, h_A, h_B)  # degenerate axes: +inf
    least = overlap.min(axis=1)
    return -least  # separated: -min(overlap) = max(gap) > 0; overlapping: -depth


def box_slab_signed_distance(p_SB, R_SB, h_B, h_S):
    """Signed distance [m] of box B from the top face (+z of S) of slab box S.

    p_SB (n, 3) [m] and R_SB (n, 3, 3): B's pose in the slab's frame; h_B, h_S half
    extents (n, 3) or (3,) [m]. Returns (distance (n,) [m]: the lowest corner's height
    over the top face, negative = penetration; valid (n,) bool: True where that is the
    exact signed distance, i.e. every corner lies over the footprint with a margin of at
    least the penetration depth, and the depth is below the slab's half thickness).
    """
    p_SB = np.asarray(p_SB, dtype=float).reshape(-1, 3)
    R_SB = np.asarray(R_SB, dtype=float).reshape(-1, 3, 3)
    h_S = np.broadcast_to(np.asarray(h_S, dtype=float), p_SB.shape)
    corners = corners_of_B_in_A(p_SB, R_SB, h_B)  # (n, 8, 3) in S
    distance = corners[:, :, 2].min(axis=1) - h_S[:, 2]
    depth = np.maximum(-distance, 0.0)
    margin = (h_S[:, None, :2] - np.abs(corners[:, :, :2])).min(axis=(1, 2))  # (n,) [m]
    valid = (margin >= depth) & (depth < h_S[:, 2])
    return distance, valid


def pose_of_B_in_A(p_WA, R_WA, p_WB, R_WB):
    """(p_AB (n, 3) [m], R_AB (n, 3, 3)) from world poses (n, 3), (n, 3, 3)."""
    R_AW = np.swapaxes(R_WA, 1, 2)
    p_AB = np.einsum("nij,nj->ni", R_AW, p_WB - p_WA)
    return p_AB, R_AW @ R_WB


def pairwise_signed_distances(p_W, R_W, h, pairs, slab, max_distance):
    """Signed distances [m] of box pairs, choosing the exact slab form where it applies.

    p_W (m, 3) [m], R_W (m, 3, 3): world poses of m boxes; h (m, 3) half extents [m];
    pairs (k, 2) int indices; slab (m,) bool: boxes to treat as a slab (their top face,
    +z of their frame, faces the others; the quay); max_distance [m].
    Returns (k,) distances; pairs whose bounding spheres are farther apart than
    max_distance get +inf without further work.
    """
    pairs = np.asarray(pairs, dtype=int).reshape(-1, 2)
    out = np.full(len(pairs), np.inf)
    if not len(pairs):
        return out
    radius = np.linalg.norm(h, axis=1)  # (m,) bounding-sphere radii [m]
    i, j = pairs[:, 0], pairs[:, 1]
    gap = np.linalg.norm(p_W[j] - p_W[i], axis=1) - radius[i] - radius[j]
    near = gap <= max_distance
    # slab pairs: slab first (A = S), the other box second
    swap = slab[j] & ~slab[i]
    s = np.where(swap, j, i)
    o = np.where(swap, i, j)
    use_slab = near & (slab[i] ^ slab[j])
    if use_slab.any():
        p_SB, R_SB = pose_of_B_in_A(p_W[s[use_slab]], R_W[s[use_slab]], p_W[o[use_slab]], R_W[o[use_slab]])
        d, valid = box_slab_signed_distance(p_SB, R_SB, h[o[use_slab]], h[s[use_slab]])
        idx = np.flatnonzero(use_slab)
        out[idx[valid]] = d[valid]
        use_slab[idx[~valid]] = False  # off the footprint or deep: the general test below
    general = near & ~use_slab
    if general.any():
        p_AB, R_AB = pose_of_B_in_A(p_W[i[general]], R_W[i[general]], p_W[j[general]], R_W[j[general]])
        out[general] = box_box_signed_distance(p_AB, R_AB, h[i[general]], h[j[general]])
    return out


def pairwise_signed_distances_fast(p_W, R_W, h, pairs, slab, max_distance) -> np.ndarray:
    """pairwise_signed_distances in compiled C (native/geometry/pairwise.c: a fixed number of
    floating-point operations per pair, no Python per pair), with an axis-aligned-box prune
    instead of the bounding spheres: a pair whose world AABBs are more than max_distance apart
    on some axis gets +inf (the gap along a world axis bounds the distance below). Distances up
    to max_distance equal the reference's. Without the native module: the reference itself."""
    pairs = np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2)
    if _PAIRWISE is None:
        return pairwise_signed_distances(np.asarray(p_W, dtype=float), np.asarray(R_W, dtype=float),
                                         np.asarray(h, dtype=float), pairs, np.asarray(slab, dtype=bool), max_distance)
    out = np.empty(len(pairs))
    _PAIRWISE.signed_distances(np.ascontiguousarray(p_W, dtype=float), np.ascontiguousarray(R_W, dtype=float),
                               np.ascontiguousarray(h, dtype=float), pairs,
                               np.ascontiguousarray(slab, dtype=np.uint8), float(max_distance), out)
    return out


SLAB_ASPECT = 10.0  # a box whose footprint half extents are both >= 10x its half height is a slab


class QueryBoxes:
    """The proximity boxes of a Drake scene and their candidate pairs, read once from
    a QueryObject (duck-typed, so this module does not import Drake).

    Candidate pairs are those Drake's proximity queries would consider: pairs not
    collision-filtered (the filter also removes anchored-anchored pairs and bodies
    welded together). A non-box proximity shape has no closed form here: its pairs are
    left out (`skipped` names them), never sent to the generic query.
    """

    def __init__(self, query):
        inspector = query.inspector()
        ids, half, skipped = [], [], []
        for gid in inspector.GetAllGeometryIds():
            if inspector.GetProximityProperties(gid) is None:
                continue
            shape = inspector.GetShape(gid)
            if type(shape).__name__ != "Box":
                skipped.append(gid)
                continue
            ids.append(gid)
            half.append(0.5 * np.asarray(shape.size(), dtype=float))
        self.ids = ids
        self.skipped = skipped
        self.half = np.asarray(half, dtype=float).reshape(-1, 3)  # (m, 3) [m]
        self.slab = np.minimum(self.half[:, 0], self.half[:, 1]) >= SLAB_ASPECT * self.half[:, 2]  # (m,) bool
        self.pairs = np.array(
            [(a, b) for a in range(len(ids)) for b in range(a + 1, len(ids))
             if not inspector.CollisionFiltered(ids[a], ids[b])], dtype=int,
        ).reshape(-1, 2)
        self._keys = [frozenset((ids[a], ids[b])) for a, b in self.pairs.tolist()]

    def poses(self, query) -> tuple[np.ndarray, np.ndarray]:
        """World poses of the boxes: p_WG (m, 3) [m], R_WG (m, 3, 3)."""
        X = np.array([query.GetPoseInWorld(gid).GetAsMatrix34() for gid in self.ids]).reshape(-1, 3, 4)
        return X[:, :, 3], X[:, :, :3]

    def near(self, query, max_distance: float) -> dict:
        """{frozenset(GeometryId, GeometryId): signed distance [m]} for candidate pairs
        whose signed distance (exact, or a lower bound for separated box-box pairs) is
        at most max_distance [m]."""
        if not len(self.pairs):
            return {}
        return self.near_at(*self.poses(query), max_distance)

    def near_at(self, p_WG, R_WG, max_distance: float) -> dict:
        """`near` with the boxes' world poses given: p_WG (m, 3) [m], R_WG (m, 3, 3), in
        the order of `ids` (a caller that already holds its bodies' poses saves the m
        GetPoseInWorld calls, ~5 us each)."""
        if not len(self.pairs):
            return {}
        d = pairwise_signed_distances_fast(p_WG, R_WG, self.half, self.pairs, self.slab, max_distance)
        keys = self._keys
        return {keys[k]: float(d[k]) for k in np.flatnonzero(d <= max_distance)}
