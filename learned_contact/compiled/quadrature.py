"""Drake's face-on-face quadrature for one pose, compiled: the numba twin of
learned_contact.model.quadrature (face_on_face, hand_over); read that module's docstring
for what is computed and why.

Frames and units as there: A's frame; p (3,) [m] is B's centre in A, R (3, 3) B's axes in
A (columns), hA, hB (3,) half extents [m], n (3,) the separating-axis normal (unit, A->B,
in A) that picks the two faces. One pose per call, plain loops over small arrays: the
caller allocates the scratch once per batch (`face_on_face_scratch`) and passes it in, so a call
allocates nothing. The helpers are inlined into face_on_face (numba's inline="always": as
separate functions, the calls that pass a dozen arrays each cost more than the clipping
itself; inlined, the quadrature takes 3.4-3.7 us per pair instead of 4.6-5.3, measured
side by side on 4,096 centred stacks and 2,048 stacking and general poses), and an edge
that misses a triangle leaves its sliver at zero without the rest of the arithmetic.

The operation order follows the numpy reference wherever a comparison depends on it (the
clipping tests, the sliver interval ends), and elsewhere too where it costs nothing: the
numpy path's einsum sums three products as (x0 y0 + x2 y2) + x1 y1 where both operands
are contiguous along the summed axis (its SIMD loop: `_dot_c`; measured bit for bit on
numpy 2.4) and left to right elsewhere (written out inline); its sums along an axis are
pairwise (`_pairwise`). The two paths agree to rounding: on 65,000 random, resting and
tilted poses the outputs differ by at most 9e-16 m (point), 0 (normal, weight) and
2e-16 rad (tilt, np.arccos against math.acos); 98-100 % of the points bit for bit.

Division by zero gives inf or NaN as in the numpy path (error_model="numpy"), not an
exception; the divisions the numpy path guards are guarded the same way.

Caution (numba's cache): a function cached with cache=True is recompiled only when its
own source file changes, not when a function it calls from another file does; after an
edit here, touch learned_contact/compiled/kernels.py (or delete its cache files) so that
improved_predict picks the change up.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

QUAD_VERTS = 9  # a triangle clipped by 6 half-planes keeps at most 9 vertices (quadrature._MAX_VERTS)
# scratch rows (`face_on_face_scratch`): frame (13, 3): A's fan corners cA (0-3), B's fan corners cB (4-7),
# A's face centre (8), B's face centre (9), A's face normal (10), B's face normal towards A
# (11), the equal-pressure normal (12); planes (32, 7): (normal (3), limit, a point (3)) of
# A's triangles' sides (i * 3 + k, 0-11), B's triangles' sides in A's face plane (12 + j * 3 + k),
# the edge clips of B's edges (24 + j) and of A's edges (28 + i); items (48, 7): (weight
# [m^3], centre (3) [m], normal direction (3)) of the 16 polygons (i * 4 + j), then B's and
# A's slivers (16 + i * 4 + j, 32 + i * 4 + j)
_F_CA, _F_CB, _F_TOP, _F_CENTRE_B, _F_NA, _F_NB, _F_MAIN = 0, 4, 8, 9, 10, 11, 12
_P_SIDE_A, _P_SIDE_B, _P_EDGE_B, _P_EDGE_A = 0, 12, 24, 28
_I_POLY, _I_SLIVER_B, _I_SLIVER_A = 0, 16, 32
_FAN_U = (1.0, -1.0, -1.0, 1.0)  # quadrature._FAN: corners (+u +v), (-u +v), (-u -v), (+u -v)
_FAN_V = (1.0, 1.0, -1.0, -1.0)
_SQRT2 = math.sqrt(2.0)


@njit(cache=True)
def face_on_face_scratch():
    """(frame (13, 3), planes (32, 7), items (48, 7), poly (2, QUAD_VERTS, 3)): the work
    arrays of face_on_face, allocated once per batch."""
    return np.empty((13, 3)), np.empty((32, 7)), np.empty((48, 7)), np.empty((2, QUAD_VERTS, 3))


@njit(cache=True, inline="always", error_model="numpy")
def _dot_c(x, y):
    """x . y in the order of numpy's einsum on operands contiguous along the sum."""
    return (x[0] * y[0] + x[2] * y[2]) + x[1] * y[1]


