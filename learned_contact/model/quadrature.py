"""The exact centre of pressure of Drake's face-on-face contact surface, in closed form
(pure numpy, batched).

What Drake computes for two compliant boxes pressed face to face (measured with
SceneGraphInspector.maybe_get_hydroelastic_mesh on Drake 1.51 and 1.58, 1CC, 1AA and 1AAA;
the accuracy per size class, testbed/bench/size_classes.py, holds the model for every
ISO 668 series 1 type and the boxes of improved.ANSWERED_SIZE_RANGE): each box's pressure field lives on a coarse medial-axis tetrahedral mesh of 18
vertices and 44 tetrahedra, and every face of the box is the base of exactly four of
them, a fan of four triangles around the face's centre. Within the thin overlap of a
resting contact (well under a millimetre against tetrahedra a metre deep) each of those
tetrahedra is a prism over its face triangle, with a pressure that grows linearly with
depth below the face. The contact surface (kPolygon, what the plant and our labels use)
is then one polygon per pair of triangles, A's triangle i clipped by B's triangle j and
by the line where the overlap ends, with a pressure linear on each polygon (E / (H_A + H_B) times the
local overlap, H a box's half smallest extent, the depth of its tetrahedra), plus thin strips along the faces' edges where a side face's tetrahedra
take over (the slivers).

This module integrates that pressure exactly, as the labels do
(testbed.contact.surfaces.face_moments, StaticPressure.cop): each polygon's weight is the
integral of p dA and its point the integral of p x dA over it (fan triangles, closed
form); each sliver is placed at its pressure-weighted centre within the strip model. Drake's
discrete solver applies the one-point rule instead (each polygon's force at its
centroid, StaticPressure.cop_one_point), which differs from the exact integral by
centimetres to decimetres on tilted faces (a polygon 2 m^2 in area carries a single sample
of the pressure); that is a property of the solver, not of the contact surface, and is
not reproduced here. The continuum integral of the same linear pressure over the overlap
(learned_contact.model.prior) ignores the mesh (the slivers and the 45 deg clips along
the edges) and misses by about a millimetre at the median of stacking poses, several at
the 95th percentile. The answer is a function of the relative
pose alone, which is why a pose-only predictor can reproduce it: this module does, by
construction, wherever the contact is face on face.

Frames and units: A's frame; p_AB (n, 3) [m], R_AB (n, 3, 3) (columns: B's axes in A),
half extents h_A, h_B (n, 3) [m].
"""

from __future__ import annotations

import numpy as np

from learned_contact.model.clipping import clip_halfspace

# The fan: a face's four triangles join its centre to consecutive corners, corners in
# the order (+u +v), (-u +v), (-u -v), (+u -v) of the face's two in-plane axes.
_FAN = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
# Where the face-on-face answer holds (measured against Drake on held-out poses;
# learned_contact/README.md; set against the one-point rule, kept for the exact integral):
# its point to the exact centre of pressure within 1.0, 1.8 and 1.2 mm p95 over tilts of
# 5-20, 20-30 and 30-40 deg (tests/learned/test_quadrature.py, 200 held-out stacks), its normal
# to 0.1 deg p95 up to 2.5 deg (the slivers' 45 deg model loses accuracy as the faces tilt).
# Beyond, the learned pipeline answers; between, the two are blended (hand_over).
POINT_TILT = (np.radians(20.0), np.radians(30.0))  # [rad]
NORMAL_TILT = (np.radians(2.0), np.radians(4.0))  # [rad]
_MAX_VERTS = 9  # a triangle clipped by 6 half-planes keeps at most 9 vertices


