"""Compiled predictor pipelines (numba, cached): input checks, canonicalisation,
features, the MLP, decoding and reflection, one fused loop over poses.

Array arguments (all float64, C-contiguous): p (n, 3) [m], R (n, 3, 3), sA, sB
(1, 3) or (n, 3) full extents [m] (one row broadcasts), supported (k, 3) [m].
The MLP is packed by `pack_mlp`: params (flat float64: x_mean, x_std, then W_i
(in, out) row-major and b_i per layer) and dims (int64: [layers, d_0, ..., d_L]).
Kernels return their outputs plus (status, row): status 0 ok, 1 non-finite pose,
2/3 size_A/size_B not supported, 4/5 size_A/size_B not finite, 6 R_AB not a proper
rotation (interface.ROTATION_TOLERANCE); row: the first bad row
(interface.raise_for_status turns these into the numpy path's errors).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from learned_contact.compiled.prior import (
    LENGTH_SCALE,
    MAX_VERTS,
    N_FEATURES,
    band_half_weights,
    canonicalise,
    patch_estimate,
    reflect,
    sat_depth,
    sat_normal,
    sat_overlap,
)
from learned_contact.compiled.quadrature import face_on_face, face_on_face_scratch, face_tilt, hand_over
from learned_contact.interface import CLIP_MARGIN, DOMAIN_DEPTH, ROTATION_TOLERANCE, SIZE_TOLERANCE
from learned_contact.model.encodings import PAPER_FRAME

ACTIVATION_CODES = {"tanh": 0, "silu": 1, "relu": 2}
POINT_STEP = 0.5  # [m] per unit of the improved MLP's point outputs (predictor.POINT_STEP)
# [m] encodings.SYMMETRY_BAND; a literal in this file, not an import: numba freezes globals
# into the cached machine code of improved_predict and recompiles only when this file changes
SYMMETRY_BAND = 0.02
R_SLAB = 0.01  # learned_contact.model.expert.R_SLAB (a literal for the same reason): the slab scale without an expert
# [rad] learned_contact.model.quadrature.POINT_TILT and NORMAL_TILT (literals for the same reason): the
# tilts between the two faces over which the face-on-face answer hands over to the learned one
POINT_TILT = (math.radians(20.0), math.radians(30.0))
NORMAL_TILT = (math.radians(2.0), math.radians(4.0))
_FRAME = np.ascontiguousarray(PAPER_FRAME)
# numba caches the kernels below with the machine code of what they call from prior.py and
# quadrature.py, and with the imported constants frozen in, yet recompiles them only when this
# file changes (its cache stamp is this file's). A stale cache would answer with old
# numerics, so this file carries a digest of those sources and values: a change to either
# fails tests/learned/test_learned_compiled.py until the digest here is updated, which
# changes this file and so recompiles the kernels.
DEPENDENCY_DIGEST = "b196555fadb301af"


def dependency_digest() -> str:
    """sha256 (16 hex digits) of prior.py's and quadrature.py's sources and of the constants
    the kernels import (what DEPENDENCY_DIGEST must equal)."""
    import hashlib
    from pathlib import Path

    here = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for name in ("prior.py", "quadrature.py"):
        h.update((here / name).read_bytes().replace(b"\r\n", b"\n"))
    h.update(repr((CLIP_MARGIN, DOMAIN_DEPTH, ROTATION_TOLERANCE, SIZE_TOLERANCE, PAPER_FRAME.tolist())).encode())
    return h.hexdigest()[:16]


def pack_mlp(mlp):
    """(params (P,) float64, dims (L + 2,) int64, activation code) of a NumpyMLP: two
    arrays keep the per-call dispatch cheap (a tuple of weight arrays costs ~2 us more
    per call to type-check)."""
    parts = [mlp.x_mean.ravel(), mlp.x_std.ravel()]
    for W, b in zip(mlp.weights, mlp.biases):
        parts += [np.ascontiguousarray(W, dtype=float).ravel(), np.asarray(b, dtype=float).ravel()]
    dims = [len(mlp.weights), mlp.weights[0].shape[0]] + [W.shape[1] for W in mlp.weights]
    return np.concatenate(parts).astype(float), np.array(dims, dtype=np.int64), ACTIVATION_CODES[mlp.activation]


@njit(cache=True)
def _check_sizes(s, supported, bad_size, bad_value):
    for r in range(s.shape[0]):
        for c in range(3):
            if not math.isfinite(s[r, c]):
                return bad_value, r
        found = False
        for k in range(supported.shape[0]):
            if (abs(s[r, 0] - supported[k, 0]) <= SIZE_TOLERANCE and abs(s[r, 1] - supported[k, 1]) <= SIZE_TOLERANCE
                    and abs(s[r, 2] - supported[k, 2]) <= SIZE_TOLERANCE):
                found = True
                break
        if not found:
            return bad_size, r
    return 0, 0


@njit(cache=True)
def check_inputs(p, R, sA, sB, supported):
    """(status, row) of the inputs (see the module docstring)."""
    for r in range(p.shape[0]):
        for c in range(3):
            if not math.isfinite(p[r, c]):
                return 1, r
            for j in range(3):
                if not math.isfinite(R[r, c, j]):
                    return 1, r
    for r in range(p.shape[0]):  # R^T R = I and det R = +1, within ROTATION_TOLERANCE
        for a in range(3):
            for b in range(3):
                dot = R[r, 0, a] * R[r, 0, b] + R[r, 1, a] * R[r, 1, b] + R[r, 2, a] * R[r, 2, b]
                if abs(dot - (1.0 if a == b else 0.0)) > ROTATION_TOLERANCE:
                    return 6, r
        det = (R[r, 0, 0] * (R[r, 1, 1] * R[r, 2, 2] - R[r, 1, 2] * R[r, 2, 1])
               - R[r, 0, 1] * (R[r, 1, 0] * R[r, 2, 2] - R[r, 1, 2] * R[r, 2, 0])
               + R[r, 0, 2] * (R[r, 1, 0] * R[r, 2, 1] - R[r, 1, 1] * R[r, 2, 0]))
        if det < 0.0:
            return 6, r
    status, row = _check_sizes(sA, supported, 2, 4)
    if status != 0:
        return status, row
    return _check_sizes(sB, supported, 3, 5)


# 1/k! for k = 16 .. 0: Taylor coefficients of exp, highest first (Horner)
_EXP_TAYLOR = tuple(1.0 / math.factorial(k) for k in range(16, -1, -1))


@njit(cache=True, inline="always", error_model="numpy")
def fast_tanh(x):
    """tanh(x) in plain arithmetic, so that a loop over it vectorises (numba calls libm's
    scalar tanh otherwise, ~10x slower per element). exp(-2|x|) = exp(-|x|/32)^64: a
    degree-16 Taylor polynomial on [-0.625, 0] (truncation < 1e-18) squared 6 times
    (relative error < 64 ulp); |x| is capped at 20, where tanh is 1 in float64. Agrees
    with np.tanh to < 1e-14 (measured 3.4e-15 on 1.2e6 points over [-25, 25])."""
    a = min(math.fabs(x), 20.0)
    z = a * (-1.0 / 32.0)
    e = _EXP_TAYLOR[0]
    for k in range(1, 17):
        e = e * z + _EXP_TAYLOR[k]
    e = e * e
    e = e * e
    e = e * e
    e = e * e
    e = e * e
    e = e * e
    return math.copysign((1.0 - e) / (1.0 + e), x)


@njit(cache=True, error_model="numpy")
def _layer(x, W, b, out, act, hidden):
    """out = act(x @ W + b) (linear when not hidden); W (in, out) C-contiguous. The inner
    loops run along W's rows and over plain arithmetic, so they vectorise."""
    n_out = W.shape[1]
    for j in range(n_out):
        out[j] = b[j]
    for i in range(W.shape[0]):
        xi = x[i]
        for j in range(n_out):
            out[j] += xi * W[i, j]
    if not hidden:
        return
    if act == 0:
        for j in range(n_out):
            out[j] = fast_tanh(out[j])
    elif act == 1:
        for j in range(n_out):
            v = out[j]
            out[j] = v * (0.5 + 0.5 * fast_tanh(0.5 * v))
    else:
        for j in range(n_out):
            out[j] = max(out[j], 0.0)