@njit(cache=True, inline="always", error_model="numpy")
def _norm(x):
    """|x| (np.linalg.norm along an axis: the squares summed left to right)."""
    return math.sqrt((x[0] * x[0] + x[1] * x[1]) + x[2] * x[2])


@njit(cache=True, inline="always", error_model="numpy")
def _pairwise(items, col, start, count):
    """sum of items[start:start + count, col] in the order of numpy's pairwise sum
    (ndarray.sum along a contiguous axis, count <= 128)."""
    if count < 8:
        res = -0.0
        for i in range(count):
            res += items[start + i, col]
        return res
    r0, r1, r2, r3 = items[start, col], items[start + 1, col], items[start + 2, col], items[start + 3, col]
    r4, r5, r6, r7 = items[start + 4, col], items[start + 5, col], items[start + 6, col], items[start + 7, col]
    i = 8
    while i < count - count % 8:
        b = start + i
        r0, r1, r2, r3 = r0 + items[b, col], r1 + items[b + 1, col], r2 + items[b + 2, col], r3 + items[b + 3, col]
        r4, r5, r6, r7 = r4 + items[b + 4, col], r5 + items[b + 5, col], r6 + items[b + 6, col], r7 + items[b + 7, col]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < count:
        res += items[start + i, col]
        i += 1
    return res


@njit(cache=True, inline="always", error_model="numpy")
def hand_over(tilt, band0, band1):
    """Weight of the face-on-face answer for a tilt [rad] between the two faces
    (quadrature.hand_over): 1 up to band0, 0 from band1 on [rad], a C1 smoothstep between."""
    u = min(max((tilt - band0) / (band1 - band0), 0.0), 1.0)
    return 1.0 - u * u * (3.0 - 2.0 * u)


@njit(cache=True, inline="always", error_model="numpy")
def _clip(poly, src, count, n0, n1, n2, limit):
    """Sutherland-Hodgman (learned_contact.model.clipping.clip_halfspace for one polygon): the polygon poly[src] (count
    valid rows of (QUAD_VERTS, 3)) clipped to the half-space (n0, n1, n2) . x <= limit,
    written to poly[1 - src]; returns the new count. Vertices beyond the budget overwrite
    the last row, as the numpy path's scatter does. Each vertex's signed distance is
    computed once (carried over to the next side), and rows are indexed, not viewed (a
    view costs a reference count in numba)."""
    dst = 1 - src
    n_out = 0
    s_first = (poly[src, 0, 0] * n0 + poly[src, 0, 2] * n2) + poly[src, 0, 1] * n1 - limit
    si = s_first
    for i in range(count):
        j = i + 1 if i + 1 < count else 0
        sj = s_first if j == 0 else (poly[src, j, 0] * n0 + poly[src, j, 2] * n2) + poly[src, j, 1] * n1 - limit
        inside = si <= 0.0
        if inside:
            r = min(n_out, QUAD_VERTS - 1)
            for c in range(3):
                poly[dst, r, c] = poly[src, i, c]
            n_out += 1
        if inside != (sj <= 0.0):
            d = si - sj
            t = si / (1.0 if d == 0.0 else d)
            r = min(n_out, QUAD_VERTS - 1)
            for c in range(3):
                poly[dst, r, c] = poly[src, i, c] + t * (poly[src, j, c] - poly[src, i, c])
            n_out += 1
        si = sj
    return min(n_out, QUAD_VERTS)