def _pressure_moments(poly, count, face_level, normal_A):
    """(weight (N,) [m^3], moment (N, 3) [m^4]) of convex polygons (N, V, 3) with count (N,)
    vertices: the exact integrals of p dA and p x dA for the pressure p = half the overlap
    below A's face, face_level - x . normal_A, linear on each polygon. Fanned from the first
    vertex; a triangle (a, b, c) of area A contributes A (p_a + p_b + p_c) / 3 and
    A / 12 [(p_a + p_b + p_c)(x_a + x_b + x_c) + p_a x_a + p_b x_b + p_c x_c]
    (testbed.contact.surfaces.face_moments, the labels' rule)."""
    N, V, _ = poly.shape
    v0 = poly[:, :1]
    v1, v2 = poly[:, 1:-1], poly[:, 2:]
    ok = (np.arange(1, V - 1)[None, :] + 1) < count[:, None]
    area = 0.5 * np.linalg.norm(np.cross(v1 - v0, v2 - v0), axis=2) * ok  # (N, V-2)
    p = 0.5 * (face_level[:, None] - np.einsum("nvj,nj->nv", poly, normal_A))  # (N, V) at the vertices
    p0, p1, p2 = p[:, :1], p[:, 1:-1], p[:, 2:]
    s = p0 + p1 + p2
    weight = (area * s).sum(axis=1) / 3.0
    m = s[..., None] * (v0 + v1 + v2) + p0[..., None] * v0 + p1[..., None] * v1 + p2[..., None] * v2
    moment = np.einsum("nt,ntj->nj", area, m) / 12.0
    return weight, moment


def faces(p_AB, R_AB, h_A, h_B, n_AB):
    """The two faces that meet for contact normal n_AB (n, 3) (unit, A->B, in A).

    Returns (a (n,) A's face axis, sigma_A (n,) its side (+-1, A's face normal is
    sigma_A e_a), m (n,) B's face axis, s_B (n,) its side (B's face normal, s_B b_m,
    points towards A))."""
    rows = np.arange(len(p_AB))
    a = np.argmax(np.abs(n_AB), axis=1)
    sigma_A = np.where(n_AB[rows, a] >= 0.0, 1.0, -1.0)
    along = np.einsum("nj,njm->nm", n_AB, R_AB)  # n . b_m
    m = np.argmax(np.abs(along), axis=1)
    s_B = np.where(along[rows, m] > 0.0, -1.0, 1.0)
    return a, sigma_A, m, s_B