@njit(cache=True)
def mlp_forward(x, params, dims, act, h0, h1, y):
    """y = MLP(x) for one row (mlp.NumpyMLP.__call__); h0, h1 scratch of the widest
    layer. params, dims: see pack_mlp; each layer's W is viewed as a 2-D (in, out) array."""
    d0 = dims[1]
    for i in range(d0):
        h0[i] = (x[i] - params[i]) / params[d0 + i]
    cur, nxt = h0, h1
    off = 2 * d0
    n_layers = dims[0]
    for layer in range(n_layers):
        n_in, n_out = dims[1 + layer], dims[2 + layer]
        W = params[off:off + n_in * n_out].reshape((n_in, n_out))
        b = params[off + n_in * n_out:off + n_in * n_out + n_out]
        _layer(cur, W, b, nxt, act, layer < n_layers - 1)
        off += n_in * n_out + n_out
        cur, nxt = nxt, cur
    for j in range(y.shape[0]):
        y[j] = cur[j]


@njit(cache=True)
def features(x, p_c, R_c, hA, hB, overlap, point_est, normal_est, pen, k, weight):
    """encodings.features for one canonical pose: fills x (N_FEATURES,)."""
    s = LENGTH_SCALE
    for i in range(3):
        x[i], x[3 + i], x[6 + i] = p_c[i] * s, hA[i] * s, hB[i] * s
    o = 9
    for a in range(3):
        for i in range(3):
            for j in range(i, 3):
                x[o] = R_c[i, a] * R_c[j, a]
                o += 1
    for i in range(15):
        x[27 + i] = min(overlap[i], 0.5) * 10.0
    for i in range(3):
        x[42 + i], x[45 + i] = normal_est[i], point_est[i] * s
    x[48] = math.log10(weight + 1e-9)
    x[49] = pen * 30.0
    x[50] = 1.0 if k >= 6 else 0.0
    for c in range(8):
        sx, sy, sz = (1.0 if c & 4 else -1.0), (1.0 if c & 2 else -1.0), (1.0 if c & 1 else -1.0)
        lx, ly, lz = sx * hB[0], sy * hB[1], sz * hB[2]
        dB = np.inf
        for i in range(3):
            corner = p_c[i] + (lx * R_c[i, 0] + ly * R_c[i, 1] + lz * R_c[i, 2])
            x[51 + 3 * c + i] = corner * s
            dB = min(dB, hA[i] - abs(corner))
        x[75 + c] = min(max(dB, -0.5), 0.5) * 10.0
        ax, ay, az = sx * hA[0] - p_c[0], sy * hA[1] - p_c[1], sz * hA[2] - p_c[2]
        dA = np.inf
        for j in range(3):
            dA = min(dA, hB[j] - abs(ax * R_c[0, j] + ay * R_c[1, j] + az * R_c[2, j]))
        x[83 + c] = min(max(dA, -0.5), 0.5) * 10.0


