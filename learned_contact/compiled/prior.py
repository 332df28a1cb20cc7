"""Compiled box geometry, one pose at a time: the numba twin of learned_contact.model.prior
(sat_overlap, sat_normal, patch_estimate) and encodings (canonicalise, features).

Every function works on one pose with caller-provided scratch arrays, so a batched
kernel allocates once per call, not once per pose. Frames and units as in
learned_contact.model.prior: p (3,) [m] is B's centre in A, R (3, 3) B's axes in A
(columns), hA, hB (3,) half extents [m]. The operation order follows the numpy
reference so that both agree to rounding (tests/learned/test_learned_compiled.py: 1e-9).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

MAX_VERTS = 9  # a quad clipped by 5 half-planes has at most 9 vertices (geometry._MAX_VERTS)
EDGE_BIAS = 1e-3  # [m] face axes preferred over edge axes within this (geometry.sat_normal)
LENGTH_SCALE = 1.0 / 6.0  # [1/m] encodings.LENGTH_SCALE
N_FEATURES = 91


@njit(cache=True)
def sat_overlap(p, R, hA, hB, axes, overlap):
    """Fills axes (15, 3) (A's faces, B's faces, the 9 edge crosses; zero when
    degenerate) and overlap (15,) [m] (positive = overlapping, +inf for zero axes)."""
    for k in range(15):
        for c in range(3):
            axes[k, c] = 0.0
    for i in range(3):
        axes[i, i] = 1.0
        for c in range(3):
            axes[3 + i, c] = R[c, i]
    for i in range(3):
        for j in range(3):
            bx, by, bz = R[0, j], R[1, j], R[2, j]
            if i == 0:
                cx, cy, cz = 0.0, -bz, by
            elif i == 1:
                cx, cy, cz = bz, 0.0, -bx
            else:
                cx, cy, cz = -by, bx, 0.0
            norm = math.sqrt(cx * cx + cy * cy + cz * cz)
            k = 6 + 3 * i + j
            if norm > 1e-6:
                d = max(norm, 1e-12)
                axes[k, 0], axes[k, 1], axes[k, 2] = cx / d, cy / d, cz / d
    for k in range(15):
        a0, a1, a2 = axes[k, 0], axes[k, 1], axes[k, 2]
        if a0 * a0 + a1 * a1 + a2 * a2 < 0.25:
            overlap[k] = np.inf
            continue
        rA = abs(a0) * hA[0] + abs(a1) * hA[1] + abs(a2) * hA[2]
        rB = 0.0
        for j in range(3):
            rB += abs(a0 * R[0, j] + a1 * R[1, j] + a2 * R[2, j]) * hB[j]
        overlap[k] = rA + rB - abs(a0 * p[0] + a1 * p[1] + a2 * p[2])


@njit(cache=True)
def sat_normal(p, axes, overlap, normal):
    """Fills normal (3,) (the minimum-overlap axis, A towards B); returns (depth [m], axis index)."""
    best, k = np.inf, 0
    for i in range(15):
        v = overlap[i] + (EDGE_BIAS if i >= 6 else 0.0)
        if v < best:
            best, k = v, i
    dot = axes[k, 0] * p[0] + axes[k, 1] * p[1] + axes[k, 2] * p[2]
    sign = -1.0 if dot < 0.0 else 1.0
    for c in range(3):
        normal[c] = axes[k, c] * sign
    return overlap[k], k


@njit(cache=True)
def sat_depth(p, R, hA, hB, axes, overlap):
    """Separating-axis penetration depth [m] of one pose."""
    sat_overlap(p, R, hA, hB, axes, overlap)
    best, k = np.inf, 0
    for i in range(15):
        v = overlap[i] + (EDGE_BIAS if i >= 6 else 0.0)
        if v < best:
            best, k = v, i
    return overlap[k]


@njit(cache=True)
def _clip(poly, count, ax, sg, lim, out):
    """Sutherland-Hodgman: poly (count valid rows of (MAX_VERTS, 3)) clipped to
    sg * x[ax] <= lim, written to out; returns the new count."""
    n_out = 0
    for i in range(count):
        j = i + 1 if i + 1 < count else 0
        si = sg * poly[i, ax] - lim
        sj = sg * poly[j, ax] - lim
        if si <= 0.0:
            r = min(n_out, MAX_VERTS - 1)
            for c in range(3):
                out[r, c] = poly[i, c]
            n_out += 1
        if (si <= 0.0) != (sj <= 0.0):
            d = si - sj
            t = si / (d if d != 0.0 else 1.0)
            r = min(n_out, MAX_VERTS - 1)
            for c in range(3):
                out[r, c] = poly[i, c] + t * (poly[j, c] - poly[i, c])
            n_out += 1
    return min(n_out, MAX_VERTS)


@njit(cache=True)
def _weighted_centroid(poly, count, depth, centroid):
    """Fan-triangulated integral of the linear weight depth (count,) over the polygon.
    Fills centroid (3,) (the vertex mean where the integral is ~0); returns the integral."""
    total = 0.0
    f0, f1, f2 = 0.0, 0.0, 0.0
    d0 = depth[0]
    for j in range(1, count - 1):
        e1x, e1y, e1z = poly[j, 0] - poly[0, 0], poly[j, 1] - poly[0, 1], poly[j, 2] - poly[0, 2]
        e2x, e2y, e2z = poly[j + 1, 0] - poly[0, 0], poly[j + 1, 1] - poly[0, 1], poly[j + 1, 2] - poly[0, 2]
        cx, cy, cz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
        area = 0.5 * math.sqrt(cx * cx + cy * cy + cz * cz)
        d1, d2 = depth[j], depth[j + 1]
        total += area * (d0 + d1 + d2) / 3.0
        w0, w1, w2 = 2 * d0 + d1 + d2, d0 + 2 * d1 + d2, d0 + d1 + 2 * d2
        a = area / 12.0
        f0 += a * (w0 * poly[0, 0] + w1 * poly[j, 0] + w2 * poly[j + 1, 0])
        f1 += a * (w0 * poly[0, 1] + w1 * poly[j, 1] + w2 * poly[j + 1, 1])
        f2 += a * (w0 * poly[0, 2] + w1 * poly[j, 2] + w2 * poly[j + 1, 2])
    if total > 1e-12:
        centroid[0], centroid[1], centroid[2] = f0 / total, f1 / total, f2 / total
    else:
        m = max(count, 1)
        for c in range(3):
            s = 0.0
            for v in range(count):
                s += poly[v, c]
            centroid[c] = s / m
    return total


@njit(cache=True)
def face_patch(p, R, hA, hB, axis, poly, tmp, depth, point):
    """B's incident face clipped against A's face normal to `axis` (on B's side), its
    depth-weighted centroid moved half the depth towards A's face. Fills point (3,)
    in A [m]; returns the patch volume [m^3] (geometry._face_patch)."""
    sigma = 1.0 if p[axis] >= 0.0 else -1.0
    m, best = 0, abs(R[axis, 0] * sigma)
    for mm in range(1, 3):
        v = abs(R[axis, mm] * sigma)
        if v > best:
            m, best = mm, v
    s_m = -1.0 if R[axis, m] * sigma > 0.0 else 1.0
    u, w = (m + 1) % 3, (m + 2) % 3
    for c in range(3):
        centre = p[c] + (s_m * hB[m]) * R[c, m]
        du, dv = hB[u] * R[c, u], hB[w] * R[c, w]
        poly[0, c] = centre + du + dv
        poly[1, c] = centre - du + dv
        poly[2, c] = centre - du - dv
        poly[3, c] = centre + du - dv
    count = 4
    for k in range(1, 3):
        ax = (axis + k) % 3
        for sg in (1.0, -1.0):
            count = _clip(poly, count, ax, sg, hA[ax], tmp)
            poly, tmp = tmp, poly
    count = _clip(poly, count, axis, sigma, hA[axis], tmp)
    poly, tmp = tmp, poly
    top = hA[axis]
    for v in range(count):
        depth[v] = max(top - sigma * poly[v, axis], 0.0)
    weight = _weighted_centroid(poly, count, depth, point)
    point[axis] = 0.5 * (point[axis] + sigma * top)
    return weight


@njit(cache=True)
def edge_patch(p, R, hA, hB, k, normal, point):
    """Midpoint of the closest points of A's and B's edges along edge axis k (6..14)
    (geometry._edge_patch). Fills point (3,) in A [m]."""
    i, j = (k - 6) // 3, (k - 6) % 3
    cA = np.empty(3)
    cB = np.empty(3)
    for c in range(3):
        cA[c] = (1.0 if normal[c] >= 0.0 else -1.0) * hA[c]
    cA[i] = 0.0
    sB = np.empty(3)
    for jj in range(3):
        nB = normal[0] * R[0, jj] + normal[1] * R[1, jj] + normal[2] * R[2, jj]
        sB[jj] = (-1.0 if nB >= 0.0 else 1.0) * hB[jj]
    sB[j] = 0.0
    for c in range(3):
        cB[c] = p[c] + (R[c, 0] * sB[0] + R[c, 1] * sB[1] + R[c, 2] * sB[2])
    b = R[i, j]
    d = cA[i] - cB[i]
    e = 0.0
    for c in range(3):
        e += R[c, j] * (cA[c] - cB[c])
    den = max(1.0 - b * b, 1e-9)
    s = min(max((b * e - d) / den, -hA[i]), hA[i])
    t = min(max((e - b * d) / den, -hB[j]), hB[j])
    for c in range(3):
        point[c] = 0.5 * (cA[c] + (s if c == i else 0.0) + cB[c] + t * R[c, j])


@njit(cache=True)
def patch_estimate(p, R, hA, hB, work, RT, axes, overlap, poly, tmp, depth, point, normal):
    """geometry.patch_estimate for one pose. Fills point (3,) [m], normal (3,) unit
    A->B, overlap (15,) [m]; returns (depth [m], SAT axis index, patch volume [m^3]).
    work (6,), RT (3, 3) are scratch."""
    sat_overlap(p, R, hA, hB, axes, overlap)
    pen, k = sat_normal(p, axes, overlap, normal)
    face, best = 0, overlap[0]
    for f in range(1, 6):
        if overlap[f] < best:
            face, best = f, overlap[f]
    if face < 3:
        weight = face_patch(p, R, hA, hB, face, poly, tmp, depth, point)
    else:
        p_BA, R_BA, q = work[0:3], RT, work[3:6]
        for a in range(3):
            p_BA[a] = -(R[0, a] * p[0] + R[1, a] * p[1] + R[2, a] * p[2])
            for b in range(3):
                R_BA[a, b] = R[b, a]
        weight = face_patch(p_BA, R_BA, hB, hA, face - 3, poly, tmp, depth, q)
        for c in range(3):
            point[c] = p[c] + (R[c, 0] * q[0] + R[c, 1] * q[1] + R[c, 2] * q[2])
    if weight <= 1e-12 and k >= 6:
        edge_patch(p, R, hA, hB, k, normal, point)
    return pen, k, weight


@njit(cache=True)
def canonicalise(p, R, S, p_c, R_c):
    """Reflects one pose into A's positive octant (encodings.canonicalise): fills
    S (3,) signs, p_c (3,) [m], R_c (3, 3) (columns sign-fixed to a non-negative sum)."""
    for i in range(3):
        S[i] = 1.0 if p[i] >= 0.0 else -1.0
    reflect(p, R, S, p_c, R_c)


@njit(cache=True)
def reflect(p, R, S, p_c, R_c):
    """One pose seen in A's frame reflected by diag(S) (encodings.reflect): fills
    p_c (3,) [m] and R_c (3, 3) (columns sign-fixed to a non-negative sum)."""
    for i in range(3):
        p_c[i] = S[i] * p[i]
    for j in range(3):
        col = 1.0 if S[0] * R[0, j] + S[1] * R[1, j] + S[2] * R[2, j] >= 0.0 else -1.0
        for i in range(3):
            R_c[i, j] = S[i] * R[i, j] * col


@njit(cache=True)
def band_half_weights(p, band, half):
    """Fills half (3,) with w(|p_k|) / 2 (encodings.band_weight: 1 - smoothstep(|p_k| / band))."""
    for k in range(3):
        u = min(max(abs(p[k]) / band, 0.0), 1.0)
        half[k] = 0.5 * (1.0 - u * u * (3.0 - 2.0 * u))
