"""The shipped predictors' graphs: `improved_graph` and `paper_graph` build each predictor's
whole pipeline from standard ONNX operators, with the contract's inputs and outputs
(onnx_contract.py).

What the exported graphs hold (standard ONNX operators, opset 17, no custom ops):
- "paper": the whole pipeline of paper_mlp.PaperPredictor (reflection into A's
  positive octant, canonical position and roll-pitch-yaw, the 6-20-18-4 tanh MLP,
  its spherical outputs decoded into the point where the ray leaves A and the unit
  force direction, reflected back), computed in float32; `depth` (the 15-axis
  separating-axis test) in float64.
- "improved": the whole pipeline of predictor.ContactPredictor, computed in float64
  inside the graph (inputs cast up, outputs cast down to float32). The learned answer:
  canonicalisation, the 15-axis separating-axis test, the geometric prior (reference
  face, B's incident face clipped by Sutherland-Hodgman with the fixed 9-vertex budget,
  the depth-weighted centroid, the edge-edge midpoint where the patch is empty), the 91
  features, the 64-64 SiLU MLP (and the resting expert, by its gate and the slab scale)
  and the correction of the prior, with the octant-plane blend of encodings.frame_blend
  (the poses within SYMMETRY_BAND of one of A's planes answered in the neighbouring
  frames too, gathered into one batch and summed back with ScatterND), clipped outside
  the domain. The exact face-on-face integral (model.quadrature.face_on_face, on the
  separating-axis normal of the pose as given): the faces that meet, the two 4-triangle
  fans, the 16 polygons (B's triangle j clipped by the three sides of A's triangle i, by
  A's face plane and by the two 45 deg trims) clipped as one (16 n, 9, 3) batch with
  the fixed 9-vertex budget, their exact pressure moments (fan triangles), the 32 sliver strips
  (edges clipped in the parameter t by the other face's triangle and the overlap),
  the weighted point and normal, the tilt (arccos: float32 Acos refined by two float64
  Newton steps, onnxruntime having no float64 Acos; within 1e-14 rad over the
  hand-over bands). The answer: the quadrature's where two faces meet, handed over to
  the learned one by quadrature.hand_over of the tilt (point over POINT_TILT, normal
  over NORMAL_TILT; 0 below DOMAIN_DEPTH[0] and where the quadrature's weight is 0). The
  learned answer is computed for every pose (a graph does not skip rows), the
  quadrature's taken as it is where its hand-over weight is 1. Nothing is left for the
  simulator to add. float64 inside, because the geometry branches (the least overlap
  of 15 axes, the reference face, which clipped vertices are kept) and the depth- and
  overlap-weighted patches amplify rounding on shallow contacts (overlaps of
  micrometres against coordinates of metres): the learned pipeline alone, as a
  float32 graph, differed from the compiled path by up to 3.8e-4 m and 0.035 deg (800
  held-out poses); the float64 graph differs from the numpy reference path by 2.4e-7
  m and 2.4e-6 deg (the answers' float32 rounding; 5,000 random poses and 2,000 each
  resting and tilted up to 40 deg). It holds 2,368 nodes (1,191 without the quadrature).
- Domain handling: both graphs reproduce outside="clip" (interface.DOMAIN_DEPTH,
  CLIP_MARGIN): where the separating-axis depth lies outside DOMAIN_DEPTH the point
  is clamped into A's box grown by CLIP_MARGIN (the paper's point lies on A's surface
  and is never moved). A host that applies the same clip again changes nothing. The
  graphs do NOT check their inputs: sizes outside `supported_sizes`, non-finite poses
  or matrices that are not rotations are answered without complaint; the host (the
  bench's loader, a simulator) checks them, as Predictor.predict does.
"""

from __future__ import annotations

import numpy as np

from learned_contact.export.onnx_blocks import Graph, atan2, cross, onnx_type, transpose
from learned_contact.export.onnx_contract import INPUTS
from learned_contact.export.onnx_network import mlp
from learned_contact.export.onnx_prior import canonicalise, corners_depths, frame_rows, patch_estimate, reflect, sat
from learned_contact.export.onnx_quadrature import face_on_face
from learned_contact.interface import CLIP_MARGIN, DOMAIN_DEPTH
from learned_contact.model.encodings import FLIPS, LENGTH_SCALE, PAPER_FRAME, SYMMETRY_BAND
from learned_contact.model.expert import DOMAIN_FIELDS_V2, R_SLAB
from learned_contact.model.quadrature import NORMAL_TILT, POINT_TILT
from learned_contact.predictors.improved import POINT_STEP


