"""The face-on-face quadrature's graph: learned_contact.model.quadrature.face_on_face,
operation for operation, batched: the 16 polygons of a pair (A's triangle i x B's triangle
j, row 16 k + 4 i + j) are clipped together as one (16 n, MAX_VERTS, 3) batch, the 32
sliver strips as (n, 4, 4) arrays. Shapes, frames and units as onnx_prior.py: p (n, 3) [m]
B's centre in A, R (n, 3, 3), hA, hB (n, 3) half extents [m]; computed in `g.dt` (float64
for the improved predictor; onnxruntime's CPU provider has float64 kernels for every
operator used here but Acos, which `acos01` runs in float32 and refines in float64).
"""

from __future__ import annotations

import numpy as np

from learned_contact.export.onnx_blocks import NEXT, NEXT2, Graph, batch_shape, cross, dot, norm, onnx_type, transpose
from learned_contact.export.onnx_prior import MAX_VERTS, clip_halfspace

_FAN = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])  # quadrature._FAN
_FAN_NEXT = [1, 2, 3, 0]  # the next corner of a face's fan


def pressure_moments(g: Graph, poly, count, face_level, nA):
    """quadrature._pressure_moments: (weight (N, 1) [m^3], moment (N, 3) [m^4]) of convex
    polygons poly (N, V, 3) with count (N, 1) vertices, the exact integrals of p dA and p x dA
    for p = (face_level (N, 1) - x . nA (N, 3)) / 2 (fan triangles from the first vertex)."""
    V = MAX_VERTS
    v0 = g.take(poly, [0], 1)
    v1, v2 = g.take(poly, list(range(1, V - 1)), 1), g.take(poly, list(range(2, V)), 1)
    ok = g.op("Cast", g.op("Less", g.i(np.arange(2, V)[None, :]), count), to=onnx_type(g.dt))
    area = g.mul(g.mul(g.f(0.5), norm(g, cross(g, g.sub(v1, v0), g.sub(v2, v0)), keep=0)), ok)  # (N, V - 2)
    p = g.mul(g.f(0.5), g.sub(face_level, dot(g, poly, g.unsq(nA, [1]))))  # (N, V) at the vertices
    p0, p1, p2 = g.take(p, [0], 1), g.take(p, list(range(1, V - 1)), 1), g.take(p, list(range(2, V)), 1)
    s = g.add(g.add(p0, p1), p2)  # (N, V - 2)
    weight = g.div(g.rsum(g.mul(area, s), 1, keep=1), g.f(3.0))
    u = lambda x: g.unsq(x, [2])  # noqa: E731
    m = g.add(g.add(g.add(g.mul(u(s), g.add(g.add(v0, v1), v2)), g.mul(u(p0), v0)), g.mul(u(p1), v1)), g.mul(u(p2), v2))
    moment = g.div(g.rsum(g.mul(u(area), m), 1), g.f(12.0))
    return weight, moment


def _inward(g: Graph, e0, e1, centre, nA):
    """quadrature._inward: unit vectors in A's face plane (normal nA (n, 1, 3)), perpendicular
    to the edges e0 -> e1 (n, 4, 3), towards centre (n, 1, 3)."""
    d = g.sub(centre, e0)
    d = g.sub(d, g.mul(dot(g, d, nA, 1), nA))
    edge = g.sub(e1, e0)
    edge = g.sub(edge, g.mul(dot(g, edge, nA, 1), nA))
    edge = g.div(edge, g.op("Max", norm(g, edge), g.f(1e-12)))
    d = g.sub(d, g.mul(dot(g, d, edge, 1), edge))
    return g.div(d, g.op("Max", norm(g, d), g.f(1e-12)))


def _sides(g: Graph, tri, nA):
    """The three sides of triangles tri (n, 4, 3 verts, 3) in A's face plane (normal nA
    (n, 1, 1, 3)): (p0 (n, 4, 3 sides, 3) each side's first vertex, out (n, 4, 3, 3) the
    side's in-plane perpendicular cross(p1 - p0, nA), flip (n, 4, 3, 1) -1 where out points
    into the triangle, else 1), as quadrature's loop over k and _side_value compute them."""
    p1, opp = g.take(tri, [1, 2, 0], 2), g.take(tri, [2, 0, 1], 2)
    out = cross(g, g.sub(p1, tri), nA)
    flip = g.where(g.op("Greater", dot(g, out, g.sub(opp, tri), 1), g.f(0.0)), g.f(-1.0), g.f(1.0))
    return tri, out, flip


