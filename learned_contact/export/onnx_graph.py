"""Graph-building helpers for learned_contact.export.onnx_export: a small node/initializer
collector over the `onnx` package's helper API, and the batched box geometry of
learned_contact.model.prior / encodings written in standard ONNX operators (opset 17).

Every function here takes a `Graph` and tensor names and returns tensor names; the
first axis of every tensor is the batch (n, dynamic). Shapes, frames and units follow
learned_contact.model.prior: p (n, 3) [m] B's centre in A, R (n, 3, 3) B's axes in A
(columns), hA, hB (n, 3) half extents [m]. `dt` is the numpy dtype the geometry is
computed in (float64 for the improved predictor, so that every branch of the geometry
(argmin of the 15 overlaps, the reference face, the clipping) is taken as in the
compiled path; onnxruntime's CPU provider has float64 kernels for every operator used
here but Acos, which `acos01` runs in float32 and refines in float64). The operations follow learned_contact.compiled.prior step by step; those of
`face_on_face` follow learned_contact.model.quadrature operation for operation.
"""

from __future__ import annotations

import numpy as np

from testbed.geometry.boxes import CORNER_SIGNS

OPSET = 17
IR_VERSION = 8  # onnx 1.23 writes IR 11 by default; IR 8 (opset <= 17) loads in onnxruntime >= 1.12
I64 = np.int64
MAX_VERTS = 9  # learned_contact.model.prior._MAX_VERTS
EDGE_BIAS = 1e-3  # [m] learned_contact.compiled.prior.EDGE_BIAS
_NEXT = np.array([1, 2, 0], dtype=I64)  # (m + 1) % 3
_NEXT2 = np.array([2, 0, 1], dtype=I64)  # (m + 2) % 3


class Graph:
    """Collects nodes and initializers; `op` adds one node and returns its output name."""

    def __init__(self, dt=np.float64):
        self.dt = np.dtype(dt)
        self.nodes, self.initializers, self._consts, self._n = [], [], {}, 0

    def name(self, hint: str) -> str:
        self._n += 1
        return f"{hint}_{self._n}"

    def const(self, value, dtype=None) -> str:
        """An initializer holding `value` (in self.dt unless dtype is given); shared by value."""
        from onnx import numpy_helper

        arr = np.asarray(value, dtype=dtype or self.dt)
        key = (arr.dtype.str, arr.shape, arr.tobytes())
        if key not in self._consts:
            name = self.name("c")
            self.initializers.append(numpy_helper.from_array(arr, name))
            self._consts[key] = name
        return self._consts[key]

    def op(self, op_type: str, *inputs, n_out: int = 1, out=None, **attrs):
        from onnx import helper

        outs = [out] if out is not None else [self.name(op_type.lower()) for _ in range(n_out)]
        self.nodes.append(helper.make_node(op_type, list(inputs), outs, **attrs))
        return outs[0] if n_out == 1 else outs

    # ---------------------------------------------------------------- shorthands
    def f(self, value) -> str:
        return self.const(value)

    def i(self, value) -> str:
        return self.const(value, I64)

    def add(self, a, b):
        return self.op("Add", a, b)

    def sub(self, a, b):
        return self.op("Sub", a, b)

    def mul(self, a, b):
        return self.op("Mul", a, b)

    def div(self, a, b):
        return self.op("Div", a, b)

    def where(self, c, a, b):
        return self.op("Where", c, a, b)

    def sign_ge0(self, x):
        """+1 where x >= 0, else -1 (np.where(x >= 0, 1, -1))."""
        return self.where(self.op("Less", x, self.f(0.0)), self.f(-1.0), self.f(1.0))

    def take(self, x, idx, axis):
        """x[..., idx, ...] along `axis` with a constant index list (or int: the axis drops)."""
        return self.op("Gather", x, self.i(idx), axis=axis)

    def pick(self, x, k, axis):
        """x gathered along `axis` with a per-row index tensor k broadcast to x's other
        axes (np.take_along_axis); k has x's rank with size 1 on `axis`."""
        return self.op("GatherElements", x, k, axis=axis)

    def unsq(self, x, axes):
        return self.op("Unsqueeze", x, self.i(axes))

    def sq(self, x, axes):
        return self.op("Squeeze", x, self.i(axes))

    def reshape(self, x, shape):
        return self.op("Reshape", x, self.i(shape))

    def rsum(self, x, axis, keep=0):
        return self.op("ReduceSum", x, self.i([axis]), keepdims=keep)

    def rmin(self, x, axis, keep=0):
        return self.op("ReduceMin", x, axes=[axis], keepdims=keep)

    def rmax(self, x, axis, keep=0):
        return self.op("ReduceMax", x, axes=[axis], keepdims=keep)

    def clip(self, x, lo, hi):
        return self.op("Max", self.op("Min", x, hi), lo)

    def onehot(self, k, depth: int, dtype=bool):
        """(n, depth) one-hot of k (n, 1) int64, as bool or self.dt."""
        hit = self.op("Equal", k, self.i(np.arange(depth)[None, :]))
        return hit if dtype is bool else self.op("Cast", hit, to=_onnx_type(self.dt))

    def vec_at(self, x3, k):
        """(n, 1) x3[n, k[n]] for x3 (n, 3) and k (n, 1) int64."""
        return self.pick(x3, k, 1)

    def row_at(self, M, k):
        """(n, 3) M[n, k[n], :] for M (n, 3, 3) and k (n, 1) int64."""
        kk = self.op("Expand", self.unsq(k, [2]), self.i([1, 1, 3]))
        return self.sq(self.pick(M, kk, 1), [1])


