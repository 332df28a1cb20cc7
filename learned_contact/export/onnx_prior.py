"""The geometric prior's graph: the batched box geometry of learned_contact.model.prior /
encodings written in standard ONNX operators (canonicalisation, the 15-axis separating-axis
test, the reference face, B's incident face clipped with a fixed vertex budget, the
depth-weighted centroid, the edge-edge midpoint, the corner features).

Shapes, frames and units follow learned_contact.model.prior: p (n, 3) [m] B's centre in A,
R (n, 3, 3) B's axes in A (columns), hA, hB (n, 3) half extents [m]. `g.dt` is the numpy
dtype the geometry is computed in (float64 for the improved predictor, so that every branch
of the geometry (argmin of the 15 overlaps, the reference face, the clipping) is taken as in
the compiled path). The operations follow learned_contact.compiled.prior step by step.
"""

from __future__ import annotations

import numpy as np

from learned_contact.export.onnx_blocks import NEXT, NEXT2, Graph, cross, dot, matvec, onnx_type, transpose
from testbed.geometry.boxes import CORNER_SIGNS

MAX_VERTS = 9  # learned_contact.model.prior._MAX_VERTS
EDGE_BIAS = 1e-3  # [m] learned_contact.compiled.prior.EDGE_BIAS


def canonicalise(g: Graph, p, R):
    """encodings.canonicalise: (S (n, 3) signs, p_c (n, 3) >= 0 [m], R_c (n, 3, 3))."""
    S = g.sign_ge0(p)
    return (S, *reflect(g, S, p, R))


def reflect(g: Graph, S, p, R):
    """encodings.reflect: the poses seen in A's frame reflected by diag(S) (S (n, 3) of
    +-1): (p (n, 3) [m], R (n, 3, 3), B's columns sign-fixed)."""
    RS = g.mul(g.unsq(S, [2]), R)
    col = g.sign_ge0(g.rsum(RS, 1))
    return g.mul(S, p), g.mul(RS, g.unsq(col, [1]))


def frame_rows(g: Graph, p, band: float, flips):
    """encodings.frame_blend as rows to evaluate: (rows (M,) int64 indices into the batch,
    sigma (M, 3) frame signs, coef (M, 1) weights). The first n rows are the own octant
    frame of every pose in order; then, per flip pattern, the poses whose weight is > 0."""
    S = g.sign_ge0(p)
    u = g.clip(g.div(g.op("Abs", p), g.f(band)), g.f(0.0), g.f(1.0))
    half = g.mul(g.f(0.5), g.sub(g.f(1.0), g.mul(g.mul(u, u), g.sub(g.f(3.0), g.mul(g.f(2.0), u)))))
    other = [g.take(half, [k], 1) for k in range(3)]
    own = [g.sub(g.f(1.0), h) for h in other]
    n = g.op("Gather", g.op("Shape", p), g.i(0))
    rows, sigma, coef = [], [], []
    for flip in flips:
        c = g.mul(g.mul(other[0] if flip[0] else own[0], other[1] if flip[1] else own[1]),
                  other[2] if flip[2] else own[2])
        s = g.mul(S, g.f(np.where(np.array(flip) == 1, -1.0, 1.0)[None]))
        if not any(flip):
            r = g.op("Range", g.i(0), n, g.i(1))
        else:
            r = g.sq(g.op("NonZero", g.op("Greater", g.sq(c, [1]), g.f(0.0))), [0])
        rows.append(r)
        sigma.append(g.op("Gather", s, r, axis=0))
        coef.append(g.op("Gather", c, r, axis=0))
    return g.op("Concat", *rows, axis=0), g.op("Concat", *sigma, axis=0), g.op("Concat", *coef, axis=0)