@njit(cache=True, inline="always", error_model="numpy")
def _side_planes(frame, tri0, tri1, tri2, planes, row):
    """The three sides of the triangle (frame rows tri0, tri1, tri2) as planes
    perpendicular to A's face (quadrature.face_on_face's triangle clips and _side_value):
    planes[row + k] = (outward normal in A's face plane, normal . p0, p0) of side k
    (p0 -> p1), outward = away from the opposite vertex."""
    nA = frame[_F_NA]
    rows = (tri0, tri1, tri2)
    for k in range(3):
        p0, p1, opp = frame[rows[k]], frame[rows[(k + 1) % 3]], frame[rows[(k + 2) % 3]]
        d0, d1, d2 = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
        o0, o1, o2 = d1 * nA[2] - d2 * nA[1], d2 * nA[0] - d0 * nA[2], d0 * nA[1] - d1 * nA[0]  # np.cross
        toward = (o0 * (opp[0] - p0[0]) + o1 * (opp[1] - p0[1])) + o2 * (opp[2] - p0[2])
        flip = -1.0 if toward > 0.0 else 1.0
        pl = planes[row + k]
        pl[0], pl[1], pl[2] = o0 * flip, o1 * flip, o2 * flip
        pl[3] = (pl[0] * p0[0] + pl[1] * p0[1]) + pl[2] * p0[2]
        pl[4], pl[5], pl[6] = p0[0], p0[1], p0[2]


@njit(cache=True, inline="always", error_model="numpy")
def _edge_plane(frame, e0, e1, centre, face_level, plane):
    """The clip that keeps a face's own part near its outer edge e0 -> e1 (frame rows) of
    the face centred at frame row centre (quadrature.face_on_face with _inward): plane =
    (g, c) with g = -(nA / 2 + w_in), c = -(face_level / 2 + w_in . e0), w_in the unit
    inward perpendicular to the edge in A's face plane."""
    nA, a, b, o = frame[_F_NA], frame[e0], frame[e1], frame[centre]
    d0, d1, d2 = o[0] - a[0], o[1] - a[1], o[2] - a[2]
    s = (d0 * nA[0] + d2 * nA[2]) + d1 * nA[1]
    d0, d1, d2 = d0 - s * nA[0], d1 - s * nA[1], d2 - s * nA[2]
    g0, g1, g2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    s = (g0 * nA[0] + g2 * nA[2]) + g1 * nA[1]
    g0, g1, g2 = g0 - s * nA[0], g1 - s * nA[1], g2 - s * nA[2]
    length = max(math.sqrt((g0 * g0 + g1 * g1) + g2 * g2), 1e-12)
    g0, g1, g2 = g0 / length, g1 / length, g2 / length
    s = (d0 * g0 + d1 * g1) + d2 * g2
    d0, d1, d2 = d0 - s * g0, d1 - s * g1, d2 - s * g2
    length = max(math.sqrt((d0 * d0 + d1 * d1) + d2 * d2), 1e-12)
    w0, w1, w2 = d0 / length, d1 / length, d2 / length
    plane[0], plane[1], plane[2] = -(0.5 * nA[0] + w0), -(0.5 * nA[1] + w1), -(0.5 * nA[2] + w2)
    plane[3] = -(0.5 * face_level + ((w0 * a[0] + w1 * a[1]) + w2 * a[2]))


@njit(cache=True, inline="always", error_model="numpy")
def _polygon(frame, planes, i, j, face_level, poly, items, k_item):
    """Polygon (i, j): B's triangle j clipped by A's triangle i's sides, A's face plane and
    both edge clips, evaluated once at its centroid. Fills items[k_item, :4] = (area x pressure at
    the centroid [m^3], centroid (3) [m]) and returns the overlap at the centroid [m]
    (face_on_face keeps it in items[k_item, 4] for the mean depth)."""
    cj, cn = _F_CB + j, _F_CB + (j + 1) % 4
    for c in range(3):
        poly[0, 0, c], poly[0, 1, c], poly[0, 2, c] = frame[_F_CENTRE_B, c], frame[cj, c], frame[cn, c]
    count, src = 3, 0
    for k in range(6):  # A's triangle's 3 sides, A's face plane, the edge clips of B's edge j and A's edge i
        if count == 0:  # nothing left (a polygon of 1 or 2 vertices can still grow a degenerate third)
            break
        if k == 3:
            count = _clip(poly, src, count, frame[_F_NA, 0], frame[_F_NA, 1], frame[_F_NA, 2], face_level)
        else:
            row = _P_SIDE_A + 3 * i + k if k < 3 else (_P_EDGE_B + j if k == 4 else _P_EDGE_A + i)
            count = _clip(poly, src, count, planes[row, 0], planes[row, 1], planes[row, 2], planes[row, 3])
        src = 1 - src
    a = poly[src]
    # quadrature._area_centroid: fan from the first vertex, areas summed left to right
    total, f0, f1, f2 = -0.0, 0.0, 0.0, 0.0
    for t in range(count - 2):
        e10, e11, e12 = a[t + 1, 0] - a[0, 0], a[t + 1, 1] - a[0, 1], a[t + 1, 2] - a[0, 2]
        e20, e21, e22 = a[t + 2, 0] - a[0, 0], a[t + 2, 1] - a[0, 1], a[t + 2, 2] - a[0, 2]
        x0, x1, x2 = e11 * e22 - e12 * e21, e12 * e20 - e10 * e22, e10 * e21 - e11 * e20
        area = 0.5 * math.sqrt((x0 * x0 + x1 * x1) + x2 * x2)
        total += area
        f0 += area * (a[0, 0] + (e10 + e20) / 3.0)
        f1 += area * (a[0, 1] + (e11 + e21) / 3.0)
        f2 += area * (a[0, 2] + (e12 + e22) / 3.0)
    safe = total if total > 0.0 else 1.0
    items[k_item, 1], items[k_item, 2], items[k_item, 3] = f0 / safe, f1 / safe, f2 / safe
    nA = frame[_F_NA]
    overlap = max(face_level - ((items[k_item, 1] * nA[0] + items[k_item, 2] * nA[1]) + items[k_item, 3] * nA[2]), 0.0)
    items[k_item, 0] = total * 0.5 * overlap  # pressure at the equal-pressure plane: half the overlap deep
    return overlap