def _inputs(g, dt):
    """Casts the float32 contract inputs to dt; returns (p, R, hA, hB) names."""

    names = []
    for name in INPUTS:
        names.append(name if np.dtype(dt) == np.float32 else g.op("Cast", name, to=onnx_type(dt)))
    p, R, sA, sB = names
    return p, R, g.mul(g.f(0.5), sA), g.mul(g.f(0.5), sB)


def _outputs(g, point, normal, depth):
    """Casts the answers to float32 under the contract's output names."""
    for name, value in (("point_A", point), ("normal_A", normal), ("depth", g.sq(depth, [1]))):
        g.op("Cast", value, to=1, out=name)


def _clip_outside(g, point, depth, hA):
    """outside='clip': the point clamped into A's box grown by CLIP_MARGIN where depth (n, 1)
    lies outside DOMAIN_DEPTH."""
    out = g.op("Or", g.op("Less", depth, g.f(DOMAIN_DEPTH[0])), g.op("Greater", depth, g.f(DOMAIN_DEPTH[1])))
    bound = g.add(hA, g.f(CLIP_MARGIN))
    return g.where(out, g.clip(point, g.op("Neg", bound), bound), point)


def _ramp_off(g, t, lo, hi):
    """1 - smoothstep((t - lo) / (hi - lo)) (expert._ramp_off) of a tensor t."""
    u = g.clip(g.div(g.sub(t, g.f(lo)), g.f(hi - lo)), g.f(0.0), g.f(1.0))
    return g.sub(g.f(1.0), g.mul(g.mul(u, u), g.sub(g.f(3.0), g.mul(g.f(2.0), u))))


def _slab_scale(g, R_c, hA, hB, depth, overlap, r_slab):
    """(M, 1) the slab scale s = smoothstep(r / r_slab) of canonical rows (learned_contact.
    expert.slab_ratio on expert.slab_axes): R_c (M, 3, 3), half extents hA, hB (M, 3) [m],
    depth (M, 1) [m], overlap (M, 15) [m]; s = 1 where depth <= 0."""
    A = g.op("Abs", R_c)
    face = g.op("ArgMin", g.take(overlap, list(range(6)), 1), axis=1, keepdims=1)  # (M, 1)
    on_A = g.op("Less", face, g.i(3))
    f3 = g.op("Mod", face, g.i(3))
    row_f = g.row_at(A, f3)  # (M, 3) |R_c[f3, :]|
    col_f = g.sq(g.pick(A, g.op("Expand", g.unsq(f3, [1]), g.i([1, 3, 1])), 2), [2])  # (M, 3) |R_c[:, f3]|
    k = g.where(on_A, f3, g.op("ArgMax", col_f, axis=1, keepdims=1))
    j = g.where(on_A, g.op("ArgMax", row_f, axis=1, keepdims=1), f3)
    col_j = g.sq(g.pick(A, g.op("Expand", g.unsq(j, [1]), g.i([1, 3, 1])), 2), [2])  # (M, 3) |R_c[i, j]|
    masked = g.where(g.unsq(g.onehot(j, 3), [1]), g.f(-1.0), A)  # column j out of the running
    m = g.sq(g.op("ArgMax", masked, axis=2, keepdims=1), [2])  # (M, 3) B's axis nearest A's i
    terms = g.mul(col_j, g.op("Min", hA, g.pick(hB, m, 1)))
    rise = g.mul(g.f(2.0), g.rsum(g.where(g.onehot(k, 3), g.f(0.0), terms), 1, keep=1))
    positive = g.op("Greater", depth, g.f(0.0))
    ratio = g.div(rise, g.where(positive, depth, g.f(1.0)))
    return g.where(positive, g.sub(g.f(1.0), _ramp_off(g, ratio, 0.0, r_slab)), g.f(1.0))