def _onnx_type(dt) -> int:
    from onnx import TensorProto

    return {np.dtype(np.float32): TensorProto.FLOAT, np.dtype(np.float64): TensorProto.DOUBLE}[np.dtype(dt)]


def onnx_type(dt) -> int:
    """The TensorProto element type of a numpy float dtype."""
    return _onnx_type(dt)


def cross(g: Graph, a, b):
    """a x b along the last axis (size 3)."""
    return g.sub(g.mul(g.take(a, [1, 2, 0], -1), g.take(b, [2, 0, 1], -1)),
                 g.mul(g.take(a, [2, 0, 1], -1), g.take(b, [1, 2, 0], -1)))


def matvec(g: Graph, M, v):
    """(n, r) M @ v for M (n, r, 3), v (n, 3)."""
    return g.sq(g.op("MatMul", M, g.unsq(v, [2])), [2])


def transpose(g: Graph, M):
    return g.op("Transpose", M, perm=[0, 2, 1])


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
    out = g.op("MatMul", g.op("Cast", hit, to=_onnx_type(g.dt)), cand)
    return out, g.op("Min", total, g.i(V))


def _weighted_centroid(g: Graph, poly, count, depth):
    """geometry._weighted_centroid: (centroid (n, 3), integral (n, 1) [m^3])."""
    V = MAX_VERTS
    v0, v1, v2 = g.take(poly, [0], 1), g.take(poly, list(range(1, V - 1)), 1), g.take(poly, list(range(2, V)), 1)
    d0, d1, d2 = g.take(depth, [0], 1), g.take(depth, list(range(1, V - 1)), 1), g.take(depth, list(range(2, V)), 1)
    tri_ok = g.op("Cast", g.op("Less", g.i(np.arange(2, V)[None, :]), count), to=_onnx_type(g.dt))
    c = cross(g, g.sub(v1, v0), g.sub(v2, v0))
    area = g.mul(g.mul(g.f(0.5), g.op("Sqrt", g.rsum(g.mul(c, c), 2))), tri_ok)  # (n, V - 2)
    dsum = g.add(g.add(d0, d1), d2)
    mass = g.div(g.mul(area, dsum), g.f(3.0))
    w0, w1, w2 = g.add(dsum, d0), g.add(dsum, d1), g.add(dsum, d2)
    u = g.unsq
    first = g.mul(u(g.div(area, g.f(12.0)), [2]),
                  g.add(g.add(g.mul(u(w0, [2]), v0), g.mul(u(w1, [2]), v1)), g.mul(u(w2, [2]), v2)))
    total = g.rsum(mass, 1, keep=1)
    valid = g.op("Cast", g.op("Less", g.i(np.arange(V)[None, :]), count), to=_onnx_type(g.dt))
    cnt = g.op("Max", g.op("Cast", count, to=_onnx_type(g.dt)), g.f(1.0))
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
    u_ax, v_ax = g.op("Gather", g.i(_NEXT), m), g.op("Gather", g.i(_NEXT2), m)
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
    eA = g.op("Cast", eA_b, to=_onnx_type(g.dt))
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