@njit(cache=True, inline="always", error_model="numpy")
def _sliver(frame, planes, side_row, e0, e1, centre, own_b, face_level, facing, items, k, p, R, hA, hB, axes):
    """The sliver along the edge e0 -> e1 (frame rows) of the face centred at frame row
    centre, clipped by the other face's triangle (planes[side_row:side_row + 3], sides in
    A's face plane) and to where the overlap is >= 0 (own_b: B's edge, overlap below A's
    face plane; else A's edge, overlap above B's face, / facing = cos of the tilt).
    Fills items[k] = (area x centroid's distance from the edge [m^3], centre (3) [m], normal
    direction (3), unnormalised) as quadrature.face_on_face's sliver loop."""
    nA, nB, a, b, o = frame[_F_NA], frame[_F_NB], frame[e0], frame[e1], frame[centre]
    cB = frame[_F_CENTRE_B]
    t0, t1 = 0.0, 1.0
    for f in range(4):
        if f < 3:
            pl = planes[side_row + f]
            s0 = (pl[0] * (a[0] - pl[4]) + pl[1] * (a[1] - pl[5])) + pl[2] * (a[2] - pl[6])
            s1 = (pl[0] * (b[0] - pl[4]) + pl[1] * (b[1] - pl[5])) + pl[2] * (b[2] - pl[6])
        elif own_b:
            s0 = -(face_level - ((a[0] * nA[0] + a[2] * nA[2]) + a[1] * nA[1]))
            s1 = -(face_level - ((b[0] * nA[0] + b[2] * nA[2]) + b[1] * nA[1]))
        else:
            s0 = -(((nB[0] * (cB[0] - a[0]) + nB[2] * (cB[2] - a[2])) + nB[1] * (cB[1] - a[1])) / facing)
            s1 = -(((nB[0] * (cB[0] - b[0]) + nB[2] * (cB[2] - b[2])) + nB[1] * (cB[1] - b[1])) / facing)
        d = s0 - s1
        t_cross = s0 / (1.0 if d == 0.0 else d)
        if s0 > 0.0 and s1 <= 0.0:
            t0 = max(t0, t_cross)
        if s0 <= 0.0 and s1 > 0.0:
            t1 = min(t1, t_cross)
        if s0 > 0.0 and s1 > 0.0:  # wholly outside
            t1 = -1.0
            break
    if not t1 > t0:  # the edge misses the triangle: a zero item (what the full computation gives)
        for c in range(7):
            items[k, c] = 0.0
        return
    u0, u1, u2 = a[0] + t0 * (b[0] - a[0]), a[1] + t0 * (b[1] - a[1]), a[2] + t0 * (b[2] - a[2])
    v0, v1, v2 = a[0] + t1 * (b[0] - a[0]), a[1] + t1 * (b[1] - a[1]), a[2] + t1 * (b[2] - a[2])
    if own_b:  # the strip's width at each end [m]: half the local overlap
        h0 = 0.5 * max(face_level - ((u0 * nA[0] + u2 * nA[2]) + u1 * nA[1]), 0.0)
        h1 = 0.5 * max(face_level - ((v0 * nA[0] + v2 * nA[2]) + v1 * nA[1]), 0.0)
    else:
        h0 = 0.5 * max(((nB[0] * (cB[0] - u0) + nB[2] * (cB[2] - u2)) + nB[1] * (cB[1] - u1)) / facing, 0.0)
        h1 = 0.5 * max(((nB[0] * (cB[0] - v0) + nB[2] * (cB[2] - v2)) + nB[1] * (cB[1] - v1)) / facing, 0.0)
    l0, l1, l2 = v0 - u0, v1 - u1, v2 - u2
    length = math.sqrt((l0 * l0 + l1 * l1) + l2 * l2)
    hsum = h0 + h1 if h0 + h1 > 0.0 else 1.0
    area = _SQRT2 * length * 0.5 * (h0 + h1)
    y_bar = (h0 * h0 + h0 * h1 + h1 * h1) / (3.0 * hsum)  # the strip centroid's distance from the edge
    along = (h0 + 2.0 * h1) / (3.0 * hsum)
    xc0, xc1, xc2 = u0 + along * l0, u1 + along * l1, u2 + along * l2  # the strip's centre on the edge
    # inward: in A's face plane, perpendicular to the edge, towards the face's centre
    w0, w1, w2 = o[0] - xc0, o[1] - xc1, o[2] - xc2
    s = (w0 * nA[0] + w2 * nA[2]) + w1 * nA[1]
    w0, w1, w2 = w0 - s * nA[0], w1 - s * nA[1], w2 - s * nA[2]
    g0, g1, g2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    g = max(math.sqrt((g0 * g0 + g1 * g1) + g2 * g2), 1e-12)
    g0, g1, g2 = g0 / g, g1 / g, g2 / g
    s = (w0 * g0 + w1 * g1) + w2 * g2
    w0, w1, w2 = w0 - s * g0, w1 - s * g1, w2 - s * g2
    g = max(math.sqrt((w0 * w0 + w1 * w1) + w2 * w2), 1e-12)
    w0, w1, w2 = w0 / g, w1 / g, w2 / g
    # the fade where this edge runs within one overlap of the other face's edge (quadrature.face_on_face)
    uA, vA, uB, vB = axes[0], axes[1], axes[2], axes[3]
    if own_b:  # how far inside A's face rectangle, and the overlap there
        xu = xc0 if uA == 0 else (xc1 if uA == 1 else xc2)
        xv = xc0 if vA == 0 else (xc1 if vA == 1 else xc2)
        inside = min(hA[uA] - abs(xu), hA[vA] - abs(xv))
        o_c = max(face_level - ((xc0 * nA[0] + xc2 * nA[2]) + xc1 * nA[1]), 0.0)
    else:  # how far inside B's face rectangle (in B's frame)
        d0, d1, d2 = xc0 - p[0], xc1 - p[1], xc2 - p[2]
        qu = (R[0, uB] * d0 + R[1, uB] * d1) + R[2, uB] * d2
        qv = (R[0, vB] * d0 + R[1, vB] * d1) + R[2, vB] * d2
        inside = min(hB[uB] - abs(qu), hB[vB] - abs(qv))
        o_c = max(((nB[0] * (cB[0] - xc0) + nB[2] * (cB[2] - xc2)) + nB[1] * (cB[1] - xc1)) / facing, 0.0)
    u = min(max(inside / (o_c if o_c > 0.0 else 1.0), 0.0), 1.0)
    items[k, 0] = area * y_bar * (u * u * (3.0 - 2.0 * u))
    items[k, 1], items[k, 2], items[k, 3] = xc0 + y_bar * w0, xc1 + y_bar * w1, xc2 + y_bar * w2
    if own_b:  # B's side face's inward normal lies in B's face plane
        s = (w0 * nB[0] + w2 * nB[2]) + w1 * nB[1]
        z0, z1, z2 = w0 - s * nB[0], w1 - s * nB[1], w2 - s * nB[2]
        g = max(math.sqrt((z0 * z0 + z1 * z1) + z2 * z2), 1e-12)
        items[k, 4], items[k, 5], items[k, 6] = nA[0] + z0 / g, nA[1] + z1 / g, nA[2] + z2 / g
    else:
        items[k, 4], items[k, 5], items[k, 6] = -w0 - nB[0], -w1 - nB[1], -w2 - nB[2]