def face_on_face(p_AB, R_AB, h_A, h_B, n_AB):
    """The exact centre of pressure and the normal of B's face pressed on A's face (module docstring).

    p_AB (n, 3) [m], R_AB (n, 3, 3), h_A, h_B (n, 3) [m], n_AB (n, 3) unit A->B: picks the
    faces (`faces`). Returns (point (n, 3) [m] in A, on the equal-pressure surface;
    normal (n, 3) unit A->B, the equal-pressure surface's (grad p_B - grad p_A: the bisector of
    the two faces' normals where both fields rise as fast, i.e. both boxes' smallest extents are
    equal, as for every pair of full-height ISO boxes, whose tetrahedra are a half width deep; a
    half height's field rises twice as fast); weight (n,) [m^3] the integral of the pressure (in
    units of E / (H_A + H_B): half the overlap for equal fields) over the polygons and the slivers,
    0 where the faces do not overlap)."""
    n = len(p_AB)
    rows = np.arange(n)
    a, sigma_A, m, s_B = faces(p_AB, R_AB, h_A, h_B, n_AB)
    # Each field rises at E / H with depth, H its box's half smallest extent (the tetrahedra's depth): the
    # equal-pressure surface lies f_A of the local overlap below A's face and f_B above B's (one half each
    # for two boxes of one smallest extent, every pair of full-height ISO boxes; a half height on a full
    # height box: 0.35 / 0.65). ratio_AB = H_A / H_B tilts the normals (1.0 exactly for equal fields).
    H_A, H_B = h_A.min(axis=1), h_B.min(axis=1)
    f_A, f_B = H_A / (H_A + H_B), H_B / (H_A + H_B)
    ratio_AB, ratio_BA = H_A / H_B, H_B / H_A
    u_A, v_A = (a + 1) % 3, (a + 2) % 3
    e = np.eye(3)
    top = (sigma_A * h_A[rows, a])[:, None] * e[a]  # (n, 3) A's face centre
    cA = top[:, None, :] + (_FAN[None, :, 0, None] * h_A[rows, u_A][:, None, None] * e[u_A][:, None, :]
                            + _FAN[None, :, 1, None] * h_A[rows, v_A][:, None, None] * e[v_A][:, None, :])  # (n, 4, 3)
    b = np.swapaxes(R_AB, 1, 2)  # rows: B's axes in A
    u_B, v_B = (m + 1) % 3, (m + 2) % 3
    centre_B = p_AB + (s_B * h_B[rows, m])[:, None] * b[rows, m]
    cB = centre_B[:, None, :] + (_FAN[None, :, 0, None] * h_B[rows, u_B][:, None, None] * b[rows, u_B][:, None, :]
                                 + _FAN[None, :, 1, None] * h_B[rows, v_B][:, None, None] * b[rows, v_B][:, None, :])
    # 16 polygons per pair: B's triangle j (centre, corner j, corner j+1), clipped by the
    # three sides of A's triangle i (planes along A's face normal) and by A's face plane.
    nxt = [1, 2, 3, 0]
    poly = np.zeros((n, 4, 4, _MAX_VERTS, 3))
    poly[:, :, :, 0] = centre_B[:, None, None, :]
    poly[:, :, :, 1] = cB[:, None, :, :]
    poly[:, :, :, 2] = cB[:, None, nxt, :]
    poly = poly.reshape(16 * n, _MAX_VERTS, 3)
    count = np.full(16 * n, 3)
    normal_A = sigma_A[:, None] * e[a]  # (n, 3)
    tri = np.stack([np.broadcast_to(top[:, None, :], cA.shape), cA, cA[:, nxt]], axis=2)  # (n, 4 i, 3 verts, 3)
    for k in range(3):
        p0, p1 = tri[:, :, k], tri[:, :, (k + 1) % 3]
        opposite = tri[:, :, (k + 2) % 3]
        out = np.cross(p1 - p0, normal_A[:, None, :])  # in the face plane, perpendicular to the side
        flip = np.where(np.einsum("nij,nij->ni", out, opposite - p0) > 0.0, -1.0, 1.0)
        out = out * flip[:, :, None]  # pointing away from the triangle
        limit = np.einsum("nij,nij->ni", out, p0)
        nrm = np.repeat(out[:, :, None, :], 4, axis=2).reshape(16 * n, 3)
        lim = np.repeat(limit[:, :, None], 4, axis=2).reshape(16 * n)
        poly, count = clip_halfspace(poly, count, nrm, lim)
    face_level = h_A[rows, a]  # A's face along normal_A
    poly, count = clip_halfspace(poly, count, np.repeat(normal_A, 16, axis=0), np.repeat(face_level, 16))
    # Near an outer edge of either face, within its share of the local overlap (f_B for B's
    # edges, f_A for A's) of it, the side face's tetrahedra take over (their 45 deg boundary runs
    # from the edge to the medial axis): o(x) f - inward distance from the edge <= 0 keeps the
    # face's own part.
    for e0, e1, centre, f in ((cB[:, None, :, :], cB[:, None, nxt, :], centre_B, f_B),
                              (cA[:, :, None, :], cA[:, nxt, None, :], top, f_A)):
        e0, e1 = np.broadcast_to(e0, (n, 4, 4, 3)), np.broadcast_to(e1, (n, 4, 4, 3))
        w_in = _inward(e0, e1, centre, normal_A)  # (n, 4, 4, 3)
        g = -(f[:, None, None, None] * normal_A[:, None, None, :] + w_in)
        c = -(f[:, None, None] * face_level[:, None, None] + np.einsum("nijk,nijk->nij", w_in, e0))
        poly, count = clip_halfspace(poly, count, g.reshape(16 * n, 3), c.reshape(16 * n))
    # the pressure (in units of E / (H_A + H_B): half the overlap for equal fields), linear on each polygon
    w, moment = _pressure_moments(poly, count, np.repeat(face_level, 16), np.repeat(normal_A, 16, axis=0))
    w, moment = w.reshape(n, 16), moment.reshape(n, 16, 3)
    n_Bout = s_B[:, None] * b[rows, m]  # (n, 3) B's face normal, towards A
    main_normal = ratio_BA[:, None] * normal_A - n_Bout  # grad p_B - grad p_A, scaled by H_B / E
    main_normal /= np.linalg.norm(main_normal, axis=1, keepdims=True)
    # The slivers: along an edge of a face, inside the overlap, the other box's field
    # meets the field of the side face's tetrahedra (pressure rising from the side face):
    # a strip half the local overlap wide, on a 45 deg surface, one polygon per pair of
    # triangles. B's bottom edges first (B's triangle j's outer side, clipped by A's
    # triangle i), then A's top edges (A's triangle i's outer side, clipped by B's j).
    tri_B = np.stack([np.broadcast_to(centre_B[:, None, :], cB.shape), cB, cB[:, nxt]], axis=2)  # (n, 4 j, 3, 3)
    depth_of = lambda x: face_level[:, None, None] - np.einsum("nijk,nk->nij", x, normal_A)  # noqa: E731
    facing = np.maximum(-np.einsum("nk,nk->n", n_Bout, normal_A), 1e-6)  # cos of the tilt (> 0 where it counts)
    depth_B_at = lambda x: np.einsum("nk,nijk->nij", n_Bout, centre_B[:, None, None, :] - x) / facing[:, None, None]  # noqa: E731
    edge_B0 = np.broadcast_to(cB[:, None, :, :], (n, 4, 4, 3))  # [n, i, j]
    edge_B1 = np.broadcast_to(cB[:, None, nxt, :], (n, 4, 4, 3))
    edge_A0 = np.broadcast_to(cA[:, :, None, :], (n, 4, 4, 3))
    edge_A1 = np.broadcast_to(cA[:, nxt, None, :], (n, 4, 4, 3))
    sliver_w, sliver_c, sliver_n = [], [], []
    R_BA = np.swapaxes(R_AB, 1, 2)

    def _inside_other_face(x, own):
        """(n, 4, 4) [m] how far points x (n, 4, 4, 3) on one face's edge lie inside the other
        face's rectangle (its distance to the rectangle's border, < 0 outside): A's face for
        B's edges, B's face for A's."""
        if own == "B":
            q, h, ax_u, ax_v = x, h_A, u_A, v_A
        else:  # x in B's frame
            q, h, ax_u, ax_v = np.einsum("nkj,nabj->nabk", R_BA, x - p_AB[:, None, None, :]), h_B, u_B, v_B
        qu = np.take_along_axis(q, ax_u[:, None, None, None], axis=3)[..., 0]
        qv = np.take_along_axis(q, ax_v[:, None, None, None], axis=3)[..., 0]
        return np.minimum(h[rows, ax_u][:, None, None] - np.abs(qu), h[rows, ax_v][:, None, None] - np.abs(qv))
    for e0, e1, clip_tri, inward_centre, local_depth, own, f_own, ratio in (
            (edge_B0, edge_B1, tri[:, :, None], centre_B, depth_of, "B", f_B, ratio_AB),
            (edge_A0, edge_A1, tri_B[:, None, :], top, depth_B_at, "A", f_A, ratio_BA)):
        t0, t1 = np.zeros((n, 4, 4)), np.ones((n, 4, 4))
        planes = [(lambda x, k=k, tri=clip_tri: _side_value(tri, k, normal_A, x)) for k in range(3)]
        planes.append(lambda x, depth=local_depth: -depth(x))  # inside the overlap: depth >= 0
        for f in planes:
            s0, s1 = f(e0), f(e1)
            t_cross = s0 / np.where(s0 - s1 == 0.0, 1.0, s0 - s1)
            t0 = np.where((s0 > 0.0) & (s1 <= 0.0), np.maximum(t0, t_cross), t0)
            t1 = np.where((s0 <= 0.0) & (s1 > 0.0), np.minimum(t1, t_cross), t1)
            t1 = np.where((s0 > 0.0) & (s1 > 0.0), -1.0, t1)  # wholly outside
        ok = t1 > t0
        x0 = e0 + t0[..., None] * (e1 - e0)
        x1 = e0 + t1[..., None] * (e1 - e0)
        f3 = f_own[:, None, None]
        h0 = f3 * np.maximum(local_depth(x0), 0.0)  # the strip's width at each end [m]: its box's share
        h1 = f3 * np.maximum(local_depth(x1), 0.0)
        length = np.linalg.norm(x1 - x0, axis=-1) * ok
        hsum = np.where(h0 + h1 > 0.0, h0 + h1, 1.0)
        # the strip's surface rises the other box's share over its own (45 deg for equal fields), and the
        # pressure across it, y / (2 f_own) in the polygons' units, is y for equal fields
        rise = ratio[:, None, None]
        area_s = np.sqrt(1.0 + rise * rise) * length * 0.5 * (h0 + h1) * (0.5 / f3)
        h2 = h0 * h0 + h0 * h1 + h1 * h1
        y_bar = h2 / (3.0 * hsum)  # strip centroid's distance from the edge
        along = (h0 + 2.0 * h1) / (3.0 * hsum)
        x_c = x0 + along[..., None] * (x1 - x0)
        # the strip's centre of pressure: the pressure rises linearly across the strip (0 on the
        # edge, y at a distance y from it) and the width h(t) linearly along it, so the weight per
        # unit length goes as h(t)^2: from the edge int h^3 / 3 dt / int h^2 / 2 dt, along the edge
        # int t h^2 dt / int h^2 dt (the area centroid x_c, y_bar instead: 2-3 times the point
        # error against the exact labels at the median and p95 of stacking poses)
        h2 = np.where(h2 > 0.0, h2, 1.0)
        y_p = hsum * (h0 * h0 + h1 * h1) / (2.0 * h2)
        x_s = x0 + ((h0 * h0 + 2.0 * h0 * h1 + 3.0 * h1 * h1) / (4.0 * h2))[..., None] * (x1 - x0)
        direction = inward_centre[:, None, None, :] - x_c
        direction = direction - np.einsum("nijk,nk->nij", direction, normal_A)[..., None] * normal_A[:, None, None, :]
        # inward: perpendicular to the edge, towards the face's centre
        edge = (e1 - e0) / np.maximum(np.linalg.norm(e1 - e0, axis=-1, keepdims=True), 1e-12)
        direction = direction - np.einsum("nijk,nijk->nij", direction, edge)[..., None] * edge
        direction /= np.maximum(np.linalg.norm(direction, axis=-1, keepdims=True), 1e-12)
        # Where this edge runs within one overlap of the other face's edge (stacked boxes of
        # one footprint: the two edges coincide) the side fields of both boxes meet and the
        # strip model does not hold; the strip fades from whole, one overlap inside the
        # other face, to nothing on its edge, so that the answer stays continuous as one
        # edge crosses the other (B's strip hands over to A's; a step of the slivers' whole
        # weight otherwise: 0.14 deg of normal at 1 cm of overlap).
        inside = _inside_other_face(x_c, own)
        o_c = np.maximum(local_depth(x_c), 0.0)
        u = np.clip(inside / np.where(o_c > 0.0, o_c, 1.0), 0.0, 1.0)
        sliver_w.append(area_s * y_bar * (u * u * (3.0 - 2.0 * u)))
        sliver_c.append(x_s + y_p[..., None] * direction)
        if own == "B":  # B's side face's inward normal lies in B's face plane
            w_B = direction - np.einsum("nijk,nk->nij", direction, n_Bout)[..., None] * n_Bout[:, None, None, :]
            w_B /= np.maximum(np.linalg.norm(w_B, axis=-1, keepdims=True), 1e-12)
            sliver_n.append(normal_A[:, None, None, :] + ratio_AB[:, None, None, None] * w_B)
        else:
            sliver_n.append(-ratio_BA[:, None, None, None] * direction - n_Bout[:, None, None, :])
    w_all = np.concatenate([w, sliver_w[0].reshape(n, 16), sliver_w[1].reshape(n, 16)], axis=1)  # (n, 48)
    weight = w_all.sum(axis=1)
    safe = np.where(weight > 0.0, weight, 1.0)
    point = (moment.sum(axis=1) + np.einsum("nk,nkj->nj", sliver_w[0].reshape(n, 16), sliver_c[0].reshape(n, 16, 3))
             + np.einsum("nk,nkj->nj", sliver_w[1].reshape(n, 16), sliver_c[1].reshape(n, 16, 3))) / safe[:, None]
    # the polygons' pressure-weighted mean overlap: face_level - (their first moment . normal_A) / their weight
    w_main = w.sum(axis=1)
    depth_at = np.where(w_main > 0.0, face_level - np.einsum("nj,nj->n", moment.sum(axis=1), normal_A)
                        / np.where(w_main > 0.0, w_main, 1.0), 0.0)
    point = point - np.einsum("nj,nj->n", point, normal_A)[:, None] * normal_A + (face_level - f_A * depth_at)[:, None] * normal_A
    n_sl = [v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300) for v in sliver_n]  # 0 stays 0
    direction = (w[:, :, None] * main_normal[:, None, :]).sum(axis=1) + sum(
        (sw[..., None] * v).reshape(n, 16, 3).sum(axis=1) for sw, v in zip(sliver_w, n_sl))
    normal = direction / np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-300)
    normal = np.where(weight[:, None] > 0.0, normal, main_normal)
    tilt = np.arccos(np.clip(np.abs(R_AB[rows, a, m]), 0.0, 1.0))
    return point, normal, weight, tilt