def sat(g: Graph, p, R, hA, hB):
    """geometry.sat_overlap + sat_normal: (overlap (n, 15) [m] (+inf on degenerate axes),
    axes (n, 15, 3), normal (n, 3) unit A->B, depth (n, 1) [m], k (n, 1) int64 axis index)."""
    RT = transpose(g, R)  # rows: B's axes in A
    # e_i x b_j for i, j in 0..2 (k = 6 + 3 i + j): b_j @ K with K[:, 3 i + c] = (e_i x .)_c
    K = np.zeros((3, 9))
    for i in range(3):
        for c in range(3):
            K[:, 3 * i + c] = np.cross(np.eye(3)[i], np.eye(3))[:, c]
    C = g.reshape(g.op("MatMul", RT, g.f(K)), [0, 3, 3, 3])  # [n, j, i, c]
    C = g.reshape(g.op("Transpose", C, perm=[0, 2, 1, 3]), [0, 9, 3])
    norm = g.op("Sqrt", g.rsum(g.mul(C, C), 2, keep=1))
    C = g.where(g.op("Greater", norm, g.f(1e-6)), g.div(C, g.op("Max", norm, g.f(1e-12))), g.f(0.0))
    eye = g.op("Expand", g.f(np.eye(3)[None]), g.op("Shape", RT))
    axes = g.op("Concat", eye, RT, C, axis=1)  # (n, 15, 3)
    rA = matvec(g, g.op("Abs", axes), hA)
    rB = matvec(g, g.op("Abs", g.op("MatMul", axes, R)), hB)
    dist = g.op("Abs", matvec(g, axes, p))
    overlap = g.sub(g.add(rA, rB), dist)
    degenerate = g.op("Less", g.rsum(g.mul(axes, axes), 2), g.f(0.25))
    overlap = g.where(degenerate, g.f(np.inf), overlap)
    k = g.op("ArgMin", g.add(overlap, g.f(np.r_[np.zeros(6), np.full(9, EDGE_BIAS)])), axis=1, keepdims=1)
    depth = g.pick(overlap, k, 1)
    normal = g.row_at(axes, k)
    dot = g.rsum(g.mul(normal, p), 1, keep=1)
    normal = g.mul(normal, g.sign_ge0(dot))
    return overlap, axes, normal, depth, k


def clip_halfspace(g: Graph, poly, count, normal, limit):
    """learned_contact.model.clipping.clip_halfspace: Sutherland-Hodgman with a fixed vertex
    budget; poly (N, V, 3) [m], count (N, 1) int64, clipped to normal . x <= limit (normal
    (N, 3) of any length, limit (N, 1) [m x |normal|]).
    Returns (poly (N, V, 3), count (N, 1)). As numpy's indexed assignment does, the last
    kept candidate past the budget overwrites the last slot."""
    V = MAX_VERTS
    ar = np.arange(V)[None, :]
    valid = g.op("Less", g.i(ar), count)
    nxt = g.where(g.op("Less", g.i(ar + 1), count), g.i(ar + 1), g.i(0))
    s = g.sub(dot(g, poly, g.unsq(normal, [1])), limit)  # (N, V)
    s_next = g.pick(s, nxt, 1)
    v_next = g.pick(poly, g.op("Expand", g.unsq(nxt, [2]), g.i([1, 1, 3])), 1)
    inside, inside_next = g.op("LessOrEqual", s, g.f(0.0)), g.op("LessOrEqual", s_next, g.f(0.0))
    diff = g.sub(s, s_next)
    denom = g.where(g.op("Equal", diff, g.f(0.0)), g.f(1.0), diff)
    crossing = g.add(poly, g.mul(g.unsq(g.div(s, denom), [2]), g.sub(v_next, poly)))
    cand = g.reshape(g.op("Concat", g.unsq(poly, [2]), g.unsq(crossing, [2]), axis=2), [0, 2 * V, 3])
    keep = g.reshape(g.op("Concat", g.unsq(g.op("And", valid, inside), [2]),
                          g.unsq(g.op("And", valid, g.op("Xor", inside, inside_next)), [2]), axis=2), [0, 2 * V])
    keep_i = g.op("Cast", keep, to=7)  # int64
    rank = g.sub(g.op("CumSum", keep_i, g.i(1)), g.i(1))  # (N, 2V) each kept candidate's place
    total = g.rsum(keep_i, 1, keep=1)  # (N, 1) candidates kept
    # slot v < V - 1 takes the kept candidate of rank v; slot V - 1 the last kept one (rank
    # total - 1) when total >= V, else none: a one-hot (N, V, 2V) matrix product in which
    # every sum has at most one non-zero term
    last = g.where(g.op("GreaterOrEqual", total, g.i(V)), g.sub(total, g.i(1)), g.i(-1))
    target = g.op("Concat", g.op("Expand", g.i(np.arange(V - 1)[None, :]), g.op("Shape", total)), last, axis=1)
    hit = g.op("And", g.op("Equal", g.unsq(rank, [1]), g.unsq(target, [2])), g.unsq(keep, [1]))  # (N, V, 2V)
    out = g.op("MatMul", g.op("Cast", hit, to=onnx_type(g.dt)), cand)
    return out, g.op("Min", total, g.i(V))