@njit(cache=True, inline="always")
def _ramp_off(t, t_in, t_out):
    """learned_contact.model.expert._ramp_off for one value."""
    u = min(max((t - t_in) / (t_out - t_in), 0.0), 1.0)
    return 1.0 - u * u * (3.0 - 2.0 * u)


@njit(cache=True)
def expert_gate(p_c, R_c, hA, hB, pen, domain):
    """learned_contact.model.expert.gate for one canonical pose: p_c (3,) [m], R_c (3, 3),
    half extents hA, hB (3,) [m], pen [m]; domain (11,) DOMAIN_FIELDS (offsets as fractions
    of the edge of support max(hA_i, hB_i)) or (9,) DOMAIN_FIELDS_V2 (one offset bound [m])."""
    sin_tilt = math.hypot(R_c[0, 2], R_c[1, 2])
    g = (_ramp_off(pen, domain[0], domain[1]) * _ramp_off(sin_tilt, domain[2], domain[3])
         * _ramp_off(abs(R_c[1, 0]), domain[4], domain[5]))
    if domain.shape[0] == 9:
        return g * _ramp_off(abs(p_c[0]), domain[6], domain[7]) * _ramp_off(abs(p_c[1]), domain[6], domain[7])
    u_x = abs(p_c[0]) / max(hA[0], hB[0])
    u_y = abs(p_c[1]) / max(hA[1], hB[1])
    return g * _ramp_off(u_x, domain[6], domain[7]) * _ramp_off(u_y, domain[8], domain[9])