def hand_over(tilt, band) -> np.ndarray:
    """(n,) weight of the face-on-face answer for tilts (n,) [rad] between the two faces:
    1 up to band[0], 0 from band[1] on, a C1 smoothstep between (band in [rad])."""
    u = np.clip((np.asarray(tilt) - band[0]) / (band[1] - band[0]), 0.0, 1.0)
    return 1.0 - u * u * (3.0 - 2.0 * u)


def _side_value(tri, k, normal_A, x):
    """Signed distance-like value of points x (n, 4, 4, 3) from side k of triangles tri
    (n, 4|1, 4|1, 3 verts, 3), measured in A's face plane: <= 0 inside."""
    p0, p1, opp = tri[..., k, :], tri[..., (k + 1) % 3, :], tri[..., (k + 2) % 3, :]
    out = np.cross(p1 - p0, normal_A[:, None, None, :])
    flip = np.where(np.einsum("nijk,nijk->nij", out, opp - p0) > 0.0, -1.0, 1.0)
    return flip * np.einsum("nijk,nijk->nij", out, x - p0)


def _inward(e0, e1, centre, normal_A):
    """(n, 4, 4, 3) unit vectors in A's face plane, perpendicular to the edges e0 -> e1
    (n, 4, 4, 3), pointing towards the face centre (n, 3)."""
    d = centre[:, None, None, :] - e0
    d = d - np.einsum("nijk,nk->nij", d, normal_A)[..., None] * normal_A[:, None, None, :]
    edge = e1 - e0
    edge = edge - np.einsum("nijk,nk->nij", edge, normal_A)[..., None] * normal_A[:, None, None, :]
    edge = edge / np.maximum(np.linalg.norm(edge, axis=-1, keepdims=True), 1e-12)
    d = d - np.einsum("nijk,nijk->nij", d, edge)[..., None] * edge
    return d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-12)