def _weighted_centroid(g: Graph, poly, count, depth):
    """geometry._weighted_centroid: (centroid (n, 3), integral (n, 1) [m^3])."""
    V = MAX_VERTS
    v0, v1, v2 = g.take(poly, [0], 1), g.take(poly, list(range(1, V - 1)), 1), g.take(poly, list(range(2, V)), 1)
    d0, d1, d2 = g.take(depth, [0], 1), g.take(depth, list(range(1, V - 1)), 1), g.take(depth, list(range(2, V)), 1)
    tri_ok = g.op("Cast", g.op("Less", g.i(np.arange(2, V)[None, :]), count), to=onnx_type(g.dt))
    c = cross(g, g.sub(v1, v0), g.sub(v2, v0))
    area = g.mul(g.mul(g.f(0.5), g.op("Sqrt", g.rsum(g.mul(c, c), 2))), tri_ok)  # (n, V - 2)
    dsum = g.add(g.add(d0, d1), d2)
    mass = g.div(g.mul(area, dsum), g.f(3.0))
    w0, w1, w2 = g.add(dsum, d0), g.add(dsum, d1), g.add(dsum, d2)
    u = g.unsq
    first = g.mul(u(g.div(area, g.f(12.0)), [2]),
                  g.add(g.add(g.mul(u(w0, [2]), v0), g.mul(u(w1, [2]), v1)), g.mul(u(w2, [2]), v2)))
    total = g.rsum(mass, 1, keep=1)
    valid = g.op("Cast", g.op("Less", g.i(np.arange(V)[None, :]), count), to=onnx_type(g.dt))
    cnt = g.op("Max", g.op("Cast", count, to=onnx_type(g.dt)), g.f(1.0))
    mean = g.div(g.rsum(g.mul(poly, u(valid, [2])), 1), cnt)
    weighted = g.div(g.rsum(first, 1), g.op("Max", total, g.f(1e-300)))
    return g.where(g.op("Greater", total, g.f(1e-12)), weighted, mean), total


def face_patch(g: Graph, p, R, hA, hB, axis):
    """geometry._face_patch: B's incident face clipped against A's face normal to
    axis (n, 1) int64. Returns (point (n, 3) in A [m], weight (n, 1) [m^3])."""
    sigma = g.sign_ge0(g.vec_at(p, axis))
    along = g.mul(g.row_at(R, axis), sigma)
    m = g.op("ArgMax", g.op("Abs", along), axis=1, keepdims=1)
    s_m = g.where(g.op("Greater", g.vec_at(along, m), g.f(0.0)), g.f(-1.0), g.f(1.0))
    u_ax, v_ax = g.op("Gather", g.i(NEXT), m), g.op("Gather", g.i(NEXT2), m)
    RT = transpose(g, R)
    centre = g.add(p, g.mul(g.mul(s_m, g.vec_at(hB, m)), g.row_at(RT, m)))
    du = g.mul(g.vec_at(hB, u_ax), g.row_at(RT, u_ax))
    dv = g.mul(g.vec_at(hB, v_ax), g.row_at(RT, v_ax))
    corners = [g.add(g.add(centre, du), dv), g.add(g.sub(centre, du), dv),
               g.sub(g.sub(centre, du), dv), g.sub(g.add(centre, du), dv)]
    zeros = g.op("Expand", g.f(np.zeros((1, MAX_VERTS - 4, 3))), g.op("Concat", g.op("Shape", axis), g.i([3]), axis=0))
    poly = g.op("Concat", *[g.unsq(c, [1]) for c in corners], zeros, axis=1)
    count = g.op("Expand", g.i([[4]]), g.op("Shape", axis))
    for k in (1, 2):  # A's face rectangle: -hA[ax] <= x[ax] <= hA[ax] along its in-plane axes
        ax = g.op("Gather", g.i(np.array([(a + k) % 3 for a in range(3)])), axis)
        e_ax, lim = g.onehot(ax, 3, dtype=g.dt), g.vec_at(hA, ax)
        for sg in (1.0, -1.0):
            poly, count = clip_halfspace(g, poly, count, g.mul(g.f(sg), e_ax), lim)
    top = g.vec_at(hA, axis)
    poly, count = clip_halfspace(g, poly, count, g.mul(sigma, g.onehot(axis, 3, dtype=g.dt)), top)
    axv = g.op("Expand", g.unsq(axis, [2]), g.i([1, MAX_VERTS, 1]))
    depth = g.op("Max", g.sub(top, g.mul(sigma, g.sq(g.pick(poly, axv, 2), [2]))), g.f(0.0))
    centroid, weight = _weighted_centroid(g, poly, count, depth)
    moved = g.mul(g.f(0.5), g.add(g.vec_at(centroid, axis), g.mul(sigma, top)))
    return g.where(g.onehot(axis, 3), moved, centroid), weight


