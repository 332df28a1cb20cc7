"""The closed loop's per-step work as numba kernels (per-pair loops, one call per step):
plant state -> body poses, candidate pairs, the foundation force on the contact faces and
the wrenches of testbed/effects/learned_dynamics/effect.py (whose docstring states the law).

Frames: A is the first box's frame (origin at its centre, axes along its edges); p_AB
(3,) [m] and R_AB (3, 3) are B's pose in A; half extents hA, hB (3,) [m]. Compiled with
cache=True: a fresh process loads the machine code instead of compiling it.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def bodies_from_state(x, q_start, v_start, fixed_p, fixed_R, free):
    """Plant state x -> p (m, 3) [m], R (m, 3, 3), w (m, 3) [rad/s], v (m, 3) [m/s] of the body
    origins in W (quaternion floating joints: q = [w x y z, p], v = [w_W, v_W])."""
    m = len(free)
    p, R = fixed_p.copy(), fixed_R.copy()
    w, v = np.zeros((m, 3)), np.zeros((m, 3))
    for i in range(m):
        if not free[i]:
            continue
        q0 = q_start[i]
        a, b, c, d = x[q0], x[q0 + 1], x[q0 + 2], x[q0 + 3]
        s = 1.0 / (a * a + b * b + c * c + d * d)
        R[i, 0, 0] = 1 - 2 * s * (c * c + d * d)
        R[i, 0, 1] = 2 * s * (b * c - a * d)
        R[i, 0, 2] = 2 * s * (b * d + a * c)
        R[i, 1, 0] = 2 * s * (b * c + a * d)
        R[i, 1, 1] = 1 - 2 * s * (b * b + d * d)
        R[i, 1, 2] = 2 * s * (c * d - a * b)
        R[i, 2, 0] = 2 * s * (b * d - a * c)
        R[i, 2, 1] = 2 * s * (c * d + a * b)
        R[i, 2, 2] = 1 - 2 * s * (b * b + c * c)
        for k in range(3):
            p[i, k] = x[q0 + 4 + k]
            w[i, k] = x[v_start[i] + k]
            v[i, k] = x[v_start[i] + 3 + k]
    return p, R, w, v


@njit(cache=True)
def broad_phase(p, R, half, free, margin):
    """Candidate pairs by sort and sweep: (ia, ib) (k,) container indices, ia < ib, sorted by
    (ia, ib), of the pairs with one body free whose world axis-aligned boxes (|R| half about p,
    each grown by margin / 2 [m]) overlap on all three axes. The sweep runs along the world axis
    on which the boxes' centres spread most relative to their extents (a yard block's bays), so
    its work is about N log N plus the boxes that share that axis's interval. Every pair the
    narrow tests of near_pairs keep and whose boxes are not separated by margin along a world
    axis is listed (a pair separated so is at least margin apart, whatever near_pairs' face axes say)."""
    m = len(p)
    lo, hi = np.empty((m, 3)), np.empty((m, 3))
    for i in range(m):
        for a in range(3):
            e = 0.5 * margin
            for c in range(3):
                e += abs(R[i, a, c]) * half[i, c]
            lo[i, a], hi[i, a] = p[i, a] - e, p[i, a] + e
    axis, best = 0, -1.0
    for a in range(3):
        width = 0.0
        for i in range(m):
            width += hi[i, a] - lo[i, a]
        score = (np.max(p[:, a]) - np.min(p[:, a])) * m / max(width, 1e-12)
        if score > best:
            axis, best = a, score
    order = np.argsort(lo[:, axis])
    keys = []
    for s in range(m):
        i = order[s]
        for t in range(s + 1, m):
            j = order[t]
            if lo[j, axis] > hi[i, axis]:
                break
            if not (free[i] or free[j]):
                continue
            apart = False
            for a in range(3):
                if lo[j, a] > hi[i, a] or lo[i, a] > hi[j, a]:
                    apart = True
            if not apart:
                keys.append(min(i, j) * m + max(i, j))
    out = np.sort(np.array(keys, dtype=np.int64)) if len(keys) else np.zeros(0, np.int64)
    return out // m, out % m


@njit(cache=True)
def gather_pairs(ia, ib, n, keys, rows, type_index, kappa_tt):
    """Per pair (ia, ib (k,), keys ia * n + ib): its kappa (k,) [Pa/m] from kappa_tt (T, T) by the
    containers' type rows, and its stick anchors (k, 7) from the held (keys (s,) ascending,
    rows (s, 7)); zeros (not stuck) for a pair not held."""
    k = len(ia)
    kappa, held = np.empty(k), np.zeros((k, 7))
    at = np.searchsorted(keys, ia * n + ib)
    for r in range(k):
        kappa[r] = kappa_tt[type_index[ia[r]], type_index[ib[r]]]
        if at[r] < len(keys) and keys[at[r]] == ia[r] * n + ib[r]:
            held[r] = rows[at[r]]
    return kappa, held


@njit(cache=True)
def pack_anchors(ia, ib, n, anchors_next, stuck_next):
    """The anchors to hold for the next step: (keys (s,), rows (s, 7)) of the pairs whose
    stuck_next > 0, in the pairs' (ascending key) order."""
    s = 0
    for r in range(len(ia)):
        if stuck_next[r] > 0:
            s += 1
    keys, rows = np.empty(s, np.int64), np.empty((s, 7))
    s = 0
    for r in range(len(ia)):
        if stuck_next[r] > 0:
            keys[s] = ia[r] * n + ib[r]
            rows[s, :6] = anchors_next[r]
            rows[s, 6] = stuck_next[r]
            s += 1
    return keys, rows


@njit(cache=True)
def near_pairs(p, R, ia, ib, half, radius, free, margin):
    """Candidate pairs: one body free, bounding spheres within `margin` [m], and no face
    axis separating the boxes by more than `margin` (face_axis_overlap). Returns their
    indices into ia/ib (k,), p_AB (k, 3) [m] and R_AB (k, 3, 3). half: (m, 3) [m]."""
    n_pairs = len(ia)
    keep = np.zeros(n_pairs, np.int64)
    p_all, R_all = np.zeros((n_pairs, 3)), np.zeros((n_pairs, 3, 3))
    n = 0
    for k in range(n_pairs):
        i, j = ia[k], ib[k]
        if not (free[i] or free[j]):
            continue
        d2 = 0.0
        for c in range(3):
            d2 += (p[j, c] - p[i, c]) ** 2
        if d2 >= (radius[i] + radius[j] + margin) ** 2:
            continue
        for a in range(3):
            acc = 0.0
            for c in range(3):
                acc += R[i, c, a] * (p[j, c] - p[i, c])
                for e in range(3):
                    R_all[n, a, e] += R[i, c, a] * R[j, c, e]
            p_all[n, a] = acc
        if face_axis_overlap(p_all[n], R_all[n], half[i], half[j])[0] > -margin:
            keep[n] = k
            n += 1
        else:
            R_all[n] = 0.0
    return keep[:n], p_all[:n].copy(), R_all[:n].copy()


@njit(cache=True)
def face_axis_overlap(p_AB, R_AB, hA, hB):
    """The separating-axis test on the 6 face axes (A's 3, B's 3): (least overlap [m]
    (negative: separated by at least that), owner 0 = A / 1 = B, axis index)."""
    p_BA = -(R_AB.T @ p_AB)
    best, owner, axis = np.inf, 0, 0
    for k in range(3):
        o = hA[k] - abs(p_AB[k])
        for j in range(3):
            o += abs(R_AB[k, j]) * hB[j]
        if o < best:
            best, owner, axis = o, 0, k
    for j in range(3):
        o = hB[j] - abs(p_BA[j])
        for k in range(3):
            o += abs(R_AB[k, j]) * hA[k]
        if o < best - 1e-9:  # A's face on ties (aligned stacks)
            best, owner, axis = o, 1, j
    return best, owner, axis


@njit(cache=True)
def _positive_integral(a, b, lo, hi):
    """Integral of max(0, a + b x) dx over [lo, hi] (exact)."""
    if b == 0.0:
        return max(a, 0.0) * (hi - lo)
    x0 = -a / b
    x1, x2 = (max(lo, x0), hi) if b > 0 else (lo, min(hi, x0))
    if x2 <= x1:
        return 0.0
    return a * (x2 - x1) + 0.5 * b * (x2 * x2 - x1 * x1)


@njit(cache=True)
def _face_volume(p, R, hA, hB, k, s, grid):
    """Foundation integral over the overlap of A's face (axis k, side s = +-1) and B's
    facing face: (integral of max(0, depth) dA [m^3], overlap area [m^2]).

    The overlap is A's face rectangle intersected with the bounding rectangle of B's face
    projected on it (in A's in-face axes u, v); depth(u, v) is linear (B's face is a
    plane). It is integrated exactly along the axis where depth varies more and by the
    midpoint rule with `grid` points along the other, so tilts about one face axis are exact.
    """
    u, v = (k + 1) % 3, (k + 2) % 3
    j = 0
    for e in range(1, 3):
        if abs(R[k, e]) > abs(R[k, j]):
            j = e
    sigma = -1.0 if s * R[k, j] >= 0 else 1.0  # B's face outward normal = sigma * (B's axis j), towards A
    c_k = p[k] + sigma * hB[j] * R[k, j]
    c_u = p[u] + sigma * hB[j] * R[u, j]
    c_v = p[v] + sigma * hB[j] * R[v, j]
    j1, j2 = (j + 1) % 3, (j + 2) % 3
    ru = abs(R[u, j1]) * hB[j1] + abs(R[u, j2]) * hB[j2]
    rv = abs(R[v, j1]) * hB[j1] + abs(R[v, j2]) * hB[j2]
    lo_u, lo_v = max(-hA[u], c_u - ru), max(-hA[v], c_v - rv)
    w_u = max(min(hA[u], c_u + ru) - lo_u, 0.0)
    w_v = max(min(hA[v], c_v + rv) - lo_v, 0.0)
    if w_u == 0.0 or w_v == 0.0:
        return 0.0, 0.0
    b_k = sigma * R[k, j]
    if abs(b_k) < 1e-9:
        b_k = -s * 1e-9
    # depth(u, v) = d0 + g_u (u - c_u) + g_v (v - c_v), from B's face plane
    d0 = hA[k] - s * c_k
    g_u, g_v = s * sigma * R[u, j] / b_k, s * sigma * R[v, j] / b_k
    vol = 0.0
    if abs(g_u) * w_u >= abs(g_v) * w_v:  # exact along u, midpoint rule along v
        for q in range(grid):
            vv = lo_v + w_v * (q + 0.5) / grid
            vol += _positive_integral(d0 + g_v * (vv - c_v) - g_u * c_u, g_u, lo_u, lo_u + w_u)
        vol *= w_v / grid
    else:
        for q in range(grid):
            uu = lo_u + w_u * (q + 0.5) / grid
            vol += _positive_integral(d0 + g_u * (uu - c_u) - g_v * c_v, g_v, lo_v, lo_v + w_v)
        vol *= w_u / grid
    return vol, w_u * w_v


@njit(cache=True)
def elastic_one(p_AB, R_AB, hA, hB, kappa, grid):
    """One pair's elastic force (F_el [N], overlap area [m^2]), on the face pair the
    geometry selects: the face axis (A's 3, B's 3) of least overlap, the separating-axis
    test restricted to face axes (edge-on-edge contact is treated as a face contact)."""
    best, owner, axis = face_axis_overlap(p_AB, R_AB, hA, hB)
    p_BA = -(R_AB.T @ p_AB)
    if best <= 0:
        return 0.0, 0.0
    if owner == 0:
        vol, area = _face_volume(p_AB, R_AB, hA, hB, axis, 1.0 if p_AB[axis] >= 0 else -1.0, grid)
    else:
        vol, area = _face_volume(p_BA, R_AB.T.copy(), hB, hA, axis, 1.0 if p_BA[axis] >= 0 else -1.0, grid)
    return kappa * vol, area


@njit(cache=True)
def pair_wrenches(p, R, w, v, mass, I_Bo, ia, ib, kappa, point_A, normal_A, p_AB, R_AB, hA, hB,
                  dissipation, mu, slip, stiction, h, torsional, grid, anchors, stuck, stick_hw, stick_zeta):
    """The force law of learned_dynamics for k candidate pairs (ia, ib (k,) body indices).

    Friction: with stick_hw > 0 an anchored spring-damper (stick) capped at mu fn (slip);
    anchors (k, 6) are the stick's material points in A's and B's frames [m], stuck (k,)
    1.0 where they hold. Its tangential stiffness and damping follow from the pair's
    reduced mass m_red: k_t = stick_hw^2 m_red / h^2, c_t = 2 stick_zeta stick_hw m_red / h.
    With stick_hw = 0, the capped regularised law (slip, stiction).
    Returns out (m, 6) [N m, N]: torque about each body origin and force, in W; per pair
    fn (k,) [N] (0 = not touching), f_W (k, 3) [N] on B at p_W (k, 3) [m], n_W (k, 3),
    area (k,) [m^2]; and the next step's anchors (k, 6) and stuck (k,).
    """
    m, k = len(p), len(ia)
    out = np.zeros((m, 6))
    fn_all, f_all, p_all, n_all, area_all = np.zeros(k), np.zeros((k, 3)), np.zeros((k, 3)), np.zeros((k, 3)), np.zeros(k)
    anchors_next, stuck_next = np.zeros((k, 6)), np.zeros(k)
    for r in range(k):
        i, j = ia[r], ib[r]
        F_el, area = elastic_one(p_AB[r], R_AB[r], hA[r], hB[r], kappa[r], grid)
        if F_el <= 0:
            continue
        pw = p[i] + R[i] @ point_A[r]
        nw = R[i] @ normal_A[r]
        rA, rB = pw - p[i], pw - p[j]
        vrel = (v[j] + np.cross(w[j], rB)) - (v[i] + np.cross(w[i], rA))
        vn = vrel @ nw
        fn = F_el * max(0.0, 1.0 - dissipation * vn)
        f = fn * nw
        m_red = 1.0 / (1.0 / mass[i] + 1.0 / mass[j])
        tau = np.zeros(3)
        if mu > 0 and stick_hw > 0:
            vt = vrel - vn * nw
            d = np.zeros(3)
            if stuck[r] > 0:
                d = (p[j] + R[j] @ anchors[r, 3:]) - (p[i] + R[i] @ anchors[r, :3])
                d = d - (d @ nw) * nw
            k_t = stick_hw**2 * m_red / h**2
            ft = -k_t * d - (2.0 * stick_zeta * stick_hw * m_red / h) * vt
            mag, limit = np.sqrt(ft @ ft), mu * fn
            if mag > limit:  # slip: the force at the cone, the spring re-anchored to carry it
                ft = ft * (limit / mag)
                d = -ft / k_t
            f = f + ft
            anchors_next[r, :3] = R[i].T @ (pw - p[i])
            anchors_next[r, 3:] = R[j].T @ (pw + d - p[j])
            stuck_next[r] = 1.0
        elif mu > 0:
            vt = vrel - vn * nw
            speed = np.sqrt(vt @ vt)
            limit = mu * fn
            c = min(limit / slip, stiction * m_red / h)
            if speed > 0:
                c = min(c, limit / speed)
            f = f - c * vt
        if mu > 0 and torsional:
            rad = (2.0 / 3.0) * np.sqrt(area / np.pi)
            wn = (w[j] - w[i]) @ nw
            inv_I = 0.0
            for body in (i, j):
                if np.isfinite(mass[body]):
                    nb = R[body].T @ nw
                    inv_I += 1.0 / (nb @ (I_Bo[body] @ nb))
            tlim = mu * fn * rad
            ct = min(tlim * rad / slip, stiction / (inv_I * h))
            if wn != 0:
                ct = min(ct, tlim / abs(wn))
            tau = -ct * wn * nw
        tB = np.cross(rB, f) + tau
        tA = np.cross(rA, f) + tau
        for e in range(3):
            out[j, e] += tB[e]
            out[j, 3 + e] += f[e]
            out[i, e] -= tA[e]
            out[i, 3 + e] -= f[e]
        fn_all[r], area_all[r] = fn, area
        f_all[r], p_all[r], n_all[r] = f, pw, nw
    return out, fn_all, f_all, p_all, n_all, area_all, anchors_next, stuck_next