@njit(cache=True)
def slab_ratio(R_c, hA, hB, pen, overlap):
    """learned_contact.model.expert.slab_ratio on the faces that meet (expert.slab_axes of
    overlap (15,) [m]) for one canonical pose: rise / pen, inf where pen <= 0."""
    face, best = 0, overlap[0]
    for f in range(1, 6):
        if overlap[f] < best:
            face, best = f, overlap[f]
    if face < 3:
        k, j = face, 0
        for m in range(1, 3):
            if abs(R_c[face, m]) > abs(R_c[face, j]):
                j = m
    else:
        j, k = face - 3, 0
        for i in range(1, 3):
            if abs(R_c[i, j]) > abs(R_c[k, j]):
                k = i
    rise = 0.0
    for i in range(3):
        m = -1
        for q in range(3):
            if q != j and (m < 0 or abs(R_c[i, q]) > abs(R_c[i, m])):
                m = q
        rise = rise + (0.0 if i == k else abs(R_c[i, j]) * min(hA[i], hB[m]))
    rise = 2.0 * rise
    return rise / pen if pen > 0.0 else np.inf


@njit(cache=True)
def expert_weights(p_c, R_c, hA, hB, pen, overlap, domain, has_expert):
    """learned_contact.model.expert.weights for one canonical pose: (w_main, w_expert), the
    slab scale included (no expert: g = 0 and r_slab = expert.R_SLAB)."""
    g = expert_gate(p_c, R_c, hA, hB, pen, domain) if has_expert else 0.0
    r_slab = domain[domain.shape[0] - 1] if has_expert else R_SLAB
    s = 1.0 - _ramp_off(slab_ratio(R_c, hA, hB, pen, overlap), 0.0, r_slab)
    return (1.0 - g) * s, g * s


def pack_improved(supported, main, expert, domain, has_expert):
    """(floats (F,) float64, ints (I,) int64): everything improved_predict needs besides the
    poses, in two arrays (one argument costs ~0.15 us of numba's dispatch per call, and a
    call for one pair is dominated by such fixed costs). supported (k, 3) [m]; main, expert:
    pack_mlp of the main network and of the resting expert (of the main one again where there
    is none); domain: the expert's gate bounds (unread when has_expert is False).
    floats = supported, main params, expert params, domain; ints = [k, len(main params),
    len(main dims), main act, len(expert params), len(expert dims), expert act, len(domain),
    has_expert, main dims, expert dims]."""
    (params, dims, act), (eparams, edims, eact) = main, expert
    supported, domain = np.ascontiguousarray(supported, dtype=float).reshape(-1, 3), np.asarray(domain, dtype=float)
    floats = np.concatenate([supported.ravel(), params, eparams, domain.ravel()])
    head = [len(supported), len(params), len(dims), act, len(eparams), len(edims), eact, domain.size, int(bool(has_expert))]
    return floats, np.concatenate([np.array(head, dtype=np.int64), dims, edims]).astype(np.int64)


@njit(cache=True)
def _unpack_improved(floats, ints):
    """pack_improved's arrays back as (supported, params, dims, act, eparams, edims, eact,
    domain, has_expert) (views, nothing copied)."""
    k, n_p, n_d, act, n_ep, n_ed, eact, n_dom = ints[0], ints[1], ints[2], ints[3], ints[4], ints[5], ints[6], ints[7]
    supported = floats[0:3 * k].reshape((k, 3))
    o = 3 * k
    params, eparams, domain = floats[o:o + n_p], floats[o + n_p:o + n_p + n_ep], floats[o + n_p + n_ep:o + n_p + n_ep + n_dom]
    dims, edims = ints[9:9 + n_d], ints[9 + n_d:9 + n_d + n_ed]
    return supported, params, dims, act, eparams, edims, eact, domain, ints[8] != 0