def edge_patch(g: Graph, p, R, hA, hB, k, normal):
    """geometry._edge_patch for edge axis k (n, 1) int64 (6..14; smaller k are clamped
    to 6, for rows whose answer is discarded). Returns (n, 3) in A [m]."""
    kk = g.sub(g.op("Max", k, g.i(6)), g.i(6))
    i, j = g.op("Div", kk, g.i(3)), g.op("Mod", kk, g.i(3))
    eA_b, eB_b = g.onehot(i, 3), g.onehot(j, 3)
    cA = g.where(eA_b, g.f(0.0), g.mul(g.sign_ge0(normal), hA))
    nB = g.sq(g.op("MatMul", g.unsq(normal, [1]), R), [1])
    sB = g.where(eB_b, g.f(0.0), g.mul(g.where(g.op("Less", nB, g.f(0.0)), g.f(1.0), g.f(-1.0)), hB))
    cB = g.add(p, matvec(g, R, sB))
    eB = g.row_at(transpose(g, R), j)
    b = g.vec_at(eB, i)
    w = g.sub(cA, cB)
    d, e = g.vec_at(w, i), g.rsum(g.mul(eB, w), 1, keep=1)
    den = g.op("Max", g.sub(g.f(1.0), g.mul(b, b)), g.f(1e-9))
    hAi, hBj = g.vec_at(hA, i), g.vec_at(hB, j)
    s = g.clip(g.div(g.sub(g.mul(b, e), d), den), g.op("Neg", hAi), hAi)
    t = g.clip(g.div(g.sub(e, g.mul(b, d)), den), g.op("Neg", hBj), hBj)
    eA = g.op("Cast", eA_b, to=onnx_type(g.dt))
    return g.mul(g.f(0.5), g.add(g.add(g.add(cA, g.mul(s, eA)), cB), g.mul(t, eB)))


def patch_estimate(g: Graph, p, R, hA, hB):
    """geometry.patch_estimate: (point (n, 3) [m], normal (n, 3), depth (n, 1) [m],
    k (n, 1) int64, weight (n, 1) [m^3], overlap (n, 15) [m])."""
    overlap, _, normal, depth, k = sat(g, p, R, hA, hB)
    face = g.op("ArgMin", g.take(overlap, list(range(6)), 1), axis=1, keepdims=1)
    on_A = g.op("Less", face, g.i(3))
    f3 = g.op("Mod", face, g.i(3))
    point_a, weight_a = face_patch(g, p, R, hA, hB, f3)
    R_BA = transpose(g, R)
    p_BA = g.op("Neg", matvec(g, R_BA, p))
    q, weight_b = face_patch(g, p_BA, R_BA, hB, hA, f3)
    point = g.where(on_A, point_a, g.add(p, matvec(g, R, q)))
    weight = g.where(on_A, weight_a, weight_b)
    empty = g.op("And", g.op("LessOrEqual", weight, g.f(1e-12)), g.op("GreaterOrEqual", k, g.i(6)))
    point = g.where(empty, edge_patch(g, p, R, hA, hB, k, normal), point)
    return point, normal, depth, k, weight, overlap


def corners_depths(g: Graph, p_c, R_c, hA, hB):
    """encodings.features' corner blocks: (corners_B (n, 24) [m], depth_B (n, 8), depth_A (n, 8) [m])."""
    signs = g.f(CORNER_SIGNS[None])
    corners_B = g.add(g.unsq(p_c, [1]), g.op("MatMul", g.mul(signs, g.unsq(hB, [1])), transpose(g, R_c)))
    depth_B = g.rmin(g.sub(g.unsq(hA, [1]), g.op("Abs", corners_B)), 2)
    in_B = g.op("MatMul", g.sub(g.mul(signs, g.unsq(hA, [1])), g.unsq(p_c, [1])), R_c)
    depth_A = g.rmin(g.sub(g.unsq(hB, [1]), g.op("Abs", in_B)), 2)
    return g.reshape(corners_B, [0, 24]), depth_B, depth_A