def mlp(g: Graph, x, net):
    """learned_contact.model.mlp.NumpyMLP on x (n, in): standardise, hidden layers, linear output."""
    h = g.div(g.sub(x, g.f(net.x_mean[None])), g.f(net.x_std[None]))
    last = len(net.weights) - 1
    for i, (W, b) in enumerate(zip(net.weights, net.biases)):
        h = g.add(g.op("MatMul", h, g.f(W)), g.f(b[None]))
        if i < last:
            if net.activation == "tanh":
                h = g.op("Tanh", h)
            elif net.activation == "relu":
                h = g.op("Relu", h)
            else:  # silu, written as mlp._silu: x * (0.5 + 0.5 tanh(x / 2))
                h = g.mul(h, g.add(g.f(0.5), g.mul(g.f(0.5), g.op("Tanh", g.mul(g.f(0.5), h)))))
    return h


def atan2(g: Graph, y, x):
    """np.arctan2(y, x) from Atan and Where (ONNX has no Atan2): atan(y/x) (+-pi for
    x < 0) where |x| >= |y|, else +-pi/2 - atan(x/y)."""
    zero = g.f(0.0)
    wide = g.op("GreaterOrEqual", g.op("Abs", x), g.op("Abs", y))
    safe_x = g.where(g.op("Equal", x, zero), g.f(1.0), x)
    safe_y = g.where(g.op("Equal", y, zero), g.f(1.0), y)
    a = g.op("Atan", g.div(y, safe_x))
    a = g.add(a, g.where(g.op("Less", x, zero), g.mul(g.sign_ge0(y), g.f(np.pi)), zero))
    b = g.sub(g.mul(g.sign_ge0(y), g.f(np.pi / 2)), g.op("Atan", g.div(x, safe_y)))
    return g.where(wide, a, b)


# ------------------------------------------------- face-on-face quadrature (model.quadrature)
# learned_contact.model.quadrature.face_on_face, operation for operation, batched: the 16
# polygons of a pair (A's triangle i x B's triangle j, row 16 k + 4 i + j) are clipped
# together as one (16 n, MAX_VERTS, 3) batch, the 32 sliver strips as (n, 4, 4) arrays.
_FAN = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])  # quadrature._FAN
_FAN_NEXT = [1, 2, 3, 0]  # the next corner of a face's fan


def dot(g: Graph, a, b, keep: int = 0):
    """sum(a * b) over the last axis (size 3)."""
    return g.op("ReduceSum", g.mul(a, b), g.i([-1]), keepdims=keep)


def norm(g: Graph, a, keep: int = 1):
    """The Euclidean norm over the last axis (np.linalg.norm(a, axis=-1, keepdims=keep))."""
    return g.op("Sqrt", dot(g, a, a, keep))


def batch_shape(g: Graph, like, dims):
    """The int64 shape (n, *dims), n the first axis of tensor `like`."""
    n = g.op("Slice", g.op("Shape", like), g.i([0]), g.i([1]), g.i([0]))
    return g.op("Concat", n, g.i(list(dims)), axis=0)


def pressure_moments(g: Graph, poly, count, face_level, nA):
    """quadrature._pressure_moments: (weight (N, 1) [m^3], moment (N, 3) [m^4]) of convex
    polygons poly (N, V, 3) with count (N, 1) vertices, the exact integrals of p dA and p x dA
    for p = (face_level (N, 1) - x . nA (N, 3)) / 2 (fan triangles from the first vertex)."""
    V = MAX_VERTS
    v0 = g.take(poly, [0], 1)
    v1, v2 = g.take(poly, list(range(1, V - 1)), 1), g.take(poly, list(range(2, V)), 1)
    ok = g.op("Cast", g.op("Less", g.i(np.arange(2, V)[None, :]), count), to=_onnx_type(g.dt))
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
    f32 = _onnx_type(np.float32)
    t = g.op("Cast", g.op("Acos", g.op("Cast", c, to=f32)), to=_onnx_type(g.dt))
    t = g.op("Max", t, g.f(1e-3))
    for _ in range(2):
        t = g.add(t, g.div(g.sub(g.op("Cos", t), c), g.op("Sin", t)))
    return t