@njit(cache=True, inline="always", error_model="numpy")
def _faces(R, n):
    """quadrature.faces for one pose: (a, sigma_A, m, s_B): A's face axis a and side sigma_A
    (+-1; A's face normal sigma_A e_a), B's face axis m and side s_B (B's face normal
    s_B b_m points towards A), picked by the normal n (3,) (unit, A->B, in A)."""
    a = 0
    for k in range(1, 3):
        if abs(n[k]) > abs(n[a]):
            a = k
    sigma_A = 1.0 if n[a] >= 0.0 else -1.0
    m, along_m = 0, 0.0
    for k in range(3):
        along = (n[0] * R[0, k] + n[1] * R[1, k]) + n[2] * R[2, k]  # n . b_k
        if k == 0 or abs(along) > abs(along_m):
            m, along_m = k, along
    return a, sigma_A, m, -1.0 if along_m > 0.0 else 1.0


@njit(cache=True, error_model="numpy")
def face_tilt(R, n):
    """The tilt [rad] between the two faces that n (3,) picks (quadrature.faces), as
    face_on_face returns it: lets a caller skip the quadrature where every hand-over
    weight is 0 anyway."""
    a, _, m, _ = _faces(R, n)
    return math.acos(min(max(abs(R[a, m]), 0.0), 1.0))