def _expert_weights(g, p_c, R_c, hA, hB, depth, overlap, domain):
    """(w_main, w_expert) (M, 1) each: learned_contact.model.expert.weights of canonical rows
    p_c (M, 3) [m], R_c (M, 3, 3), half extents hA, hB (M, 3) [m], depth (M, 1) [m], overlap
    (M, 15) [m]; both networks are evaluated on every row and blended (where the gate is
    shut and the slab scale is 1 the main network's answer is kept exactly: 1 * y + 0 * y_expert).
    domain: the gate's bounds, (11,) DOMAIN_FIELDS (offsets as fractions of the edge of
    support max(hA_i, hB_i)) or (9,) DOMAIN_FIELDS_V2 (one offset bound [m]); None: no expert
    (w_expert None, r_slab = expert.R_SLAB)."""
    if domain is None:
        return _slab_scale(g, R_c, hA, hB, depth, overlap, R_SLAB), None
    col = lambda a, k: g.take(a, [k], 1)  # noqa: E731  (n, 1) column k of an (n, 3) array
    z_B = g.sq(g.take(R_c, [2], 2), [2])  # (M, 3) B's z axis
    sin_tilt = g.op("Sqrt", g.add(g.mul(col(z_B, 0), col(z_B, 0)), g.mul(col(z_B, 1), col(z_B, 1))))
    sin_yaw = g.op("Abs", g.sq(g.take(g.take(R_c, [1], 1), [0], 2), [2]))
    d = [float(v) for v in domain]
    offset = [g.op("Abs", col(p_c, 0)), g.op("Abs", col(p_c, 1))]
    if len(d) == len(DOMAIN_FIELDS_V2):
        bounds = [d[6:8], d[6:8]]
    else:  # fractions of the edge of support
        edge = g.op("Max", hA, hB)
        offset = [g.div(offset[0], col(edge, 0)), g.div(offset[1], col(edge, 1))]
        bounds = [d[6:8], d[8:10]]
    gate = _ramp_off(g, depth, d[0], d[1])
    for t, (lo, hi) in ((sin_tilt, d[2:4]), (sin_yaw, d[4:6]), (offset[0], bounds[0]), (offset[1], bounds[1])):
        gate = g.mul(gate, _ramp_off(g, t, lo, hi))
    s = _slab_scale(g, R_c, hA, hB, depth, overlap, d[-1])
    return g.mul(g.sub(g.f(1.0), gate), s), g.mul(gate, s)


def improved_graph(predictor):
    """The Graph of predictor.ContactPredictor (see the module docstring), in float64."""
    g = Graph(np.float64)
    p0, R0, hA0, hB0 = _inputs(g, np.float64)
    # every pose in its own octant frame, then near a plane in the neighbouring frames
    # (encodings.frame_blend): one batch of M >= n rows, summed back per pose
    rows, sigma, coef = frame_rows(g, p0, SYMMETRY_BAND, FLIPS)
    p, R, hA, hB = (g.op("Gather", a, rows, axis=0) for a in (p0, R0, hA0, hB0))
    p_c, R_c = reflect(g, sigma, p, R)
    point_est, normal_est, depth, k, weight, overlap = patch_estimate(g, p_c, R_c, hA, hB)
    # features (encodings.features), in its block order
    s = g.f(LENGTH_SCALE)
    RT = transpose(g, R_c)
    outer = g.reshape(g.op("Mul", g.unsq(RT, [3]), g.unsq(RT, [2])), [0, 3, 9])
    outer = g.reshape(g.take(outer, [0, 1, 2, 4, 5, 8], 2), [0, 18])
    corners_B, depth_B, depth_A = corners_depths(g, p_c, R_c, hA, hB)
    log_w = g.div(g.op("Log", g.add(weight, g.f(1e-9))), g.f(np.log(10.0)))
    edge = g.op("Cast", g.op("GreaterOrEqual", k, g.i(6)), to=onnx_type(np.float64))
    ten = g.f(10.0)
    x = g.op("Concat", g.mul(p_c, s), g.mul(hA, s), g.mul(hB, s), outer,
             g.mul(g.op("Min", overlap, g.f(0.5)), ten), normal_est, g.mul(point_est, s), log_w,
             g.mul(depth, g.f(30.0)), edge, g.mul(corners_B, s), g.mul(g.clip(depth_B, g.f(-0.5), g.f(0.5)), ten),
             g.mul(g.clip(depth_A, g.f(-0.5), g.f(0.5)), ten), axis=1)
    y = mlp(g, x, predictor.mlp)
    # the resting expert and the slab scale (learned_contact.model.expert.weights)
    w_main, w_expert = _expert_weights(g, p_c, R_c, hA, hB, depth, overlap,
                                       None if predictor.expert is None else predictor.expert_domain)
    y = g.mul(w_main, y)
    if w_expert is not None:
        y = g.add(y, g.mul(w_expert, mlp(g, x, predictor.expert)))
    point_t = g.mul(coef, g.mul(sigma, g.add(point_est, g.mul(g.f(POINT_STEP), g.take(y, [0, 1, 2], 1)))))
    normal_t = g.mul(coef, g.mul(sigma, g.add(normal_est, g.take(y, [3, 4, 5], 1))))
    zeros = g.op("Expand", g.f(np.zeros((1, 3))), g.op("Shape", p0))
    idx = g.unsq(rows, [1])
    point = g.op("ScatterND", zeros, idx, point_t, reduction="add")
    normal = g.op("ScatterND", zeros, idx, normal_t, reduction="add")
    # the separating axis and depth of the pose as given (predictor._predict_numpy's sat_normal)
    _, _, sat_n, depth, _ = sat(g, p0, R0, hA0, hB0)
    length = g.op("Sqrt", g.rsum(g.mul(normal, normal), 1, keep=1))
    ok = g.op("And", g.op("Greater", length, g.f(1e-9)), g.op("Not", g.op("IsInf", length)))
    normal = g.where(ok, g.div(normal, g.where(ok, length, g.f(1.0))), sat_n)
    point = _clip_outside(g, point, depth, hA0)
    # the exact face-on-face integral (learned_contact.model.quadrature), handed over to the
    # learned answer above as the faces tilt; 0 below DOMAIN_DEPTH[0] and where the faces miss
    q_point, q_normal, q_weight, tilt = face_on_face(g, p0, R0, hA0, hB0, sat_n)
    meet = g.op("And", g.op("GreaterOrEqual", depth, g.f(DOMAIN_DEPTH[0])), g.op("Greater", q_weight, g.f(0.0)))
    f_point = g.where(meet, _ramp_off(g, tilt, *POINT_TILT), g.f(0.0))
    f_normal = g.where(meet, _ramp_off(g, tilt, *NORMAL_TILT), g.f(0.0))
    # where a weight is 1 the quadrature's answer as it is (the numpy path evaluates nothing else)
    whole_p, whole_n = g.op("GreaterOrEqual", f_point, g.f(1.0)), g.op("GreaterOrEqual", f_normal, g.f(1.0))
    blend = lambda f, q, x: g.add(g.mul(f, q), g.mul(g.sub(g.f(1.0), f), x))  # noqa: E731
    point = g.where(whole_p, q_point, blend(f_point, q_point, point))
    mixed = blend(f_normal, q_normal, normal)
    mixed = g.div(mixed, g.op("Sqrt", g.rsum(g.mul(mixed, mixed), 1, keep=1)))
    normal = g.where(g.op("And", whole_p, whole_n), q_normal, mixed)
    _outputs(g, point, normal, depth)
    return g


