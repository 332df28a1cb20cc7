"""Cheap, fixed-cost box geometry in numpy, batched over poses.

Frames: A is the first box's body frame (origin at its centre, axes along its edges);
B likewise. A pose of B in A is p_AB (n, 3) [m] and R_AB (n, 3, 3). Half extents
h_A, h_B are (n, 3) or (3,) [m]. Nothing here calls Drake, so it is usable at inference.
"""

from __future__ import annotations

import numpy as np

from learned_contact.model.clipping import clip_halfspace, clip_halfspaces_scalar
from testbed.geometry.boxes import CORNER_SIGNS, corners_of_B_in_A, sat_axes, sat_normal, sat_overlap  # noqa: F401 (moved)


def support_count(vertices, direction, tol) -> np.ndarray:
    """(n,) number of vertices (n, 8, 3) whose projection on direction (n, 3) is within
    tol (n,) [m] of the largest projection: 1 vertex, 2 edge, 4 face."""
    proj = np.einsum("nkj,nj->nk", vertices, direction)
    return np.sum(proj >= proj.max(axis=1, keepdims=True) - tol[:, None], axis=1)


CONTACT_TYPES = ("vertex-face", "edge-face", "edge-edge", "face-face")


def contact_type(p_AB, R_AB, h_A, h_B) -> np.ndarray:
    """(n,) int index into CONTACT_TYPES, from the geometry alone.

    The minimum-overlap axis n is the contact normal; the feature of A is the set of
    its corners within tol of its support plane along n, the feature of B the set within
    tol along -n (1 corner: vertex, 2: edge, 4: face), tol = 2 x depth + 2 mm.
    vertex-face: a vertex of one box on a face of the other; edge-face; edge-edge
    (which also takes the rare vertex-edge and vertex-vertex cases); face-face.
    """
    n_AB, depth, _ = sat_normal(p_AB, R_AB, h_A, h_B)
    tol = 2.0 * np.maximum(depth, 0.0) + 2e-3
    h_A = np.broadcast_to(np.asarray(h_A, dtype=float), p_AB.shape)
    corners_A = CORNER_SIGNS[None] * h_A[:, None, :]
    corners_B = corners_of_B_in_A(p_AB, R_AB, h_B)
    kA = support_count(corners_A, n_AB, tol)
    kB = support_count(corners_B, -n_AB, tol)
    dim = lambda k: np.where(k >= 3, 2, np.where(k == 2, 1, 0))  # noqa: E731
    dA, dB = dim(kA), dim(kB)
    lo, hi = np.minimum(dA, dB), np.maximum(dA, dB)
    out = np.full(len(p_AB), 2)  # edge-edge (and vertex-edge, vertex-vertex)
    out[(hi == 2) & (lo == 0)] = 0
    out[(hi == 2) & (lo == 1)] = 1
    out[(hi == 2) & (lo == 2)] = 3
    return out


# ------------------------------------------------------------ contact patch estimate
_MAX_VERTS = 9  # a quad clipped by 5 half-planes has at most 9 vertices
_SCALAR_MAX = 4  # up to this many pairs, _face_patch clips in plain Python


def _face_patch(p_AB, R_AB, h_A, h_B, axis):
    """Contact patch of B's incident face on A's face normal to `axis` (n,) (the face
    on B's side): the face is clipped to A's face rectangle and to the inside of A,
    and the depth-weighted centroid is moved half the depth towards A's face (where the
    equal-pressure surface lies). Returns (point (n, 3) in A [m], weight (n,) [m^3])."""
    n = len(p_AB)
    rows = np.arange(n)
    sigma = np.where(p_AB[rows, axis] >= 0.0, 1.0, -1.0)
    along = R_AB[rows, axis, :] * sigma[:, None]  # (n, 3) n . b_m
    m = np.argmax(np.abs(along), axis=1)
    s_m = np.where(along[rows, m] > 0.0, -1.0, 1.0)
    u_ax, v_ax = (m + 1) % 3, (m + 2) % 3
    b = np.swapaxes(R_AB, 1, 2)  # rows: B's axes in A
    centre = p_AB + (s_m * h_B[rows, m])[:, None] * b[rows, m]
    du = h_B[rows, u_ax][:, None] * b[rows, u_ax]
    dv = h_B[rows, v_ax][:, None] * b[rows, v_ax]
    poly = np.zeros((n, _MAX_VERTS, 3))
    poly[:, :4] = np.stack([centre + du + dv, centre - du + dv, centre - du - dv, centre + du - dv], axis=1)
    count = np.full(n, 4)
    top = h_A[rows, axis]
    e = np.eye(3)
    planes = [(sg * e[(axis + k) % 3], h_A[rows, (axis + k) % 3]) for k in (1, 2) for sg in (1.0, -1.0)]
    planes.append((sigma[:, None] * e[axis], top))
    if n <= _SCALAR_MAX:  # few pairs: plain Python is faster than many tiny numpy calls
        poly, count = clip_halfspaces_scalar(poly, count, planes)
    else:
        for normal, limit in planes:
            poly, count = clip_halfspace(poly, count, normal, limit)
    depth = top[:, None] - sigma[:, None] * poly[rows[:, None], np.arange(_MAX_VERTS)[None, :], axis[:, None]]
    centroid, weight, _ = _weighted_centroid(poly, count, np.maximum(depth, 0.0))
    centroid[rows, axis] = 0.5 * (centroid[rows, axis] + sigma * top)
    return centroid, weight


