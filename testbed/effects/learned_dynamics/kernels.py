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

ROW = 8  # a held pair's row: stick anchors in A and B [m] (6), stuck flag (1), last normal force [N] (1)
BODY = 12  # a body's history row: v_W [m/s] (3), w_W [rad/s] (3), the normal wrench applied [N m, N] (6)


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
    containers' type rows, and its held rows (k, ROW) from the held (keys (s,) ascending,
    rows (s, ROW): stick anchors (6) [m], stuck flag, the last step's normal force [N]); zeros
    (not stuck, no force) for a pair not held."""
    k = len(ia)
    kappa, held = np.empty(k), np.zeros((k, ROW))
    at = np.searchsorted(keys, ia * n + ib)
    for r in range(k):
        kappa[r] = kappa_tt[type_index[ia[r]], type_index[ib[r]]]
        if at[r] < len(keys) and keys[at[r]] == ia[r] * n + ib[r]:
            held[r] = rows[at[r]]
    return kappa, held


@njit(cache=True)
def pack_anchors(ia, ib, n, anchors_next, stuck_next, fn):
    """The rows to hold for the next step: (keys (s,), rows (s, ROW)) of the pairs whose
    stuck_next > 0 or whose normal force fn (k,) [N] is positive (the next step's warm start),
    in the pairs' (ascending key) order: anchors (6), stuck, fn."""
    s = 0
    for r in range(len(ia)):
        if stuck_next[r] > 0 or fn[r] > 0:
            s += 1
    keys, rows = np.empty(s, np.int64), np.empty((s, ROW))
    s = 0
    for r in range(len(ia)):
        if stuck_next[r] > 0 or fn[r] > 0:
            keys[s] = ia[r] * n + ib[r]
            rows[s, :6] = anchors_next[r]
            rows[s, 6] = stuck_next[r]
            rows[s, 7] = fn[r]
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
    p_BA = np.empty(3)
    for j in range(3):
        p_BA[j] = -(R_AB[0, j] * p_AB[0] + R_AB[1, j] * p_AB[1] + R_AB[2, j] * p_AB[2])
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
    """(integral of max(0, a + b x) dx over [lo, hi] (exact), length of [lo, hi] where a + b x > 0)."""
    if b == 0.0:
        return (a * (hi - lo), hi - lo) if a > 0 else (0.0, 0.0)
    x0 = -a / b
    x1, x2 = (max(lo, x0), hi) if b > 0 else (lo, min(hi, x0))
    if x2 <= x1:
        return 0.0, 0.0
    return a * (x2 - x1) + 0.5 * b * (x2 * x2 - x1 * x1), x2 - x1


@njit(cache=True)
def _face_volume(p, R, hA, hB, k, s, grid):
    """Foundation integral over the overlap of A's face (axis k, side s = +-1) and B's
    facing face: (integral of max(0, depth) dA [m^3], overlap area [m^2], wetted area [m^2]:
    where depth > 0, the derivative of the integral with respect to a uniform approach).

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
        return 0.0, 0.0, 0.0
    b_k = sigma * R[k, j]
    if abs(b_k) < 1e-9:
        b_k = -s * 1e-9
    # depth(u, v) = d0 + g_u (u - c_u) + g_v (v - c_v), from B's face plane
    d0 = hA[k] - s * c_k
    g_u, g_v = s * sigma * R[u, j] / b_k, s * sigma * R[v, j] / b_k
    vol, wet = 0.0, 0.0
    if abs(g_u) * w_u >= abs(g_v) * w_v:  # exact along u, midpoint rule along v
        for q in range(grid):
            vv = lo_v + w_v * (q + 0.5) / grid
            a, b = _positive_integral(d0 + g_v * (vv - c_v) - g_u * c_u, g_u, lo_u, lo_u + w_u)
            vol, wet = vol + a, wet + b
        vol, wet = vol * w_v / grid, wet * w_v / grid
    else:
        for q in range(grid):
            uu = lo_u + w_u * (q + 0.5) / grid
            a, b = _positive_integral(d0 + g_u * (uu - c_u) - g_v * c_v, g_v, lo_v, lo_v + w_v)
            vol, wet = vol + a, wet + b
        vol, wet = vol * w_u / grid, wet * w_u / grid
    return vol, w_u * w_v, wet


@njit(cache=True)
def elastic_one(p_AB, R_AB, hA, hB, kappa, grid):
    """One pair's elastic force (F_el [N], overlap area [m^2]), on the face pair the
    geometry selects: the face axis (A's 3, B's 3) of least overlap, the separating-axis
    test restricted to face axes (edge-on-edge contact is treated as a face contact)."""
    F_el, area, _ = elastic_stiff(p_AB, R_AB, hA, hB, kappa, grid)
    return F_el, area


@njit(cache=True)
def elastic_stiff(p_AB, R_AB, hA, hB, kappa, grid):
    """elastic_one's (F_el [N], overlap area [m^2]) and the normal stiffness k = dF_el/dd
    [N/m] = kappa x the wetted area (where the depth is positive) of that face pair."""
    best, owner, axis = face_axis_overlap(p_AB, R_AB, hA, hB)
    if best <= 0:
        return 0.0, 0.0, 0.0
    if owner == 0:
        vol, area, wet = _face_volume(p_AB, R_AB, hA, hB, axis, 1.0 if p_AB[axis] >= 0 else -1.0, grid)
    else:
        p_BA = np.empty(3)
        for a in range(3):
            p_BA[a] = -(R_AB[0, a] * p_AB[0] + R_AB[1, a] * p_AB[1] + R_AB[2, a] * p_AB[2])
        vol, area, wet = _face_volume(p_BA, R_AB.T.copy(), hB, hA, axis, 1.0 if p_BA[axis] >= 0 else -1.0, grid)
    return kappa * vol, area, kappa * wet


@njit(cache=True)
def _inverse_inertias(R, mass, I_Bo, need):
    """(inv_m (m,) [1/kg], invI_W (m, 3, 3) [1/(kg m^2)]): for the bodies marked need (m,) and
    free (finite mass), 1 / mass and R I_Bo^-1 R^T, the inverse rotational inertia about the
    body origin in W; zeros for the others (a fixed body does not move)."""
    m = len(mass)
    inv_m, invI = np.zeros(m), np.zeros((m, 3, 3))
    for i in range(m):
        if not need[i] or not np.isfinite(mass[i]):
            continue
        inv_m[i] = 1.0 / mass[i]
        I = I_Bo[i]
        c00 = I[1, 1] * I[2, 2] - I[1, 2] * I[2, 1]
        c01 = I[1, 2] * I[2, 0] - I[1, 0] * I[2, 2]
        c02 = I[1, 0] * I[2, 1] - I[1, 1] * I[2, 0]
        det = I[0, 0] * c00 + I[0, 1] * c01 + I[0, 2] * c02
        B = np.empty((3, 3))  # I_Bo^-1 (adjugate / det)
        B[0, 0], B[1, 0], B[2, 0] = c00 / det, c01 / det, c02 / det
        B[0, 1] = (I[0, 2] * I[2, 1] - I[0, 1] * I[2, 2]) / det
        B[0, 2] = (I[0, 1] * I[1, 2] - I[0, 2] * I[1, 1]) / det
        B[1, 1] = (I[0, 0] * I[2, 2] - I[0, 2] * I[2, 0]) / det
        B[1, 2] = (I[0, 2] * I[1, 0] - I[0, 0] * I[1, 2]) / det
        B[2, 1] = (I[0, 1] * I[2, 0] - I[0, 0] * I[2, 1]) / det
        B[2, 2] = (I[0, 0] * I[1, 1] - I[0, 1] * I[1, 0]) / det
        Ri = R[i]
        for a in range(3):
            for b in range(3):
                acc = 0.0
                for c in range(3):
                    for e in range(3):
                        acc += Ri[a, c] * B[c, e] * Ri[b, e]
                invI[i, a, b] = acc
    return inv_m, invI


@njit(cache=True)
def _apply(acc, i, sign, inv_m, invI, f, n, c):
    """acc[i] += sign M_i^-1 (the wrench of a force f [N] along unit n whose moment arm term
    about body i's origin is c = r x n [m]): angular (0:3) [rad/s^2] and linear (3:6) [m/s^2]."""
    for a in range(3):
        acc[i, 3 + a] += sign * inv_m[i] * f * n[a]
        acc[i, a] += sign * f * (invI[i, a, 0] * c[0] + invI[i, a, 1] * c[1] + invI[i, a, 2] * c[2])


@njit(cache=True)
def _normal_rate(acc, i, j, r_A, r_B, n):
    """(a_B + alpha_B x r_B - a_A - alpha_A x r_A) . n [m/s^2] from body accelerations acc
    (m, 6) (angular, linear) of A = i and B = j at the contact point (lever arms r_A, r_B)."""
    out = 0.0
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        out += n[a] * (acc[j, 3 + a] + acc[j, b] * r_B[c] - acc[j, c] * r_B[b]
                       - acc[i, 3 + a] - (acc[i, b] * r_A[c] - acc[i, c] * r_A[b]))
    return out


@njit(cache=True)
def pair_wrenches(p, R, w, v, mass, I_Bo, ia, ib, kappa, point_A, normal_A, p_AB, R_AB, hA, hB,
                  dissipation, mu, slip, stiction, h, torsional, grid, anchors, stuck, stick_hw, stick_zeta,
                  fn_prev, history, sweeps):
    """The force law of learned_dynamics for k candidate pairs (ia, ib (k,) body indices).

    Normal force, linearly implicit (README.md beside this file derives it): per touching pair
    (F_el > 0) the backward-Euler Winkler-Hunt-Crossley force at the next step's penetration
    and normal rate, f = F_el - g vn', g = k h + d F_el [N s/m], k = dF_el/dd = kappa x wetted
    area [N/m], vn' = vn + h an' the normal rate [m/s] after this step, with an' the normal
    acceleration at the point from the other forces (estimated from the last step: history)
    and from every pair's f through the bodies' inverse masses and inertias (the Delassus
    operator); solved by `sweeps` projected Gauss-Seidel sweeps (f >= 0) warm-started from
    fn_prev (k,) [N], the pairs' last normal forces. history (m, BODY): each body's velocities
    v_W, w_W at the last step and the normal wrench (torque about its origin, force; W) this
    law applied then; a row of NaN = no last step (the other forces' acceleration taken as 0).

    Friction: with stick_hw > 0 an anchored spring-damper (stick) capped at mu fn (slip);
    anchors (k, 6) are the stick's material points in A's and B's frames [m], stuck (k,)
    1.0 where they hold. Its tangential stiffness and damping follow from the pair's
    reduced mass m_red: k_t = stick_hw^2 m_red / h^2, c_t = 2 stick_zeta stick_hw m_red / h.
    With stick_hw = 0, the capped regularised law (slip, stiction). Both explicit.
    Returns out (m, 6) [N m, N]: torque about each body origin and force, in W; per pair
    fn (k,) [N] (0 = not touching), f_W (k, 3) [N] on B at p_W (k, 3) [m], n_W (k, 3),
    area (k,) [m^2]; the next step's anchors (k, 6) and stuck (k,); and the next history (m, BODY).
    """
    m, k = len(p), len(ia)
    out = np.zeros((m, 6))
    fn_all, f_all, p_all, n_all, area_all = np.zeros(k), np.zeros((k, 3)), np.zeros((k, 3)), np.zeros((k, 3)), np.zeros(k)
    anchors_next, stuck_next = np.zeros((k, 6)), np.zeros(k)
    history_next = np.zeros((m, BODY))
    for i in range(m):
        for a in range(3):
            history_next[i, a], history_next[i, 3 + a] = v[i, a], w[i, a]
    # pass 1: geometry, the free normal rate, the implicit gains
    touch = np.zeros(k, np.bool_)
    need = np.zeros(m, np.bool_)
    F_el, g, W_rr, vn0, an_ext = np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(k)
    rA_all, rB_all, cA_all, cB_all = np.zeros((k, 3)), np.zeros((k, 3)), np.zeros((k, 3)), np.zeros((k, 3))
    for r in range(k):
        F, area, k_n = elastic_stiff(p_AB[r], R_AB[r], hA[r], hB[r], kappa[r], grid)
        if F <= 0:
            continue
        i, j = ia[r], ib[r]
        touch[r], need[i], need[j] = True, True, True
        F_el[r], area_all[r] = F, area
        g[r] = k_n * h + dissipation * F
        for a in range(3):
            p_all[r, a] = p[i, a] + R[i, a, 0] * point_A[r, 0] + R[i, a, 1] * point_A[r, 1] + R[i, a, 2] * point_A[r, 2]
            n_all[r, a] = R[i, a, 0] * normal_A[r, 0] + R[i, a, 1] * normal_A[r, 1] + R[i, a, 2] * normal_A[r, 2]
        for a in range(3):
            rA_all[r, a], rB_all[r, a] = p_all[r, a] - p[i, a], p_all[r, a] - p[j, a]
    inv_m, invI = _inverse_inertias(R, mass, I_Bo, need)
    acc = np.zeros((m, 6))  # the other forces' accelerations (angular, linear) of the bodies in contact
    for i in range(m):
        if need[i] and np.isfinite(mass[i]) and np.isfinite(history[i, 0]):
            for a in range(3):
                acc[i, 3 + a] = (v[i, a] - history[i, a]) / h - inv_m[i] * history[i, 9 + a]
                acc[i, a] = (w[i, a] - history[i, 3 + a]) / h - (
                    invI[i, a, 0] * history[i, 6] + invI[i, a, 1] * history[i, 7] + invI[i, a, 2] * history[i, 8])
    for r in range(k):
        if not touch[r]:
            continue
        i, j = ia[r], ib[r]
        n, rA, rB = n_all[r], rA_all[r], rB_all[r]
        vn = 0.0
        for a in range(3):
            b, c = (a + 1) % 3, (a + 2) % 3
            cA_all[r, a] = rA[b] * n[c] - rA[c] * n[b]
            cB_all[r, a] = rB[b] * n[c] - rB[c] * n[b]
            vn += n[a] * (v[j, a] + w[j, b] * rB[c] - w[j, c] * rB[b] - v[i, a] - (w[i, b] * rA[c] - w[i, c] * rA[b]))
        vn0[r] = vn
        an_ext[r] = _normal_rate(acc, i, j, rA, rB, n)
        wr = inv_m[i] + inv_m[j]
        for a in range(3):
            for b in range(3):
                wr += cA_all[r, a] * invI[i, a, b] * cA_all[r, b] + cB_all[r, a] * invI[j, a, b] * cB_all[r, b]
        W_rr[r] = wr
    # projected Gauss-Seidel on f_r = max(0, F_el - g (vn + h an)), an through every pair's f
    f = np.zeros(k)
    dacc = np.zeros((m, 6))  # the bodies' accelerations from the normal forces f
    for r in range(k):
        if touch[r] and fn_prev[r] > 0:
            f[r] = fn_prev[r]
            _apply(dacc, ib[r], 1.0, inv_m, invI, f[r], n_all[r], cB_all[r])
            _apply(dacc, ia[r], -1.0, inv_m, invI, f[r], n_all[r], cA_all[r])
    for _ in range(sweeps):
        for r in range(k):
            if not touch[r]:
                continue
            i, j = ia[r], ib[r]
            an = an_ext[r] + _normal_rate(dacc, i, j, rA_all[r], rB_all[r], n_all[r])
            residual = F_el[r] - g[r] * (vn0[r] + h * an) - f[r]
            f_new = max(0.0, f[r] + residual / (1.0 + g[r] * h * W_rr[r]))
            df = f_new - f[r]
            if df != 0.0:
                _apply(dacc, j, 1.0, inv_m, invI, df, n_all[r], cB_all[r])
                _apply(dacc, i, -1.0, inv_m, invI, df, n_all[r], cA_all[r])
                f[r] = f_new
    # pass 2: friction on the solved normal force, the wrenches
    for r in range(k):
        if not touch[r]:
            continue
        i, j = ia[r], ib[r]
        fn, nw = f[r], n_all[r]
        rA, rB = rA_all[r], rB_all[r]
        for a in range(3):
            history_next[j, 6 + a] += fn * cB_all[r, a]
            history_next[j, 9 + a] += fn * nw[a]
            history_next[i, 6 + a] -= fn * cA_all[r, a]
            history_next[i, 9 + a] -= fn * nw[a]
        vrel = np.empty(3)
        for a in range(3):
            b, c = (a + 1) % 3, (a + 2) % 3
            vrel[a] = v[j, a] + w[j, b] * rB[c] - w[j, c] * rB[b] - v[i, a] - (w[i, b] * rA[c] - w[i, c] * rA[b])
        vn = vn0[r]
        fx, fy, fz = fn * nw[0], fn * nw[1], fn * nw[2]
        m_red = 1.0 / (1.0 / mass[i] + 1.0 / mass[j])
        tau = np.zeros(3)
        if mu > 0 and stick_hw > 0:
            vt = np.empty(3)
            d = np.zeros(3)
            for a in range(3):
                vt[a] = vrel[a] - vn * nw[a]
            if stuck[r] > 0:
                dn = 0.0
                for a in range(3):
                    d[a] = (p[j, a] + R[j, a, 0] * anchors[r, 3] + R[j, a, 1] * anchors[r, 4] + R[j, a, 2] * anchors[r, 5]) - (
                        p[i, a] + R[i, a, 0] * anchors[r, 0] + R[i, a, 1] * anchors[r, 1] + R[i, a, 2] * anchors[r, 2])
                    dn += d[a] * nw[a]
                for a in range(3):
                    d[a] -= dn * nw[a]
            k_t = stick_hw**2 * m_red / h**2
            c_t = 2.0 * stick_zeta * stick_hw * m_red / h
            ft = np.empty(3)
            mag2 = 0.0
            for a in range(3):
                ft[a] = -k_t * d[a] - c_t * vt[a]
                mag2 += ft[a] * ft[a]
            mag, limit = np.sqrt(mag2), mu * fn
            if mag > limit:  # slip: the force at the cone, the spring re-anchored to carry it
                for a in range(3):
                    ft[a] *= limit / mag
                    d[a] = -ft[a] / k_t
            fx, fy, fz = fx + ft[0], fy + ft[1], fz + ft[2]
            for a in range(3):
                anchors_next[r, a] = R[i, 0, a] * rA[0] + R[i, 1, a] * rA[1] + R[i, 2, a] * rA[2]
                anchors_next[r, 3 + a] = R[j, 0, a] * (rB[0] + d[0]) + R[j, 1, a] * (rB[1] + d[1]) + R[j, 2, a] * (rB[2] + d[2])
            stuck_next[r] = 1.0
        elif mu > 0:
            vt = np.empty(3)
            speed2 = 0.0
            for a in range(3):
                vt[a] = vrel[a] - vn * nw[a]
                speed2 += vt[a] * vt[a]
            speed = np.sqrt(speed2)
            limit = mu * fn
            c = min(limit / slip, stiction * m_red / h)
            if speed > 0:
                c = min(c, limit / speed)
            fx, fy, fz = fx - c * vt[0], fy - c * vt[1], fz - c * vt[2]
        if mu > 0 and torsional:
            rad = (2.0 / 3.0) * np.sqrt(area_all[r] / np.pi)
            wn = 0.0
            for a in range(3):
                wn += (w[j, a] - w[i, a]) * nw[a]
            inv_I = 0.0
            for body in (i, j):
                if np.isfinite(mass[body]):
                    Rb = R[body]
                    nb = np.empty(3)
                    for a in range(3):
                        nb[a] = Rb[0, a] * nw[0] + Rb[1, a] * nw[1] + Rb[2, a] * nw[2]
                    q = 0.0
                    for a in range(3):
                        for b in range(3):
                            q += nb[a] * I_Bo[body, a, b] * nb[b]
                    inv_I += 1.0 / q
            tlim = mu * fn * rad
            ct = min(tlim * rad / slip, stiction / (inv_I * h))
            if wn != 0:
                ct = min(ct, tlim / abs(wn))
            for a in range(3):
                tau[a] = -ct * wn * nw[a]
        fv = (fx, fy, fz)
        for a in range(3):
            b, c = (a + 1) % 3, (a + 2) % 3
            tB = rB[b] * fv[c] - rB[c] * fv[b] + tau[a]
            tA = rA[b] * fv[c] - rA[c] * fv[b] + tau[a]
            out[j, a] += tB
            out[j, 3 + a] += fv[a]
            out[i, a] -= tA
            out[i, 3 + a] -= fv[a]
            f_all[r, a] = fv[a]
        fn_all[r] = fn
    return out, fn_all, f_all, p_all, n_all, area_all, anchors_next, stuck_next, history_next