@njit(cache=True, error_model="numpy")
def face_on_face(p, R, hA, hB, n, frame, planes, items, poly, point, normal):
    """Drake's centre of pressure and normal of B's face pressed on A's face, for one pose
    (quadrature.face_on_face, whose docstring says what and why; faces picked by n as
    quadrature.faces does).

    p (3,) [m] B's centre in A, R (3, 3) B's axes in A (columns), hA, hB (3,) half extents
    [m], n (3,) unit A->B in A; frame, planes, items, poly: `face_on_face_scratch()`. Fills point (3,)
    [m] in A (on the equal-pressure surface) and normal (3,) (unit, A->B, in A); returns
    (weight [m^3]: sum of area x overlap at the centroids, 0 where the faces do not
    overlap; tilt [rad] between the two faces)."""
    a, sigma_A, m, s_B = _faces(R, n)
    uA, vA, uB, vB = (a + 1) % 3, (a + 2) % 3, (m + 1) % 3, (m + 2) % 3
    top, cB, nA, nB = frame[_F_TOP], frame[_F_CENTRE_B], frame[_F_NA], frame[_F_NB]
    h_top, h_bottom = sigma_A * hA[a], s_B * hB[m]
    for c in range(3):
        top[c] = h_top * (1.0 if c == a else 0.0)
        nA[c] = sigma_A * (1.0 if c == a else 0.0)
        cB[c] = p[c] + h_bottom * R[c, m]
        nB[c] = s_B * R[c, m]
    for k in range(4):
        fu, fv = _FAN_U[k], _FAN_V[k]
        for c in range(3):
            frame[_F_CA + k, c] = top[c] + (fu * hA[uA] * (1.0 if c == uA else 0.0) + fv * hA[vA] * (1.0 if c == vA else 0.0))
            frame[_F_CB + k, c] = cB[c] + (fu * hB[uB] * R[c, uB] + fv * hB[vB] * R[c, vB])
    face_level = hA[a]  # A's face along nA
    for i in range(4):
        _side_planes(frame, _F_TOP, _F_CA + i, _F_CA + (i + 1) % 4, planes, _P_SIDE_A + 3 * i)
        _side_planes(frame, _F_CENTRE_B, _F_CB + i, _F_CB + (i + 1) % 4, planes, _P_SIDE_B + 3 * i)
        _edge_plane(frame, _F_CB + i, _F_CB + (i + 1) % 4, _F_CENTRE_B, face_level, planes[_P_EDGE_B + i])
        _edge_plane(frame, _F_CA + i, _F_CA + (i + 1) % 4, _F_TOP, face_level, planes[_P_EDGE_A + i])
    # the 16 polygons (A's triangle i, B's triangle j); their overlap at the centroid in column 4
    for i in range(4):
        for j in range(4):
            k = _I_POLY + 4 * i + j
            items[k, 4] = _polygon(frame, planes, i, j, face_level, poly, items, k)
    main = frame[_F_MAIN]
    for c in range(3):
        main[c] = nA[c] - nB[c]
    length = _norm(main)
    for c in range(3):
        main[c] = main[c] / length
    facing = max(-((nB[0] * nA[0] + nB[1] * nA[1]) + nB[2] * nA[2]), 1e-6)  # cos of the tilt
    for i in range(4):
        for j in range(4):
            _sliver(frame, planes, _P_SIDE_A + 3 * i, _F_CB + j, _F_CB + (j + 1) % 4, _F_CENTRE_B, True,
                    face_level, facing, items, _I_SLIVER_B + 4 * i + j, p, R, hA, hB, (uA, vA, uB, vB))
            _sliver(frame, planes, _P_SIDE_B + 3 * j, _F_CA + i, _F_CA + (i + 1) % 4, _F_TOP, False,
                    face_level, facing, items, _I_SLIVER_A + 4 * i + j, p, R, hA, hB, (uA, vA, uB, vB))
    # the weighted means (numpy's orders: pairwise for the weight sums, left to right otherwise)
    weight = _pairwise(items, 0, 0, 48)
    safe = weight if weight > 0.0 else 1.0
    for c in range(3):
        s = 0.0
        for k in range(48):
            s += items[k, 0] * items[k, 1 + c]
        point[c] = s / safe
    w_poly = _pairwise(items, 0, 0, 16)
    depth_at = 0.0
    for k in range(16):
        depth_at += items[k, 0] * items[k, 4]
    depth_at = depth_at / (w_poly if w_poly > 0.0 else 1.0)
    along_nA = (point[0] * nA[0] + point[1] * nA[1]) + point[2] * nA[2]
    level = face_level - 0.5 * depth_at
    for c in range(3):
        point[c] = (point[c] - along_nA * nA[c]) + level * nA[c]
    for k in range(16, 48):  # unit sliver normals (a zero one stays 0, as in the numpy path)
        length = max(_norm(items[k, 4:7]), 1e-300)
        for c in range(3):
            items[k, 4 + c] = items[k, 4 + c] / length
    for c in range(3):
        s_main, s_B, s_A = 0.0, 0.0, 0.0
        for k in range(16):
            s_main += items[k, 0] * main[c]
            s_B += items[_I_SLIVER_B + k, 0] * items[_I_SLIVER_B + k, 4 + c]
            s_A += items[_I_SLIVER_A + k, 0] * items[_I_SLIVER_A + k, 4 + c]
        normal[c] = s_main + (s_B + s_A)
    length = max(_norm(normal), 1e-300)
    for c in range(3):
        normal[c] = normal[c] / length if weight > 0.0 else main[c]
    tilt = math.acos(min(max(abs(R[a, m]), 0.0), 1.0))
    return weight, tilt


@njit(cache=True, error_model="numpy")
def face_on_face_many(p, R, hA, hB, n):
    """quadrature.face_on_face on (n, 3), (n, 3, 3), (n, 3), (n, 3), (n, 3) arrays, one
    pose at a time: (point (n, 3) [m], normal (n, 3), weight (n,) [m^3], tilt (n,) [rad])
    (to compare with the numpy path; the predictor calls face_on_face per pose)."""
    rows = p.shape[0]
    point, normal, weight, tilt = np.empty((rows, 3)), np.empty((rows, 3)), np.empty(rows), np.empty(rows)
    frame, planes, items, poly = face_on_face_scratch()
    for r in range(rows):
        weight[r], tilt[r] = face_on_face(p[r], R[r], hA[r], hB[r], n[r], frame, planes, items, poly, point[r], normal[r])
    return point, normal, weight, tilt