@njit(cache=True, error_model="numpy")
def improved_predict(p, R, sA, sB, floats, ints, point, normal, depth):
    """The improved predictor (predictor.ContactPredictor.predict, outside='clip'): the exact
    face-on-face centre of pressure (learned_contact.compiled.quadrature.face_on_face on the
    separating-axis normal) where two faces meet (depth >= DOMAIN_DEPTH[0]), handed over by the
    tilt between them (POINT_TILT for the point, NORMAL_TILT for the normal) to the
    learned pipeline, which is evaluated only where a hand-over weight is below 1: the
    octant-plane blend (encodings.frame_blend: the own frame, then the frames with
    sign flips in FLIPS order, skipped where their weight is 0) and, when has_expert,
    the resting expert (eparams, edims, eact: pack_mlp of it; domain (11,) or (9,): its gate's
    bounds in either layout, learned_contact.model.expert.weights), each network evaluated only
    where its weight is not 0, clipped outside DOMAIN_DEPTH; then point = f_point q_point +
    (1 - f_point) learned point, normal = normalise(f_normal q_normal + (1 - f_normal) learned
    normal), as ContactPredictor._predict_numpy. The quadrature itself runs only where its
    weights can be above 0 (depth >= DOMAIN_DEPTH[0], tilt below POINT_TILT[1]); elsewhere
    the numpy path's 0 x q_point is 0 (q is finite there: the blend is the learned answer).
    floats, ints: pack_improved's (the supported sizes, both networks, the gate's bounds).
    Fills the caller's point (n, 3) [m] in A, normal (n, 3) unit A->B and depth (n,) [m]
    (passed in: numba's boxing of three returned arrays costs ~0.65 us more per call than
    the caller's allocating them, which counts for one pair per call); returns (status, row)."""
    supported, params, dims, act, eparams, edims, eact, domain, has_expert = _unpack_improved(floats, ints)
    n = p.shape[0]
    status, row = check_inputs(p, R, sA, sB, supported)
    if status != 0:
        return status, row
    width = 0
    for i in range(1, dims.shape[0]):
        width = max(width, dims[i])
    for i in range(1, edims.shape[0]):
        width = max(width, edims[i])
    # the work arrays, as rows of a few allocations (for one pair, ~30 separate ones cost ~0.5 us)
    net, x = np.empty((2, max(width, 6))), np.empty(N_FEATURES)
    h0, h1, outs = net[0, :width], net[1, :width], np.empty((2, 6))
    y, ye = outs[0], outs[1]
    vec, mats = np.empty((15, 3)), np.empty((2, 3, 3))
    hA, hB, S, p_c, pe, ne, half, sigma = vec[0], vec[1], vec[2], vec[3], vec[4], vec[5], vec[6], vec[7]
    sat_n, q_point, q_normal, l_point, l_normal = vec[8], vec[9], vec[10], vec[11], vec[12]
    work = vec[13:15].reshape(6)
    R_c, RT = mats[0], mats[1]
    axes, overlap, dep = np.empty((15, 3)), np.empty(15), np.empty(MAX_VERTS)
    polys = np.empty((2, MAX_VERTS, 3))
    poly, tmp = polys[0], polys[1]
    frame, planes, items, q_poly = face_on_face_scratch()
    for r in range(n):
        ia = 0 if sA.shape[0] == 1 else r
        ib = 0 if sB.shape[0] == 1 else r
        for c in range(3):
            hA[c], hB[c] = 0.5 * sA[ia, c], 0.5 * sB[ib, c]
        # the separating axis in A's frame (testbed.geometry.boxes.sat_normal) picks the faces
        sat_overlap(p[r], R[r], hA, hB, axes, overlap)
        pen = sat_normal(p[r], axes, overlap, sat_n)[0]
        depth[r] = pen
        out = pen < DOMAIN_DEPTH[0] or pen > DOMAIN_DEPTH[1]
        f_point, f_normal = 0.0, 0.0
        tilt = face_tilt(R[r], sat_n)
        if pen < DOMAIN_DEPTH[0] or tilt >= POINT_TILT[1]:
            # both hand-over weights are 0: the numpy path's quadrature enters only as 0 x (a finite value)
            for c in range(3):
                q_point[c], q_normal[c] = 0.0, 0.0
            q_weight = 0.0
        else:
            q_weight, tilt = face_on_face(p[r], R[r], hA, hB, sat_n, frame, planes, items, q_poly, q_point, q_normal)
        if q_weight > 0.0:  # the faces meet (from DOMAIN_DEPTH[0] on; no upper bound)
            f_point = hand_over(tilt, POINT_TILT[0], POINT_TILT[1])
            f_normal = hand_over(tilt, NORMAL_TILT[0], NORMAL_TILT[1])
        if not (f_point < 1.0 or f_normal < 1.0):  # the quadrature alone: no network runs
            for c in range(3):
                point[r, c], normal[r, c] = q_point[c], q_normal[c]
            continue
        # the learned pipeline (ContactPredictor._learned)
        for c in range(3):
            l_point[c], l_normal[c] = 0.0, 0.0
        canonicalise(p[r], R[r], S, p_c, R_c)
        band_half_weights(p[r], SYMMETRY_BAND, half)
        for f in range(8):
            coef = 1.0
            for c in range(3):
                flip = (f >> (2 - c)) & 1
                coef = coef * (half[c] if flip else 1.0 - half[c])
                sigma[c] = -S[c] if flip else S[c]
            if not coef > 0.0:
                continue
            reflect(p[r], R[r], sigma, p_c, R_c)
            pen_c, k, weight = patch_estimate(p_c, R_c, hA, hB, work, RT, axes, overlap, poly, tmp, dep, pe, ne)
            features(x, p_c, R_c, hA, hB, overlap, pe, ne, pen_c, k, weight)
            w_main, w_expert = expert_weights(p_c, R_c, hA, hB, pen, overlap, domain, has_expert)  # the numpy path's depth
            if w_main > 0.0:
                mlp_forward(x, params, dims, act, h0, h1, y)
                for c in range(6):
                    y[c] = w_main * y[c]
            else:
                for c in range(6):
                    y[c] = 0.0
            if w_expert > 0.0:
                mlp_forward(x, eparams, edims, eact, h0, h1, ye)
                for c in range(6):
                    y[c] += w_expert * ye[c]
            for c in range(3):
                l_point[c] += coef * (sigma[c] * (pe[c] + POINT_STEP * y[c]))
                l_normal[c] += coef * (sigma[c] * (ne[c] + y[3 + c]))
        length2 = 0.0
        for c in range(3):
            length2 += l_normal[c] * l_normal[c]
        length = math.sqrt(length2)
        ok = math.isfinite(length) and length > 1e-9
        for c in range(3):
            l_normal[c] = l_normal[c] / length if ok else sat_n[c]
            v = l_point[c]
            if out:
                bound = hA[c] + CLIP_MARGIN
                v = min(max(v, -bound), bound)
            l_point[c] = v
        # the hand-over (weights 0 outside DOMAIN_DEPTH and where the faces do not meet)
        length2 = 0.0
        for c in range(3):
            point[r, c] = f_point * q_point[c] + (1.0 - f_point) * l_point[c]
            normal[r, c] = f_normal * q_normal[c] + (1.0 - f_normal) * l_normal[c]
            length2 += normal[r, c] * normal[r, c]
        length = math.sqrt(length2)
        for c in range(3):
            normal[r, c] = normal[r, c] / length
    return 0, 0