def face_on_face(g: Graph, p, R, hA, hB, n_AB):
    """quadrature.face_on_face (faces() included): (point (n, 3) [m] in A, normal (n, 3)
    unit A->B, weight (n, 1) [m^3], tilt (n, 1) [rad]) of B's face pressed on A's face, for
    contact normals n_AB (n, 3) (unit, A->B, in A); p (n, 3) [m], R (n, 3, 3), hA, hB (n, 3) [m]."""
    dt = _onnx_type(g.dt)
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

    u_A, v_A = g.op("Gather", g.i(_NEXT), a), g.op("Gather", g.i(_NEXT2), a)
    e_a, e_u, e_v = (g.onehot(k, 3, dtype=g.dt) for k in (a, u_A, v_A))  # rows of np.eye(3)
    face_level = g.vec_at(hA, a)  # (n, 1) A's face along normal_A
    top = g.mul(g.mul(sigma_A, face_level), e_a)
    cA = fan(top, g.mul(g.vec_at(hA, u_A), e_u), g.mul(g.vec_at(hA, v_A), e_v))
    b = transpose(g, R)  # rows: B's axes in A
    u_B, v_B = g.op("Gather", g.i(_NEXT), m), g.op("Gather", g.i(_NEXT2), m)
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
    # by the 45 deg trims along the outer edges of B's face (edge j), then of A's face (edge i)
    for e0, e1, centre, axis in ((cB, cB_next, centre_B, 1), (cA, cA_next, top, 2)):
        w_in = _inward(g, e0, e1, g.unsq(centre, [1]), nA3)  # (n, 4, 3)
        gvec = g.op("Neg", g.add(g.mul(g.f(0.5), nA3), w_in))
        c = g.op("Neg", g.add(g.mul(g.f(0.5), face_level), dot(g, w_in, e0)))  # (n, 4)
        nrm = g.reshape(g.op("Expand", g.unsq(gvec, [axis]), shape16_3), [-1, 3])
        lim = g.reshape(g.op("Expand", g.unsq(c, [axis]), shape16), [-1, 1])
        poly, count = clip_halfspace(g, poly, count, nrm, lim)
    # the pressure (half the overlap below A's face, linear on each polygon) integrated exactly
    w, moment = pressure_moments(g, poly, count, g.reshape(g.op("Expand", g.unsq(face_level, [2]), shape16), [-1, 1]),
                                 g.reshape(g.op("Expand", nA4, shape16_3), [-1, 3]))
    w, moment = g.reshape(w, [-1, 16]), g.reshape(moment, [-1, 16, 3])
    n_Bout = g.mul(s_B, b_m)  # (n, 3) B's face normal, towards A
    main_normal = g.sub(normal_A, n_Bout)
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
    for e0, e1, sides, axis, inward_centre, local_depth, own in (
            (edge_B0, edge_B1, (p0_A, out_A, flip_A), 2, centre_B, depth_of, "B"),
            (edge_A0, edge_A1, (p0_B, out_B, flip_B), 1, top, depth_B_at, "A")):
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
        h0 = g.mul(g.f(0.5), g.op("Max", local_depth(x0), zero))  # the strip's width at each end [m]
        h1 = g.mul(g.f(0.5), g.op("Max", local_depth(x1), zero))
        length = g.mul(norm(g, g.sub(x1, x0), keep=0), ok)
        hh = g.add(h0, h1)
        hsum3 = g.mul(g.f(3.0), g.where(g.op("Greater", hh, zero), hh, one))
        area_s = g.mul(g.mul(g.mul(g.f(np.sqrt(2.0)), length), g.f(0.5)), hh)
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
            normal_s = g.add(nA4, w_B)
        else:
            normal_s = g.sub(g.op("Neg", direction), nB4)
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
                  g.mul(g.sub(face_level, g.mul(g.f(0.5), depth_at)), normal_A))
    sl = lambda sw, v: g.rsum(g.mul(g.unsq(sw, [2]), v), 1)  # noqa: E731
    direction = g.add(g.rsum(g.mul(g.unsq(w, [2]), g.unsq(main_normal, [1])), 1), g.add(sl(wB, nB_s), sl(wA, nA_s)))
    normal = g.div(direction, g.op("Max", norm(g, direction), g.f(1e-300)))
    normal = g.where(g.op("Greater", weight, zero), normal, main_normal)
    tilt = acos01(g, g.clip(g.op("Abs", g.vec_at(g.row_at(R, a), m)), zero, one))
    return point, normal, weight, tilt