def acos01(g: Graph, c):
    """arccos of c in [0, 1] (self.dt float64: onnxruntime has no float64 Acos): the float32
    Acos refined by two Newton steps t += (cos t - c) / sin t in float64, started at 1e-3
    rad at least (a true angle below that is answered below 1e-3 rad, where only whether
    it lies below a hand-over band matters). Measured against np.arccos on 400,000 angles:
    within 7.4e-15 rad from 1.5 to 31 deg (the hand-over bands), 8.4e-11 rad from 1e-3 rad."""
    f32 = onnx_type(np.float32)
    t = g.op("Cast", g.op("Acos", g.op("Cast", c, to=f32)), to=onnx_type(g.dt))
    t = g.op("Max", t, g.f(1e-3))
    for _ in range(2):
        t = g.add(t, g.div(g.sub(g.op("Cos", t), c), g.op("Sin", t)))
    return t


def face_on_face(g: Graph, p, R, hA, hB, n_AB):
    """quadrature.face_on_face (faces() included): (point (n, 3) [m] in A, normal (n, 3)
    unit A->B, weight (n, 1) [m^3], tilt (n, 1) [rad]) of B's face pressed on A's face, for
    contact normals n_AB (n, 3) (unit, A->B, in A); p (n, 3) [m], R (n, 3, 3), hA, hB (n, 3) [m]."""
    dt = onnx_type(g.dt)
    one, zero = g.f(1.0), g.f(0.0)
    # faces(): A's face axis a and side sigma_A, B's face axis m and side s_B
    a = g.op("ArgMax", g.op("Abs", n_AB), axis=1, keepdims=1)
    sigma_A = g.where(g.op("GreaterOrEqual", g.vec_at(n_AB, a), zero), one, g.f(-1.0))
    along = g.sq(g.op("MatMul", g.unsq(n_AB, [1]), R), [1])  # (n, 3) n . b_m
    m = g.op("ArgMax", g.op("Abs", along), axis=1, keepdims=1)
    s_B = g.where(g.op("Greater", g.vec_at(along, m), zero), g.f(-1.0), one)
    # the two fans' corners: A's face centre `top` and corners cA (n, 4, 3); B's centre_B, cB
    fan0, fan1 = g.f(_FAN[None, :, 0, None]), g.f(_FAN[None, :, 1, None])  # (1, 4, 1)

    def fan(centre, du, dv):
        return g.add(g.unsq(centre, [1]), g.add(g.mul(fan0, g.unsq(du, [1])), g.mul(fan1, g.unsq(dv, [1]))))

    u_A, v_A = g.op("Gather", g.i(NEXT), a), g.op("Gather", g.i(NEXT2), a)
    e_a, e_u, e_v = (g.onehot(k, 3, dtype=g.dt) for k in (a, u_A, v_A))  # rows of np.eye(3)
    face_level = g.vec_at(hA, a)  # (n, 1) A's face along normal_A
    # each box's share of the overlap (quadrature.face_on_face: f_A, f_B, ratio_AB, ratio_BA), (n, 1)
    H_A, H_B = g.rmin(hA, 1, keep=1), g.rmin(hB, 1, keep=1)
    H_sum = g.add(H_A, H_B)
    f_A, f_B = g.div(H_A, H_sum), g.div(H_B, H_sum)
    ratio_AB, ratio_BA = g.div(H_A, H_B), g.div(H_B, H_A)
    top = g.mul(g.mul(sigma_A, face_level), e_a)
    cA = fan(top, g.mul(g.vec_at(hA, u_A), e_u), g.mul(g.vec_at(hA, v_A), e_v))
    b = transpose(g, R)  # rows: B's axes in A
    u_B, v_B = g.op("Gather", g.i(NEXT), m), g.op("Gather", g.i(NEXT2), m)
    b_m = g.row_at(b, m)
    centre_B = g.add(p, g.mul(g.mul(s_B, g.vec_at(hB, m)), b_m))
    cB = fan(centre_B, g.mul(g.vec_at(hB, u_B), g.row_at(b, u_B)), g.mul(g.vec_at(hB, v_B), g.row_at(b, v_B)))
    cA_next, cB_next = g.take(cA, _FAN_NEXT, 1), g.take(cB, _FAN_NEXT, 1)
    normal_A = g.mul(sigma_A, e_a)  # (n, 3)
    nA3, nA4 = g.unsq(normal_A, [1]), g.unsq(normal_A, [1, 2])  # (n, 1, 3), (n, 1, 1, 3)
    four = batch_shape(g, p, [4, 1, 3])
    tri_A = g.op("Concat", g.op("Expand", g.unsq(top, [1, 2]), four), g.unsq(cA, [2]), g.unsq(cA_next, [2]), axis=2)
    tri_B = g.op("Concat", g.op("Expand", g.unsq(centre_B, [1, 2]), four), g.unsq(cB, [2]), g.unsq(cB_next, [2]),
                 axis=2)  # (n, 4, 3 verts, 3)
    # 16 polygons per pair, row 16 pair + 4 i + j: B's triangle j (centre, corner j, corner j + 1)
    pad = g.op("Expand", g.f(np.zeros((1, 1, MAX_VERTS - 3, 3))), batch_shape(g, p, [4, MAX_VERTS - 3, 3]))
    poly = g.op("Concat", tri_B, pad, axis=2)  # (n, 4 j, V, 3)
    poly = g.reshape(g.op("Expand", g.unsq(poly, [1]), batch_shape(g, p, [4, 4, MAX_VERTS, 3])), [-1, MAX_VERTS, 3])
    count = g.op("Expand", g.i([[3]]), batch_shape(g, poly, [1]))  # (16 n, 1)
    # clipped by the three sides of A's triangle i (planes along A's face normal)
    p0_A, out_A, flip_A = _sides(g, tri_A, nA4)
    normal_i = g.mul(out_A, flip_A)  # (n, 4 i, 3 sides, 3) pointing away from the triangle
    limit_i = dot(g, normal_i, p0_A)  # (n, 4 i, 3 sides)
    shape16_3, shape16 = batch_shape(g, p, [4, 4, 3]), batch_shape(g, p, [4, 4])
    for k in range(3):
        nrm = g.reshape(g.op("Expand", g.unsq(g.sq(g.take(normal_i, [k], 2), [2]), [2]), shape16_3), [-1, 3])
        lim = g.reshape(g.op("Expand", g.take(limit_i, [k], 2), shape16), [-1, 1])
        poly, count = clip_halfspace(g, poly, count, nrm, lim)
    # by A's face plane
    poly, count = clip_halfspace(g, poly, count, g.reshape(g.op("Expand", nA4, shape16_3), [-1, 3]),
                                 g.reshape(g.op("Expand", g.unsq(face_level, [2]), shape16), [-1, 1]))
    # by the 45 deg trims along the outer edges of B's face (edge j), then of A's face (edge i), at
    # each box's share of the overlap
    for e0, e1, centre, axis, share in ((cB, cB_next, centre_B, 1, f_B), (cA, cA_next, top, 2, f_A)):
        w_in = _inward(g, e0, e1, g.unsq(centre, [1]), nA3)  # (n, 4, 3)
        gvec = g.op("Neg", g.add(g.mul(g.unsq(share, [2]), nA3), w_in))
        c = g.op("Neg", g.add(g.mul(share, face_level), dot(g, w_in, e0)))  # (n, 4)
        nrm = g.reshape(g.op("Expand", g.unsq(gvec, [axis]), shape16_3), [-1, 3])
        lim = g.reshape(g.op("Expand", g.unsq(c, [axis]), shape16), [-1, 1])
        poly, count = clip_halfspace(g, poly, count, nrm, lim)
    # the pressure (E / (H_A + H_B) times the overlap below A's face, linear on each polygon) integrated exactly
    w, moment = pressure_moments(g, poly, count, g.reshape(g.op("Expand", g.unsq(face_level, [2]), shape16), [-1, 1]),
                                 g.reshape(g.op("Expand", nA4, shape16_3), [-1, 3]))
    w, moment = g.reshape(w, [-1, 16]), g.reshape(moment, [-1, 16, 3])
    n_Bout = g.mul(s_B, b_m)  # (n, 3) B's face normal, towards A
    main_normal = g.sub(g.mul(ratio_BA, normal_A), n_Bout)
    main_normal = g.div(main_normal, norm(g, main_normal))
    # the slivers, (n, 4 i, 4 j) each: B's edges j clipped by A's triangles i, then A's edges i
    # clipped by B's triangles j
    nB4 = g.unsq(n_Bout, [1, 2])
    fl3 = g.unsq(face_level, [2])  # (n, 1, 1)
    facing = g.unsq(g.op("Max", g.op("Neg", dot(g, n_Bout, normal_A, 1)), g.f(1e-6)), [2])  # (n, 1, 1)
    centre_B4 = g.unsq(centre_B, [1, 2])

    def depth_of(x):
        return g.sub(fl3, dot(g, x, nA4))

    def depth_B_at(x):
        return g.div(dot(g, nB4, g.sub(centre_B4, x)), facing)

    p0_B, out_B, flip_B = _sides(g, tri_B, nA4)
    edge_B0, edge_B1 = (g.op("Expand", g.unsq(x, [1]), shape16_3) for x in (cB, cB_next))
    edge_A0, edge_A1 = (g.op("Expand", g.unsq(x, [2]), shape16_3) for x in (cA, cA_next))
    e_u4, e_v4 = g.unsq(e_u, [1, 2]), g.unsq(e_v, [1, 2])  # (n, 1, 1, 3)
    b_u4, b_v4 = g.unsq(g.row_at(b, u_B), [1, 2]), g.unsq(g.row_at(b, v_B), [1, 2])
    hA_u3, hA_v3 = g.unsq(g.vec_at(hA, u_A), [2]), g.unsq(g.vec_at(hA, v_A), [2])  # (n, 1, 1)
    hB_u3, hB_v3 = g.unsq(g.vec_at(hB, u_B), [2]), g.unsq(g.vec_at(hB, v_B), [2])
    slivers = []
    for e0, e1, sides, axis, inward_centre, local_depth, own, share, ratio in (
            (edge_B0, edge_B1, (p0_A, out_A, flip_A), 2, centre_B, depth_of, "B", f_B, ratio_AB),
            (edge_A0, edge_A1, (p0_B, out_B, flip_B), 1, top, depth_B_at, "A", f_A, ratio_BA)):
        share3, ratio3 = g.unsq(share, [2]), g.unsq(ratio, [2])  # (n, 1, 1)
        t0 = g.op("Expand", g.f(np.zeros((1, 1, 1))), shape16)
        t1 = g.op("Expand", g.f(np.ones((1, 1, 1))), shape16)
        planes = []
        for k in range(3):  # quadrature._side_value: flip * out . (x - p0), the clipping triangle's side k
            p0k, outk, flipk = (g.unsq(g.sq(g.take(x, [k], 2), [2]), [axis]) for x in sides)  # (n, 4|1, 1|4, 3|1)
            planes.append(lambda x, p0k=p0k, outk=outk, flipk=flipk: g.mul(g.sq(flipk, [3]), dot(g, outk, g.sub(x, p0k))))
        planes.append(lambda x, local_depth=local_depth: g.op("Neg", local_depth(x)))  # inside the overlap
        for f in planes:
            s0, s1 = f(e0), f(e1)
            diff = g.sub(s0, s1)
            t_cross = g.div(s0, g.where(g.op("Equal", diff, zero), one, diff))
            pos0, pos1 = g.op("Greater", s0, zero), g.op("Greater", s1, zero)
            t0 = g.where(g.op("And", pos0, g.op("Not", pos1)), g.op("Max", t0, t_cross), t0)
            t1 = g.where(g.op("And", g.op("Not", pos0), pos1), g.op("Min", t1, t_cross), t1)
            t1 = g.where(g.op("And", pos0, pos1), g.f(-1.0), t1)  # wholly outside
        ok = g.op("Cast", g.op("Greater", t1, t0), to=dt)
        span = g.sub(e1, e0)
        x0 = g.add(e0, g.mul(g.unsq(t0, [3]), span))
        x1 = g.add(e0, g.mul(g.unsq(t1, [3]), span))
        h0 = g.mul(share3, g.op("Max", local_depth(x0), zero))  # the strip's width at each end [m]
        h1 = g.mul(share3, g.op("Max", local_depth(x1), zero))
        length = g.mul(norm(g, g.sub(x1, x0), keep=0), ok)
        hh = g.add(h0, h1)
        hsum3 = g.mul(g.f(3.0), g.where(g.op("Greater", hh, zero), hh, one))
        rise = g.op("Sqrt", g.add(one, g.mul(ratio3, ratio3)))  # sqrt 2 for equal fields
        area_s = g.mul(g.mul(g.mul(g.mul(rise, length), g.f(0.5)), hh), g.div(g.f(0.5), share3))
        h2 = g.add(g.add(g.mul(h0, h0), g.mul(h0, h1)), g.mul(h1, h1))
        y_bar = g.div(h2, hsum3)
        along_t = g.div(g.add(h0, g.mul(g.f(2.0), h1)), hsum3)
        x_c = g.add(x0, g.mul(g.unsq(along_t, [3]), g.sub(x1, x0)))
        # the strip's centre of pressure (quadrature.face_on_face: y_p, x_s)
        h2 = g.where(g.op("Greater", h2, zero), h2, one)
        hsum = g.where(g.op("Greater", hh, zero), hh, one)
        y_p = g.div(g.mul(hsum, g.add(g.mul(h0, h0), g.mul(h1, h1))), g.mul(g.f(2.0), h2))
        along_p = g.div(g.add(g.add(g.mul(h0, h0), g.mul(g.mul(g.f(2.0), h0), h1)), g.mul(g.mul(g.f(3.0), h1), h1)),
                        g.mul(g.f(4.0), h2))
        x_s = g.add(x0, g.mul(g.unsq(along_p, [3]), g.sub(x1, x0)))
        direction = g.sub(g.unsq(inward_centre, [1, 2]), x_c)
        direction = g.sub(direction, g.mul(dot(g, direction, nA4, 1), nA4))
        edge = g.div(span, g.op("Max", norm(g, span), g.f(1e-12)))
        direction = g.sub(direction, g.mul(dot(g, direction, edge, 1), edge))
        direction = g.div(direction, g.op("Max", norm(g, direction), g.f(1e-12)))
        # the fade where this edge runs within one overlap of the other face's edge
        # (quadrature.face_on_face: _inside_other_face, smoothstep of inside / overlap)
        if own == "B":  # inside A's face rectangle, in A's frame
            qu, qv, hu, hv = dot(g, x_c, e_u4), dot(g, x_c, e_v4), hA_u3, hA_v3
        else:  # inside B's face rectangle, in B's frame
            rel = g.sub(x_c, g.unsq(p, [1, 2]))
            qu, qv, hu, hv = dot(g, rel, b_u4), dot(g, rel, b_v4), hB_u3, hB_v3
        inside = g.op("Min", g.sub(hu, g.op("Abs", qu)), g.sub(hv, g.op("Abs", qv)))
        o_c = g.op("Max", local_depth(x_c), zero)
        u_f = g.clip(g.div(inside, g.where(g.op("Greater", o_c, zero), o_c, one)), zero, one)
        fade = g.mul(g.mul(u_f, u_f), g.sub(g.f(3.0), g.mul(g.f(2.0), u_f)))
        weight_s = g.mul(g.mul(area_s, y_bar), fade)
        centre_s = g.add(x_s, g.mul(g.unsq(y_p, [3]), direction))
        if own == "B":  # B's side face's inward normal lies in B's face plane
            w_B = g.sub(direction, g.mul(dot(g, direction, nB4, 1), nB4))
            w_B = g.div(w_B, g.op("Max", norm(g, w_B), g.f(1e-12)))
            normal_s = g.add(nA4, g.mul(g.unsq(ratio3, [3]), w_B))
        else:
            normal_s = g.sub(g.mul(g.op("Neg", g.unsq(ratio3, [3])), direction), nB4)
        slivers.append((g.reshape(weight_s, [-1, 16]), g.reshape(centre_s, [-1, 16, 3]),
                        g.reshape(g.div(normal_s, g.op("Max", norm(g, normal_s), g.f(1e-300))), [-1, 16, 3])))
    (wB, cB_s, nB_s), (wA, cA_s, nA_s) = slivers
    w_all = g.op("Concat", w, wB, wA, axis=1)  # (n, 48)
    weight = g.rsum(w_all, 1, keep=1)
    safe = g.where(g.op("Greater", weight, zero), weight, one)
    sliver_moment = g.rsum(g.mul(g.unsq(g.op("Concat", wB, wA, axis=1), [2]), g.op("Concat", cB_s, cA_s, axis=1)), 1)
    moment_sum = g.rsum(moment, 1)  # (n, 3)
    point = g.div(g.add(moment_sum, sliver_moment), safe)
    # the polygons' pressure-weighted mean overlap
    w_sum = g.rsum(w, 1, keep=1)
    main_meet = g.op("Greater", w_sum, zero)
    depth_at = g.where(main_meet, g.sub(face_level, g.div(dot(g, moment_sum, normal_A, 1), g.where(main_meet, w_sum, one))),
                       zero)
    point = g.add(g.sub(point, g.mul(dot(g, point, normal_A, 1), normal_A)),
                  g.mul(g.sub(face_level, g.mul(f_A, depth_at)), normal_A))
    sl = lambda sw, v: g.rsum(g.mul(g.unsq(sw, [2]), v), 1)  # noqa: E731
    direction = g.add(g.rsum(g.mul(g.unsq(w, [2]), g.unsq(main_normal, [1])), 1), g.add(sl(wB, nB_s), sl(wA, nA_s)))
    normal = g.div(direction, g.op("Max", norm(g, direction), g.f(1e-300)))
    normal = g.where(g.op("Greater", weight, zero), normal, main_normal)
    tilt = acos01(g, g.clip(g.op("Abs", g.vec_at(g.row_at(R, a), m)), zero, one))
    return point, normal, weight, tilt