@njit(cache=True)
def _from_spherical(az, el, S, out):
    """out = S * (unit vector of [azimuth, elevation] in PAPER_FRAME) (encodings.from_spherical)."""
    w0, w1, w2 = math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)
    for k in range(3):
        out[k] = S[k] * (w0 * _FRAME[0, k] + w1 * _FRAME[1, k] + w2 * _FRAME[2, k])


@njit(cache=True)
def paper_predict(p, R, sA, sB, supported, params, dims, act, with_depth):
    """The paper's MLP (paper_mlp.PaperPredictor.predict): canonical position and
    roll-pitch-yaw in, spherical angles of the point direction and the force out; the
    point is where its ray leaves A. Returns (point (n, 3) [m], normal (n, 3), depth
    (n,) [m] (NaN unless with_depth), status, row)."""
    n = p.shape[0]
    point, normal, depth = np.empty((n, 3)), np.empty((n, 3)), np.full(n, np.nan)
    status, row = check_inputs(p, R, sA, sB, supported)
    if status != 0:
        return point, normal, depth, status, row
    width = 0
    for i in range(1, dims.shape[0]):
        width = max(width, dims[i])
    h0, h1, y, x = np.empty(width), np.empty(width), np.empty(4), np.empty(6)
    S, p_c, R_c, d = np.empty(3), np.empty(3), np.empty((3, 3)), np.empty(3)
    hA, hB, axes, overlap = np.empty(3), np.empty(3), np.empty((15, 3)), np.empty(15)
    for r in range(n):
        ia = 0 if sA.shape[0] == 1 else r
        canonicalise(p[r], R[r], S, p_c, R_c)
        det = (R_c[0, 0] * (R_c[1, 1] * R_c[2, 2] - R_c[1, 2] * R_c[2, 1])
               - R_c[0, 1] * (R_c[1, 0] * R_c[2, 2] - R_c[1, 2] * R_c[2, 0])
               + R_c[0, 2] * (R_c[1, 0] * R_c[2, 1] - R_c[1, 1] * R_c[2, 0]))
        flip = -1.0 if det < 0.0 else 1.0
        x[0], x[1], x[2] = p_c[0], p_c[1], p_c[2]
        x[3] = math.atan2(R_c[2, 1], R_c[2, 2] * flip)
        x[4] = math.asin(min(max(-R_c[2, 0], -1.0), 1.0))
        x[5] = math.atan2(R_c[1, 0], R_c[0, 0])
        mlp_forward(x, params, dims, act, h0, h1, y)
        _from_spherical(y[0], y[1], S, d)
        reach = 0.0
        for k in range(3):
            reach = max(reach, abs(d[k]) / (0.5 * sA[ia, k]))
        for k in range(3):
            point[r, k] = d[k] / reach
        _from_spherical(y[2], y[3], S, d)
        length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        for k in range(3):
            normal[r, k] = d[k] / length
        if with_depth:
            ib = 0 if sB.shape[0] == 1 else r
            for c in range(3):
                hA[c], hB[c] = 0.5 * sA[ia, c], 0.5 * sB[ib, c]
            depth[r] = sat_depth(p[r], R[r], hA, hB, axes, overlap)
    return point, normal, depth, 0, 0


