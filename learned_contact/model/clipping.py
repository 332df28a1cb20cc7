"""Convex polygons clipped by half-spaces normal . x <= limit (Sutherland-Hodgman), in numpy.

Used by learned_contact.model.prior (an incident box face clipped to a reference face's
slab) and learned_contact.model.quadrature (Drake's face triangles clipped against each
other). A batch of N polygons is poly (N, V, 3) [m], any one frame for all of them, with
count (N,) valid leading vertices; V is the fixed vertex budget, and the rows past count
are zeros.
"""

from __future__ import annotations

import numpy as np


def clip_halfspace(poly, count, normal, limit):
    """Clips convex polygons poly (N, V, 3) [m] with count (N,) vertices to the half-space
    normal . x <= limit (normal (N, 3) of any length, limit (N,) [m x |normal|]), all N
    at once. Vertices past the budget V overwrite the last slot. Returns (poly (N, V, 3),
    count (N,))."""
    N, V, _ = poly.shape
    idx = np.arange(V)[None, :]
    valid = idx < count[:, None]
    nxt = np.where(idx + 1 < count[:, None], idx + 1, 0)
    rows = np.arange(N)[:, None]
    s = np.einsum("nvj,nj->nv", poly, normal) - limit[:, None]
    s_next = s[rows, nxt]
    v_next = poly[rows, nxt]
    inside, inside_next = s <= 0.0, s_next <= 0.0
    denom = np.where(s - s_next == 0.0, 1.0, s - s_next)
    cross = poly + (s / denom)[:, :, None] * (v_next - poly)
    cand = np.stack([poly, cross], axis=2).reshape(N, 2 * V, 3)
    keep = np.stack([valid & inside, valid & (inside != inside_next)], axis=2).reshape(N, 2 * V)
    pos = np.minimum(np.cumsum(keep, axis=1) - 1, V - 1)
    out = np.zeros_like(poly)
    r, c = np.nonzero(keep)
    out[r, pos[r, c]] = cand[r, c]
    return out, np.minimum(keep.sum(axis=1), V)


def clip_halfspaces_scalar(poly, count, planes):
    """clip_halfspace applied for each plane in turn, one polygon at a time in plain Python
    (faster than the batched form for a few polygons). poly (N, V, 3) [m] with count (N,)
    vertices; planes: [(normal (N, 3), limit (N,))]. Within the budget V the result is
    clip_halfspace's; past it, the first V vertices are kept. Returns (poly (N, V, 3),
    count (N,))."""
    N, V, _ = poly.shape
    out = np.zeros_like(poly)
    counts = np.zeros(N, dtype=int)
    for r in range(N):
        verts = [tuple(v) for v in poly[r, : count[r]].tolist()]
        for normal, limit in planes:
            n0, n1, n2 = normal[r].tolist()
            c = float(limit[r])
            s = [n0 * v[0] + n1 * v[1] + n2 * v[2] - c for v in verts]
            new = []
            m = len(verts)
            for i in range(m):
                j = i + 1 if i + 1 < m else 0
                si, sj = s[i], s[j]
                if si <= 0.0:
                    new.append(verts[i])
                if (si <= 0.0) != (sj <= 0.0):
                    d = si - sj
                    t = si / d if d != 0.0 else si
                    vi, vj = verts[i], verts[j]
                    new.append((vi[0] + t * (vj[0] - vi[0]), vi[1] + t * (vj[1] - vi[1]), vi[2] + t * (vj[2] - vi[2])))
            verts = new[:V]
        counts[r] = len(verts)
        if verts:
            out[r, : len(verts)] = verts
    return out, counts