def _edge_patch(p_AB, R_AB, h_A, h_B, k, normal):
    """Midpoint of the closest points of A's and B's edges along SAT edge axis k (n,)
    in 6..14, for contact normal (n, 3) A->B. Returns (n, 3) in A [m]."""
    n = len(p_AB)
    rows = np.arange(n)
    i, j = (k - 6) // 3, (k - 6) % 3
    sA = np.where(normal >= 0.0, 1.0, -1.0)
    cA = sA * h_A
    cA[rows, i] = 0.0
    eA = np.zeros((n, 3))
    eA[rows, i] = 1.0
    nB = np.einsum("nj,nji->ni", normal, R_AB)  # normal in B
    sB = np.where(nB >= 0.0, -1.0, 1.0) * h_B
    sB[rows, j] = 0.0
    cB = p_AB + np.einsum("nij,nj->ni", R_AB, sB)
    eB = R_AB[rows, :, j]
    w = cA - cB
    b = np.einsum("ni,ni->n", eA, eB)
    d, e = np.einsum("ni,ni->n", eA, w), np.einsum("ni,ni->n", eB, w)
    den = np.maximum(1.0 - b * b, 1e-9)
    s = np.clip((b * e - d) / den, -h_A[rows, i], h_A[rows, i])
    t = np.clip((e - b * d) / den, -h_B[rows, j], h_B[rows, j])
    return 0.5 * (cA + s[:, None] * eA + cB + t[:, None] * eB)


def patch_estimate(p_AB, R_AB, h_A, h_B):
    """Fixed-cost geometric estimate of the contact answer (the ODE/dBoxBox recipe,
    with a clipped, depth-weighted patch instead of its single deepest point).

    p_AB (n, 3) [m], R_AB (n, 3, 3), h_A, h_B (n, 3) half extents [m].
    The patch comes from the reference face (the face axis, of A or of B, with least
    overlap) clipped against the other box's incident face; this also places
    edge-edge crossings, whose clipped patch is a small region around the crossing.
    Returns (point (n, 3) in A [m], normal (n, 3) unit A->B (the minimum-overlap axis
    of all 15), depth (n,) [m], axis (n,) SAT axis index, weight (n,) [m^3] patch volume,
    overlap (n, 15) [m] the separating-axis overlaps).
    """
    overlap, axes = sat_overlap(p_AB, R_AB, h_A, h_B)
    normal, depth, k = sat_normal(p_AB, R_AB, h_A, h_B, (overlap, axes))
    face = np.argmin(overlap[:, :6], axis=1)  # reference face: least-overlap face axis
    point = np.zeros_like(p_AB)
    weight = np.zeros(len(p_AB))
    on_A, on_B = face < 3, face >= 3
    if on_A.any():
        point[on_A], weight[on_A] = _face_patch(p_AB[on_A], R_AB[on_A], h_A[on_A], h_B[on_A], face[on_A])
    if on_B.any():
        R_BA = np.swapaxes(R_AB[on_B], 1, 2)
        p_BA = -np.einsum("nij,nj->ni", R_BA, p_AB[on_B])
        q, weight[on_B] = _face_patch(p_BA, R_BA, h_B[on_B], h_A[on_B], face[on_B] - 3)
        point[on_B] = p_AB[on_B] + np.einsum("nij,nj->ni", R_AB[on_B], q)
    empty = (weight <= 1e-12) & (k >= 6)  # no clipped patch: an edge-edge crossing
    if empty.any():
        point[empty] = _edge_patch(p_AB[empty], R_AB[empty], h_A[empty], h_B[empty], k[empty], normal[empty])
    return point, normal, depth, k, weight, overlap


def _weighted_centroid(poly, count, depth):
    """Fan-triangulated integral of a linear weight `depth` (n, V) over convex polygons.
    Returns (centroid (n, 3), integral (n,), plain vertex mean (n, 3))."""
    n, V, _ = poly.shape
    v0, d0 = poly[:, :1], depth[:, :1]
    v1, v2 = poly[:, 1:-1], poly[:, 2:]
    d1, d2 = depth[:, 1:-1], depth[:, 2:]
    j = np.arange(1, V - 1)[None, :]
    tri_ok = (j + 1) < count[:, None]
    e1, e2 = v1 - v0, v2 - v0
    c = np.stack([e1[..., 1] * e2[..., 2] - e1[..., 2] * e2[..., 1],
                  e1[..., 2] * e2[..., 0] - e1[..., 0] * e2[..., 2],
                  e1[..., 0] * e2[..., 1] - e1[..., 1] * e2[..., 0]], axis=-1)
    area = 0.5 * np.sqrt(np.einsum("nvj,nvj->nv", c, c)) * tri_ok  # (n, V-2)
    mass = area * (d0 + d1 + d2) / 3.0
    first = area[:, :, None] / 12.0 * (
        (2 * d0 + d1 + d2)[:, :, None] * v0 + (d0 + 2 * d1 + d2)[:, :, None] * v1
        + (d0 + d1 + 2 * d2)[:, :, None] * v2)
    total = mass.sum(axis=1)
    valid = np.arange(V)[None, :] < count[:, None]
    mean = (poly * valid[:, :, None]).sum(axis=1) / np.maximum(count, 1)[:, None]
    centroid = np.where(total[:, None] > 1e-12, first.sum(axis=1) / np.maximum(total, 1e-300)[:, None], mean)
    return centroid, total, mean