@njit(cache=True)
def box_depth(p, R, sA, sB, supported):
    """(depth (n,) [m] separating-axis penetration, status, row)."""
    n = p.shape[0]
    depth = np.empty(n)
    status, row = check_inputs(p, R, sA, sB, supported)
    if status != 0:
        return depth, status, row
    hA, hB, axes, overlap = np.empty(3), np.empty(3), np.empty((15, 3)), np.empty(15)
    for r in range(n):
        ia = 0 if sA.shape[0] == 1 else r
        ib = 0 if sB.shape[0] == 1 else r
        for c in range(3):
            hA[c], hB[c] = 0.5 * sA[ia, c], 0.5 * sB[ib, c]
        depth[r] = sat_depth(p[r], R[r], hA, hB, axes, overlap)
    return depth, 0, 0


@njit(cache=True)
def improved_features(p, R, sA, sB):
    """(x (n, N_FEATURES), point_est (n, 3) [m], normal_est (n, 3)) in the canonical frame:
    encodings.features of canonicalised poses, compiled (no input checks; the MLP-free
    part of improved_predict, timed alone by the benchmark)."""
    n = p.shape[0]
    X, PE, NE = np.empty((n, N_FEATURES)), np.empty((n, 3)), np.empty((n, 3))
    hA, hB, S, p_c, R_c = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty((3, 3))
    work, RT, axes, overlap = np.empty(6), np.empty((3, 3)), np.empty((15, 3)), np.empty(15)
    poly, tmp, dep = np.empty((MAX_VERTS, 3)), np.empty((MAX_VERTS, 3)), np.empty(MAX_VERTS)
    for r in range(n):
        ia = 0 if sA.shape[0] == 1 else r
        ib = 0 if sB.shape[0] == 1 else r
        for c in range(3):
            hA[c], hB[c] = 0.5 * sA[ia, c], 0.5 * sB[ib, c]
        canonicalise(p[r], R[r], S, p_c, R_c)
        pen, k, weight = patch_estimate(p_c, R_c, hA, hB, work, RT, axes, overlap, poly, tmp, dep, PE[r], NE[r])
        features(X[r], p_c, R_c, hA, hB, overlap, PE[r], NE[r], pen, k, weight)
    return X, PE, NE
