"""The exact centre of pressure of a face-on-face contact for one pose, compiled: the numba
twin of learned_contact.model.quadrature (face_on_face, hand_over); read that module's
docstring for what is computed and why (the exact integral of Drake's linear pressure over
its contact surface, not the one-point rule of Drake's discrete solver).

Frames and units as there: A's frame; p (3,) [m] is B's centre in A, R (3, 3) B's axes in
A (columns), hA, hB (3,) half extents [m], n (3,) the separating-axis normal (unit, A->B,
in A) that picks the two faces. One pose per call, plain loops over small arrays: the
caller allocates the scratch once per batch (`face_on_face_scratch`) and passes it in, so
a call allocates nothing; the helpers are inlined into face_on_face (numba's
inline="always": as calls that pass a dozen arrays each they cost more than the work).
"Face coordinates" below are (x[u_A], x[v_A], sigma_A x[a]) of a point x in A: the two
in-plane axes of A's face and the height along its outward normal, so that A's face is
|u| <= hA[u_A], |v| <= hA[v_A] at height hA[a].

What is computed where:
- once per pose: the faces (`_faces`), the fan corners, the sides of both faces' fan
  triangles and the edge clips of both faces' edges (`_side_planes`, `_edge_plane`: A's
  face normal is an axis, so only the two in-plane components are computed), the sides'
  values at the other face's fan corners, and the overlap below B's face at A's corners;
- the 16 polygons (A's triangle i, B's triangle j): B's triangle clipped by A's triangle's
  sides, A's face plane and the two edge clips in the numpy path's order. A pair is
  skipped where a side of A's triangle has B's triangle wholly outside, where B's face
  runs above all of A's triangle or above all of B's triangle j, or where B's triangle lies
  wholly outside its own edge clip; a clip that keeps every vertex copies none;
- the 32 slivers: per edge, the interval where the overlap is >= 0 and the edge's
  direction (a miss skips the edge); per (edge, triangle) the interval from the three
  sides' values at the edge's ends (divided only where a side crosses the edge, stopping
  at the first side it misses), then the strip; a strip of zero weight (faded out) adds
  nothing, its normal is not computed; A's strips share one normal per edge;
- per polygon, the exact integrals of the pressure and of the pressure times position
  (fan triangles from the first vertex, the pressure half the overlap below A's face at
  each vertex); per sliver, its weight and its centre of pressure within the strip model;
- the weighted means, summed as they come (no per-item storage): the point on the
  equal-pressure plane half the polygons' pressure-weighted mean overlap below A's face,
  and the normal.
Cost: 1.2 us per pair on 4,096 centred stacks and 1.8 us on 2,048 stacking and general
poses (learned_contact.evaluation.benchmark: centred_stacks, _poses; best of 9, a 2-core
VM), against 3.6 and 3.8 us for the form that clipped all 16 pairs and evaluated all 32
slivers in full. Those figures are the one-point form's; the exact integrals cost about the
same (4,096 centred stacks, the two forms timed in turn in one process, best of 9 per round,
quietest rounds of 12 on a shared 2-core VM: 1.67 us per pair against 1.65).

The arithmetic follows the numpy reference wherever a result depends on its rounding: the
clip distances and the polygon vertices, areas and pressure moments (a resting contact's weights
are area x an overlap of microns under faces a metre high, and an edge clip runs within
microns of a polygon side, so a reordered sum moves the point by 1e-10 m), the sliver
interval ends, and the sliver strips' widths, centres, centres of pressure and fades (`_dot_lr`,
`_dot_c`: the numpy path's sums over A's axes, its einsum on contiguous operands summing
(x0 y0 + x2 y2) + x1 y1, written in face coordinates). The sums of the weighted means are
in another order, and the skipped pairs and strips are those whose area or weight is zero
but for rounding. On 26,624 poses (4,096 centred stacks; the 2,048 stacking and general
poses; 2,048 each of learned_contact.data.sampling's resting, resting_wide,
resting_level, resting_wider, resting_support, stacking, general and outside-training
stacking proposals placed at their depth; 4,096 random tilted stacks) the one-point form
this replaced differed from the numpy path's by at most 4.4e-15 m (point), 1.7e-15
(normal), 8.8e-16 relative (weight) and 2.2e-16 rad (tilt, np.arccos against math.acos).
The exact form, on 3,648 poses (2,048 centred stacks; 400 each of the stacking, general,
resting and resting_wider labelled sets): at most 4.4e-15 m (point), 4.4e-16 (normal),
6.1e-16 relative (weight), 1.4e-17 rad (tilt); 34-68 % of the points bit for bit the same. Where the faces do not
overlap (weight 0) the point is A's face centre and the normal the two face normals'
bisector, as there.

Division by zero gives inf or NaN as in the numpy path (error_model="numpy"), not an
exception; the divisions the numpy path guards are guarded the same way.

Caution (numba's cache): a function cached with cache=True is recompiled only when its
own source file changes, not when a function it calls from another file does. So
kernels.py carries a digest of this file (kernels.DEPENDENCY_DIGEST, checked by
tests/learned/test_learned_compiled.py): after an edit here, set it to the value that test
prints, which changes kernels.py and recompiles improved_predict.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

QUAD_VERTS = 9  # a triangle clipped by 6 half-planes keeps at most 9 vertices (quadrature._MAX_VERTS)
# scratch rows (`face_on_face_scratch`): frame (16, 3): A's fan corners (0-3), B's fan corners
# (4-7), A's face centre (8), B's face centre (9) [m], A's face normal (10), B's face normal
# towards A (11), all in A, and B's fan corners in face coordinates (12-15) [m]; planes (32, 6):
# (normal (3), limit [m], a point's two in-plane coordinates [m]) of A's triangles' sides
# (i * 3 + k, 0-11) and B's triangles' sides in A's face plane (12 + j * 3 + k), (normal (3),
# limit) of the edge clips of B's edges (24 + j) and of A's edges (28 + i); items (11, 12): the
# current clip's signed distance per vertex (row 0), the values of A's 12 sides at B's face
# centre and fan corners (rows 1-5) and of B's 12 sides at A's fan corners (rows 6-9) [m^2],
# the overlap below B's face at A's fan corners and face centre (row 10, columns 0-4) [m];
# poly (2, QUAD_VERTS, 3): ping-pong polygon buffers [m] in A
_F_CA, _F_CB, _F_TOP, _F_CENTRE_B, _F_NA, _F_NB, _F_LOCAL_B = 0, 4, 8, 9, 10, 11, 12
_P_SIDE_A, _P_SIDE_B, _P_EDGE_B, _P_EDGE_A = 0, 12, 24, 28
_V_SIDE_A, _V_SIDE_B, _V_DEPTH_B = 1, 6, 10
# A's fan corners (+u +v), (-u +v), (-u -v), (+u -v) (quadrature._FAN); in face coordinates
# the outward unit normal of A's edge i (corner i -> i + 1)
_FAN_U = (1.0, -1.0, -1.0, 1.0)
_FAN_V = (1.0, 1.0, -1.0, -1.0)
_OUT_U = (0.0, -1.0, 0.0, 1.0)
_OUT_V = (1.0, 0.0, -1.0, 0.0)
_SQRT2 = math.sqrt(2.0)


@njit(cache=True)
def face_on_face_scratch():
    """(frame (16, 3), planes (32, 6), items (11, 12), poly (2, QUAD_VERTS, 3)): the work
    arrays of face_on_face, allocated once per batch (their rows: the comment above)."""
    return np.empty((16, 3)), np.empty((32, 6)), np.empty((11, 12)), np.empty((2, QUAD_VERTS, 3))


@njit(cache=True, inline="always", error_model="numpy")
def hand_over(tilt, band0, band1):
    """Weight of the face-on-face answer for a tilt [rad] between the two faces
    (quadrature.hand_over): 1 up to band0, 0 from band1 on [rad], a C1 smoothstep between."""
    u = min(max((tilt - band0) / (band1 - band0), 0.0), 1.0)
    return 1.0 - u * u * (3.0 - 2.0 * u)


@njit(cache=True, inline="always", error_model="numpy")
def _clip(poly, src, count, n0, n1, n2, limit, items):
    """Sutherland-Hodgman (learned_contact.model.clipping.clip_halfspace for one polygon):
    the polygon poly[src] (count valid rows of (QUAD_VERTS, 3)) clipped to the half-space
    (n0, n1, n2) . x <= limit. Returns (count, buffer): (count, src) untouched where every
    vertex is inside, else the clipped polygon written to poly[1 - src]. Vertices beyond
    the budget overwrite the last row, as the numpy path's scatter does; items[0] takes
    each vertex's signed distance, computed once in the numpy path's order."""
    outside = False
    for i in range(count):
        s = (poly[src, i, 0] * n0 + poly[src, i, 2] * n2) + poly[src, i, 1] * n1 - limit
        items[0, i] = s
        outside |= not s <= 0.0
    if not outside:
        return count, src
    dst = 1 - src
    n_out = 0
    x0, x1, x2, si = poly[src, 0, 0], poly[src, 0, 1], poly[src, 0, 2], items[0, 0]
    for i in range(count):
        j = i + 1 if i + 1 < count else 0
        y0, y1, y2, sj = poly[src, j, 0], poly[src, j, 1], poly[src, j, 2], items[0, j]
        inside = si <= 0.0
        if inside:
            r = min(n_out, QUAD_VERTS - 1)
            poly[dst, r, 0], poly[dst, r, 1], poly[dst, r, 2] = x0, x1, x2
            n_out += 1
        if inside != (sj <= 0.0):
            d = si - sj
            t = si / (1.0 if d == 0.0 else d)
            r = min(n_out, QUAD_VERTS - 1)
            poly[dst, r, 0], poly[dst, r, 1], poly[dst, r, 2] = x0 + t * (y0 - x0), x1 + t * (y1 - x1), x2 + t * (y2 - x2)
            n_out += 1
        x0, x1, x2, si = y0, y1, y2, sj
    return min(n_out, QUAD_VERTS), dst


@njit(cache=True, inline="always", error_model="numpy")
def _side_planes(frame, tri0, tri1, tri2, planes, row, uA, vA, sigma_A):
    """The three sides of the triangle (frame rows tri0, tri1, tri2) as planes
    perpendicular to A's face (quadrature.face_on_face's triangle clips and _side_value):
    planes[row + k] = (outward normal (3), normal . p0, p0's in-plane coordinates (2)) of
    side k (p0 -> p1), outward = away from the opposite vertex. The normal is the numpy
    path's cross product with A's face normal sigma_A e_a: its component along e_a is 0
    and the in-plane ones (axes uA, vA) are the same values computed alone."""
    rows = (tri0, tri1, tri2)
    a = 3 - uA - vA
    for k in range(3):
        r0, r1, ro = rows[k], rows[(k + 1) % 3], rows[(k + 2) % 3]
        ou, ov = sigma_A * (frame[r1, vA] - frame[r0, vA]), -(sigma_A * (frame[r1, uA] - frame[r0, uA]))
        toward = ou * (frame[ro, uA] - frame[r0, uA]) + ov * (frame[ro, vA] - frame[r0, vA])
        flip = -1.0 if toward > 0.0 else 1.0
        r = row + k
        planes[r, uA], planes[r, vA], planes[r, a] = ou * flip, ov * flip, 0.0
        planes[r, 3] = planes[r, uA] * frame[r0, uA] + planes[r, vA] * frame[r0, vA]
        planes[r, 4], planes[r, 5] = frame[r0, uA], frame[r0, vA]


@njit(cache=True, inline="always", error_model="numpy")
def _edge_plane(frame, e0, e1, centre, face_level, planes, row, uA, vA, sigma_A):
    """The clip that keeps a face's own part near its outer edge e0 -> e1 (frame rows) of
    the face centred at frame row centre (quadrature.face_on_face with _inward):
    planes[row, :4] = (g, c) with g = -(nA / 2 + w_in), c = -(face_level / 2 + w_in . e0),
    w_in the unit inward perpendicular to the edge in A's face plane (from the in-plane
    components alone: the numpy path's values)."""
    a = 3 - uA - vA
    du, dv = frame[centre, uA] - frame[e0, uA], frame[centre, vA] - frame[e0, vA]
    gu, gv = frame[e1, uA] - frame[e0, uA], frame[e1, vA] - frame[e0, vA]
    length = max(math.sqrt(gu * gu + gv * gv), 1e-12)
    gu, gv = gu / length, gv / length
    s = du * gu + dv * gv
    du, dv = du - s * gu, dv - s * gv
    length = max(math.sqrt(du * du + dv * dv), 1e-12)
    wu, wv = du / length, dv / length
    planes[row, uA], planes[row, vA], planes[row, a] = -wu, -wv, -(0.5 * sigma_A)
    planes[row, 3] = -(0.5 * face_level + (wu * frame[e0, uA] + wv * frame[e0, vA]))


@njit(cache=True, inline="always", error_model="numpy")
def _plane_dist(frame, r, planes, row):
    """planes[row, :3] . frame[r] - planes[row, 3] [m]: a point's signed distance as the clip
    computes it."""
    return (frame[r, 0] * planes[row, 0] + frame[r, 2] * planes[row, 2]) + frame[r, 1] * planes[row, 1] - planes[row, 3]


@njit(cache=True, inline="always", error_model="numpy")
def _side_value(planes, row, frame, r, uA, vA):
    """Where the point frame[r] [m] lies from the triangle side planes[row]
    (quadrature._side_value; <= 0 inside), from the in-plane components."""
    return planes[row, uA] * (frame[r, uA] - planes[row, 4]) + planes[row, vA] * (frame[r, vA] - planes[row, 5])


@njit(cache=True, inline="always", error_model="numpy")
def _interval(s0, s1, t0, t1):
    """The part [t0, t1] of a segment (t in [0, 1]) where a linear function, s0 at t = 0 and
    s1 at t = 1, is <= 0, intersected with the given [t0, t1]; t1 = -1 where s0 and s1 are
    both > 0 (quadrature.face_on_face's sliver interval)."""
    if s0 > 0.0:
        if s1 > 0.0:
            t1 = -1.0
        elif s1 <= 0.0:
            d = s0 - s1
            t0 = max(t0, s0 / (1.0 if d == 0.0 else d))
    elif s0 <= 0.0 and s1 > 0.0:
        d = s0 - s1
        t1 = min(t1, s0 / (1.0 if d == 0.0 else d))
    return t0, t1


@njit(cache=True, inline="always", error_model="numpy")
def _strip(h0, h1, length):
    """A sliver strip over an edge interval length [m] long, h0, h1 [m] wide at its ends, the
    pressure rising linearly across it from the edge (quadrature.face_on_face): (area on the
    45 deg surface [m^2], the strip centroid's distance from the edge [m] (area x it is the
    strip's weight), the strip centroid's place along the interval (0 at its start, 1 at its
    end), the centre of pressure's distance from the edge [m] and its place along the interval)."""
    hs = h0 + h1
    hsum = hs if hs > 0.0 else 1.0
    h2 = h0 * h0 + h0 * h1 + h1 * h1
    y_bar = h2 / (3.0 * hsum)
    h2 = h2 if h2 > 0.0 else 1.0
    return (_SQRT2 * length * 0.5 * hs, y_bar, (h0 + 2.0 * h1) / (3.0 * hsum),
            hsum * (h0 * h0 + h1 * h1) / (2.0 * h2), (h0 * h0 + 2.0 * h0 * h1 + 3.0 * h1 * h1) / (4.0 * h2))


@njit(cache=True, inline="always", error_model="numpy")
def _dot_lr(xu, xv, xz, yu, yv, yz, a):
    """x . y of two vectors in face coordinates, summed left to right over A's axes."""
    if a == 0:
        return (xz * yz + xu * yu) + xv * yv
    if a == 1:
        return (xv * yv + xz * yz) + xu * yu
    return (xu * yu + xv * yv) + xz * yz


@njit(cache=True, inline="always", error_model="numpy")
def _dot_c(xu, xv, xz, yu, yv, yz, a):
    """x . y of two vectors in face coordinates, summed over A's axes in the order of the
    numpy path's einsum on contiguous operands: (x0 y0 + x2 y2) + x1 y1."""
    if a == 0:
        return (xz * yz + xv * yv) + xu * yu
    if a == 1:
        return (xv * yv + xu * yu) + xz * yz
    return (xu * yu + xz * yz) + xv * yv


@njit(cache=True, inline="always", error_model="numpy")
def _fade(inside, overlap):
    """The sliver's fade (quadrature.face_on_face): a smoothstep of how far [m] its centre lies
    inside the other face's rectangle, in units of the overlap there [m]."""
    u = min(max(inside / (overlap if overlap > 0.0 else 1.0), 0.0), 1.0)
    return u * u * (3.0 - 2.0 * u)


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
    """The exact centre of pressure and the normal of B's face pressed on A's face, for one pose
    (quadrature.face_on_face, whose docstring says what and why; faces picked by n as
    quadrature.faces does).

    p (3,) [m] B's centre in A, R (3, 3) B's axes in A (columns), hA, hB (3,) half extents
    [m], n (3,) unit A->B in A; frame, planes, items, poly: `face_on_face_scratch()`. Fills point (3,)
    [m] in A (on the equal-pressure surface) and normal (3,) (unit, A->B, in A); returns
    (weight [m^3]: the integral of the pressure (half the overlap) over the polygons and
    the slivers, 0 where the faces do not overlap; tilt [rad] between the two faces)."""
    a, sigma_A, m, s_B = _faces(R, n)
    uA, vA, uB, vB = (a + 1) % 3, (a + 2) % 3, (m + 1) % 3, (m + 2) % 3
    U, V, L = hA[uA], hA[vA], hA[a]  # A's face: |u| <= U, |v| <= V at height L
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
    for i in range(4):
        _side_planes(frame, _F_TOP, _F_CA + i, _F_CA + (i + 1) % 4, planes, _P_SIDE_A + 3 * i, uA, vA, sigma_A)
        _side_planes(frame, _F_CENTRE_B, _F_CB + i, _F_CB + (i + 1) % 4, planes, _P_SIDE_B + 3 * i, uA, vA, sigma_A)
        _edge_plane(frame, _F_CB + i, _F_CB + (i + 1) % 4, _F_CENTRE_B, L, planes, _P_EDGE_B + i, uA, vA, sigma_A)
        _edge_plane(frame, _F_CA + i, _F_CA + (i + 1) % 4, _F_TOP, L, planes, _P_EDGE_A + i, uA, vA, sigma_A)
    # each side's value (quadrature._side_value) at the other face's fan corners (and B's centre)
    for k in range(12):
        items[_V_SIDE_A, k] = _side_value(planes, _P_SIDE_A + k, frame, _F_CENTRE_B, uA, vA)
        for r in range(4):
            items[_V_SIDE_A + 1 + r, k] = _side_value(planes, _P_SIDE_A + k, frame, _F_CB + r, uA, vA)
            items[_V_SIDE_B + r, k] = _side_value(planes, _P_SIDE_B + k, frame, _F_CA + r, uA, vA)
    # face coordinates (x[uA], x[vA], sigma_A x[a]) of B's face centre, face normal, axes u
    # and v and fan corners
    p0, p1, p2 = p[uA], p[vA], sigma_A * p[a]
    o0, o1, o2 = cB[uA], cB[vA], sigma_A * cB[a]
    nB0, nB1, nB2 = nB[uA], nB[vA], sigma_A * nB[a]
    bu0, bu1, bu2 = R[uA, uB], R[vA, uB], sigma_A * R[a, uB]
    bv0, bv1, bv2 = R[uA, vB], R[vA, vB], sigma_A * R[a, vB]
    for k in range(4):
        frame[_F_LOCAL_B + k, 0] = frame[_F_CB + k, uA]
        frame[_F_LOCAL_B + k, 1] = frame[_F_CB + k, vA]
        frame[_F_LOCAL_B + k, 2] = sigma_A * frame[_F_CB + k, a]
    facing = max(-nB2, 1e-6)  # cos of the tilt
    # the overlap below B's face (quadrature.face_on_face's depth_B_at [m]) at A's fan corners and face centre
    for r in range(5):
        xu, xv = (_FAN_U[r] * U, _FAN_V[r] * V) if r < 4 else (0.0, 0.0)
        items[_V_DEPTH_B, r] = _dot_c(nB0, nB1, nB2, o0 - xu, o1 - xv, o2 - L, a) / facing
    weight, w_poly, depth_sum, sum_u, sum_v = 0.0, 0.0, 0.0, 0.0, 0.0
    # the 16 polygons (A's triangle i, B's triangle j), clipped in quadrature.face_on_face's
    # order; a pair is skipped where B's triangle lies wholly above A's face or outside its
    # own edge clip, where B's face runs above all of A's triangle, or where a side of A's
    # triangle has B's triangle wholly outside; a clip that keeps every vertex copies none
    for j in range(4):
        jn = (j + 1) % 4
        if o2 > L and frame[_F_LOCAL_B + j, 2] > L and frame[_F_LOCAL_B + jn, 2] > L:
            continue
        eb = _P_EDGE_B + j
        if (_plane_dist(frame, _F_CENTRE_B, planes, eb) > 0.0 and _plane_dist(frame, _F_CB + j, planes, eb) > 0.0
                and _plane_dist(frame, _F_CB + jn, planes, eb) > 0.0):
            continue
        for i in range(4):
            if nB2 < 0.0 and items[_V_DEPTH_B, 4] < 0.0 and items[_V_DEPTH_B, i] < 0.0 and items[_V_DEPTH_B, (i + 1) % 4] < 0.0:
                continue  # B's face runs above A's triangle i: nothing of it overlaps
            apart = False
            for k in range(3):
                col = 3 * i + k
                apart |= (items[_V_SIDE_A, col] > 0.0 and items[_V_SIDE_A + 1 + j, col] > 0.0
                          and items[_V_SIDE_A + 1 + jn, col] > 0.0)
            if apart:
                continue
            for c in range(3):
                poly[0, 0, c], poly[0, 1, c], poly[0, 2, c] = cB[c], frame[_F_CB + j, c], frame[_F_CB + jn, c]
            count, src = 3, 0
            for k in range(6):  # A's triangle's 3 sides, A's face plane, the edge clips of B's edge j and A's edge i
                if count < 3:  # no area left (what a polygon of 1 or 2 vertices can still grow is degenerate)
                    break
                if k == 3:
                    n0, n1, n2, limit = nA[0], nA[1], nA[2], L
                else:
                    row = _P_SIDE_A + 3 * i + k if k < 3 else (_P_EDGE_B + j if k == 4 else _P_EDGE_A + i)
                    n0, n1, n2, limit = planes[row, 0], planes[row, 1], planes[row, 2], planes[row, 3]
                count, src = _clip(poly, src, count, n0, n1, n2, limit, items)
            if count < 3:
                continue
            # quadrature._pressure_moments: fan from the first vertex, the pressure (half the
            # overlap below A's face, linear) integrated exactly over each triangle
            q0, q1, q2 = poly[src, 0, 0], poly[src, 0, 1], poly[src, 0, 2]
            pa = 0.5 * (L - sigma_A * poly[src, 0, a])
            total, wt, f0, f1, f2 = -0.0, 0.0, 0.0, 0.0, 0.0
            for t in range(count - 2):
                y0, y1, y2 = poly[src, t + 1, 0], poly[src, t + 1, 1], poly[src, t + 1, 2]
                z0, z1, z2 = poly[src, t + 2, 0], poly[src, t + 2, 1], poly[src, t + 2, 2]
                e10, e11, e12 = y0 - q0, y1 - q1, y2 - q2
                e20, e21, e22 = z0 - q0, z1 - q1, z2 - q2
                x0, x1, x2 = e11 * e22 - e12 * e21, e12 * e20 - e10 * e22, e10 * e21 - e11 * e20
                area = 0.5 * math.sqrt((x0 * x0 + x1 * x1) + x2 * x2)
                pb = 0.5 * (L - sigma_A * poly[src, t + 1, a])
                pc = 0.5 * (L - sigma_A * poly[src, t + 2, a])
                ps = (pa + pb) + pc
                total += area
                wt += area * ps
                f0 += area * ((((ps * ((q0 + y0) + z0)) + pa * q0) + pb * y0) + pc * z0)
                f1 += area * ((((ps * ((q1 + y1) + z1)) + pa * q1) + pb * y1) + pc * z1)
                f2 += area * ((((ps * ((q2 + y2) + z2)) + pa * q2) + pb * y2) + pc * z2)
            if not total > 0.0:
                continue
            w = wt / 3.0  # the integral of the pressure
            weight += w
            w_poly += w
            mom_a = (f0 if a == 0 else (f1 if a == 1 else f2)) / 12.0  # the first moment along A's axis a
            depth_sum += sigma_A * mom_a
            sum_u += (f0 if uA == 0 else (f1 if uA == 1 else f2)) / 12.0
            sum_v += (f0 if vA == 0 else (f1 if vA == 1 else f2)) / 12.0
    sum_n0, sum_n1, sum_n2 = 0.0, 0.0, 0.0
    # B's slivers: B's edge j, inside the overlap (below A's face), clipped by A's triangle i
    for j in range(4):
        jn = (j + 1) % 4
        ra, rb = _F_LOCAL_B + j, _F_LOCAL_B + jn
        a0, a1, a2 = frame[ra, 0], frame[ra, 1], frame[ra, 2]
        g0, g1, g2 = frame[rb, 0] - a0, frame[rb, 1] - a1, frame[rb, 2] - a2
        e_t0, e_t1 = _interval(-(L - a2), -(L - frame[rb, 2]), 0.0, 1.0)
        if not e_t1 > e_t0:
            continue
        g_len = max(math.sqrt(_dot_lr(g0, g1, g2, g0, g1, g2, a)), 1e-12)
        e0, e1, e2 = g0 / g_len, g1 / g_len, g2 / g_len
        for i in range(4):
            t0, t1 = e_t0, e_t1
            for k in range(3):
                col = 3 * i + k
                t0, t1 = _interval(items[_V_SIDE_A + 1 + j, col], items[_V_SIDE_A + 1 + jn, col], t0, t1)
                if not t1 > t0:  # the edge misses the triangle
                    break
            if not t1 > t0:
                continue
            u0, u1, u2 = a0 + t0 * g0, a1 + t0 * g1, a2 + t0 * g2
            v0, v1, v2 = a0 + t1 * g0, a1 + t1 * g1, a2 + t1 * g2
            h0 = 0.5 * max(L - u2, 0.0)  # the strip's width at each end [m]: half the overlap
            h1 = 0.5 * max(L - v2, 0.0)
            l0, l1, l2 = v0 - u0, v1 - u1, v2 - u2
            area, y_bar, along, y_p, along_p = _strip(h0, h1, math.sqrt(_dot_lr(l0, l1, l2, l0, l1, l2, a)))
            x0, x1, x2 = u0 + along * l0, u1 + along * l1, u2 + along * l2  # the strip's centre on the edge
            w = area * y_bar * _fade(min(U - abs(x0), V - abs(x1)), max(L - x2, 0.0))
            if not w > 0.0:
                continue
            # inward: in A's face plane, perpendicular to the edge, towards the face's centre
            d0, d1 = o0 - x0, o1 - x1
            s = d0 * e0 + d1 * e1
            d0, d1, d2 = d0 - s * e0, d1 - s * e1, -(s * e2)
            d = max(math.sqrt(_dot_lr(d0, d1, d2, d0, d1, d2, a)), 1e-12)
            d0, d1, d2 = d0 / d, d1 / d, d2 / d
            weight += w
            sum_u += w * ((u0 + along_p * l0) + y_p * d0)  # the strip's centre of pressure
            sum_v += w * ((u1 + along_p * l1) + y_p * d1)
            # the normal: A's face normal plus B's side face's inward normal (in B's face plane)
            s = (d0 * nB0 + d1 * nB1) + d2 * nB2
            d0, d1, d2 = d0 - s * nB0, d1 - s * nB1, d2 - s * nB2
            d = max(math.sqrt((d0 * d0 + d1 * d1) + d2 * d2), 1e-12)
            d0, d1, d2 = d0 / d, d1 / d, 1.0 + d2 / d
            d = max(math.sqrt((d0 * d0 + d1 * d1) + d2 * d2), 1e-300)
            sum_n0 += w * (d0 / d)
            sum_n1 += w * (d1 / d)
            sum_n2 += w * (d2 / d)
    # A's slivers: A's edge i, inside the overlap (above B's face), clipped by B's triangle j
    for i in range(4):
        ou, ov = _OUT_U[i], _OUT_V[i]
        a0, a1 = _FAN_U[i] * U, _FAN_V[i] * V
        g0, g1 = _FAN_U[(i + 1) % 4] * U - a0, _FAN_V[(i + 1) % 4] * V - a1
        e_t0, e_t1 = _interval(-items[_V_DEPTH_B, i], -items[_V_DEPTH_B, (i + 1) % 4], 0.0, 1.0)
        if not e_t1 > e_t0:
            continue
        # the strip's normal: -(A's side face's inward normal -(ou, ov, 0)) - B's face normal
        m0, m1, m2 = ou - nB0, ov - nB1, -nB2
        d = max(math.sqrt((m0 * m0 + m1 * m1) + m2 * m2), 1e-300)
        m0, m1, m2 = m0 / d, m1 / d, m2 / d
        for j in range(4):
            t0, t1 = e_t0, e_t1
            for k in range(3):
                col = 3 * j + k
                t0, t1 = _interval(items[_V_SIDE_B + i, col], items[_V_SIDE_B + (i + 1) % 4, col], t0, t1)
                if not t1 > t0:
                    break
            if not t1 > t0:
                continue
            u0, u1 = a0 + t0 * g0, a1 + t0 * g1
            v0, v1 = a0 + t1 * g0, a1 + t1 * g1
            h0 = 0.5 * max(_dot_c(nB0, nB1, nB2, o0 - u0, o1 - u1, o2 - L, a) / facing, 0.0)
            h1 = 0.5 * max(_dot_c(nB0, nB1, nB2, o0 - v0, o1 - v1, o2 - L, a) / facing, 0.0)
            l0, l1 = v0 - u0, v1 - u1
            area, y_bar, along, y_p, along_p = _strip(h0, h1, abs(l0 + l1))  # the edge runs along u or v
            x0, x1 = u0 + along * l0, u1 + along * l1
            q0, q1, q2 = x0 - p0, x1 - p1, L - p2  # how far inside B's face rectangle (in B's frame)
            qu = _dot_lr(bu0, bu1, bu2, q0, q1, q2, a)
            qv = _dot_lr(bv0, bv1, bv2, q0, q1, q2, a)
            o_c = max(_dot_c(nB0, nB1, nB2, o0 - x0, o1 - x1, o2 - L, a) / facing, 0.0)
            w = area * y_bar * _fade(min(hB[uB] - abs(qu), hB[vB] - abs(qv)), o_c)
            if not w > 0.0:
                continue
            weight += w
            sum_u += w * ((u0 + along_p * l0) - y_p * ou)
            sum_v += w * ((u1 + along_p * l1) - y_p * ov)
            sum_n0 += w * m0
            sum_n1 += w * m1
            sum_n2 += w * m2
    # the weighted means: the point on the equal-pressure plane, half the mean overlap
    # below A's face; the polygons' normal is the bisector of the two face normals
    main0, main1, main2 = sigma_A * (1.0 if a == 0 else 0.0), sigma_A * (1.0 if a == 1 else 0.0), sigma_A * (1.0 if a == 2 else 0.0)
    main0, main1, main2 = main0 - s_B * R[0, m], main1 - s_B * R[1, m], main2 - s_B * R[2, m]
    length = math.sqrt((main0 * main0 + main1 * main1) + main2 * main2)
    main = (main0 / length, main1 / length, main2 / length)
    safe = weight if weight > 0.0 else 1.0
    depth_at = L - depth_sum / w_poly if w_poly > 0.0 else 0.0  # the polygons' pressure-weighted mean overlap
    point[uA], point[vA], point[a] = sum_u / safe, sum_v / safe, sigma_A * (L - 0.5 * depth_at)
    n0 = w_poly * main[uA] + sum_n0
    n1 = w_poly * main[vA] + sum_n1
    n2 = w_poly * (sigma_A * main[a]) + sum_n2
    length = max(math.sqrt((n0 * n0 + n1 * n1) + n2 * n2), 1e-300)
    if weight > 0.0:
        normal[uA], normal[vA], normal[a] = n0 / length, n1 / length, sigma_A * (n2 / length)
    else:
        normal[0], normal[1], normal[2] = main
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