def paper_graph(predictor):
    """The Graph of paper_mlp.PaperPredictor (see the module docstring): the pipeline in
    float32 (onnxruntime has no float64 Atan/Asin), the separating-axis depth in float64."""
    g = Graph(np.float32)
    p, R, hA, _ = _inputs(g, np.float32)
    S, p_c, R_c = canonicalise(g, p, R)
    rows = [g.sq(g.take(R_c, [r], 1), [1]) for r in range(3)]
    det = g.rsum(g.mul(rows[0], cross(g, rows[1], rows[2])), 1, keep=1)
    flip = g.sign_ge0(det)  # det is +-1: its sign is never in doubt

    def Rij(i, j):
        return g.take(rows[i], [j], 1)

    roll = atan2(g, Rij(2, 1), g.mul(Rij(2, 2), flip))
    pitch = g.op("Asin", g.clip(g.op("Neg", Rij(2, 0)), g.f(-1.0), g.f(1.0)))
    yaw = atan2(g, Rij(1, 0), Rij(0, 0))
    y = mlp(g, g.op("Concat", p_c, roll, pitch, yaw, axis=1), predictor.mlp)

    def direction(az, el):  # S * from_spherical([az, el]) (n, 3)
        ce = g.op("Cos", el)
        w = g.op("Concat", g.mul(ce, g.op("Cos", az)), g.mul(ce, g.op("Sin", az)), g.op("Sin", el), axis=1)
        return g.mul(S, g.op("MatMul", w, g.f(PAPER_FRAME)))

    d = direction(g.take(y, [0], 1), g.take(y, [1], 1))
    reach = g.rmax(g.div(g.op("Abs", d), hA), 1, keep=1)
    point = g.div(d, reach)
    f = direction(g.take(y, [2], 1), g.take(y, [3], 1))
    normal = g.div(f, g.op("Sqrt", g.rsum(g.mul(f, f), 1, keep=1)))
    # the separating-axis depth, in float64 (the clip below never moves a point on A's surface)
    g.dt = np.dtype(np.float64)
    depth = sat(g, *_inputs(g, np.float64))[3]
    g.dt = np.dtype(np.float32)
    depth32 = g.op("Cast", depth, to=onnx_type(np.float32))
    point = _clip_outside(g, point, depth32, hA)
    _outputs(g, point, normal, depth)
    return g
