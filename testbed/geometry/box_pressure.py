"""The exact static hydroelastic contact of two compliant boxes, at any pose (corners, edges, any yaw).

Drake meshes a compliant box with a tetrahedral mesh that conforms to its medial axis, and its
pressure field is E e(x) with e the distance to the boundary over the largest such distance (half
the smallest side; docs/truth.md). On each box that field is exactly linear inside each of six
cells, cell f holding the points nearer face f than any other:

    d_f(x) = h_f - s_f x_a  (face f = side s_f of axis a),   cell f = {x : 0 <= d_f(x) <= d_g(x) for every g}.

The compliant-compliant contact surface is where the two fields are equal, p_A = p_B, inside both
boxes. Inside one cell pair (f of A, g of B) both fields are linear, so the surface there is a flat
convex polygon: the plane p_A = p_B clipped by the twelve half-spaces of the two cells. Summed over
the cell pairs, the polygons are the surface Drake builds from its tetrahedra (the same linear
pieces, cut finer), and the integrals are exact: p is linear on each polygon, so its integral is p
at the centroid times the area, and its first moment (for the centre of pressure) a per-triangle
closed form. Nothing is sampled, so a corner that dips a millimetre is seen as surely as a face.

The normal stiffness here is the polygons' interior part only: moving B by dd along -n (deeper) moves
each polygon's plane and raises its pressure by kappa_c dd, kappa_c = (grad p_A . m)(grad p_B . n) /
((grad p_A - grad p_B) . m) with m the polygon's unit normal (for two faces meeting, E / (2 h): two
foundations in series), so sum kappa_c A_c m_c . n. The edges on cell boundaries move too and carry
pressure (neighbouring pieces meet at a kink, so their terms do not cancel): left out here, they make
this figure 1.3 % / 5.8 % off (median / p95) on stacking poses and 2.9 % / 20 % on general ones. The
native answer (native/src/step_field.c) adds them and agrees with a central difference to 4e-10;
tests judge the stiffness there, and use this module for the force, the moment and the centre of
pressure.

Frames: A's frame (origin at A's centre, axes along its edges); B's pose p_AB (n, 3) [m], R_AB
(n, 3, 3); half extents h_A, h_B (3,) or (n, 3) [m]; moduli [Pa].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# the six faces of a box: (axis, side)
FACES = tuple((a, s) for a in range(3) for s in (1.0, -1.0))
_TOL = 1e-12  # [m] a polygon vertex may violate a half-space by this much (round-off at the cells' edges)


@dataclass(frozen=True)
class BoxContact:
    """The static contact of each pose (n poses). force: (n, 3) [N] on B, in A's frame (the integral
    of p n over the surface, n from A into B); moment: (n, 3) [N m] about A's origin, in A's frame;
    cop: (n, 3) [m] the centre of pressure (NaN without a surface); area: (n,) [m^2];
    dforce_ddepth: (n, 3) [N/m], d(force)/d(depth) when B moves by -normal (deeper); normal:
    (n, 3) the force's unit direction (NaN without a surface); stiffness: (n,) [N/m] its component
    along `normal`; pieces: (n,) the number of cell pairs that carry part of the surface."""

    force: np.ndarray
    moment: np.ndarray
    cop: np.ndarray
    area: np.ndarray
    dforce_ddepth: np.ndarray
    normal: np.ndarray
    stiffness: np.ndarray
    pieces: np.ndarray


def _cell_halfspaces(h: np.ndarray, f: int) -> tuple[np.ndarray, np.ndarray]:
    """Cell f of a box with half extents h (n, 3), as rows a . x <= b in its own frame:
    (a (n, 6, 3), b (n, 6)): d_f >= 0 and d_f <= d_g for the five other faces g."""
    n = h.shape[0]
    axis, side = FACES[f]
    a = np.zeros((n, 6, 3))
    b = np.zeros((n, 6))
    # d_f >= 0:  s x_a <= h_a
    a[:, 0, axis] = side
    b[:, 0] = h[:, axis]
    row = 1
    for g, (ax_g, s_g) in enumerate(FACES):
        if g == f:
            continue
        # h_f - s_f x_af <= h_g - s_g x_ag  ->  s_g x_ag - s_f x_af <= h_g - h_f
        a[:, row, ax_g] += s_g
        a[:, row, axis] -= side
        b[:, row] = h[:, ax_g] - h[:, axis]
        row += 1
    return a, b


def _field_gradient(h: np.ndarray, f: int, modulus: float) -> tuple[np.ndarray, np.ndarray]:
    """p = E d_f / min(h) in cell f, as p = g . x + c: (g (n, 3), c (n,)) in the box's frame."""
    axis, side = FACES[f]
    scale = modulus / h.min(axis=1)  # (n,) [Pa/m]
    g = np.zeros((h.shape[0], 3))
    g[:, axis] = -side * scale
    return g, scale * h[:, axis]


def _aabb_prune(lo: np.ndarray, hi: np.ndarray, h: np.ndarray) -> np.ndarray:
    """(n, 6) bool: may cell f of a box (half extents h) meet the axis-aligned box [lo, hi] (n, 3),
    given in the same frame? A necessary condition: somewhere in [lo, hi] d_f <= d_g for each g
    separately (min of d_f <= max of d_g)."""
    min_abs = np.where((lo <= 0) & (hi >= 0), 0.0, np.minimum(np.abs(lo), np.abs(hi)))
    max_d = h - min_abs  # (n, 3): the largest d of either face of that axis over the box
    out = np.zeros((lo.shape[0], 6), dtype=bool)
    for f, (axis, side) in enumerate(FACES):
        min_df = h[:, axis] - (hi[:, axis] if side > 0 else -lo[:, axis])
        ok = np.ones(lo.shape[0], dtype=bool)
        for g, (ax_g, _) in enumerate(FACES):
            if g != f:
                ok &= min_df <= max_d[:, ax_g] + _TOL
        out[:, f] = ok
    return out


def _overlap_aabbs(p_AB, R_AB, h_A, h_B):
    """The axis-aligned bounds of B's box intersected with A's, in A's frame, and of A's intersected
    with B's, in B's frame: (lo_A, hi_A, lo_B, hi_B), each (n, 3) [m] (lo > hi on an axis: apart)."""
    ext_B_in_A = np.einsum("nij,nj->ni", np.abs(R_AB), h_B)
    lo_A = np.maximum(p_AB - ext_B_in_A, -h_A)
    hi_A = np.minimum(p_AB + ext_B_in_A, h_A)
    p_BA = -np.einsum("nji,nj->ni", R_AB, p_AB)
    ext_A_in_B = np.einsum("nji,nj->ni", np.abs(R_AB), h_A)
    lo_B = np.maximum(p_BA - ext_A_in_B, -h_B)
    hi_B = np.minimum(p_BA + ext_A_in_B, h_B)
    return lo_A, hi_A, lo_B, hi_B


def _polygon(plane_n, plane_c, A, b):
    """The convex polygon {x : plane_n . x = plane_c, A x <= b} for each of k problems, by vertex
    enumeration: every point where the plane meets two of the half-spaces' planes and that satisfies
    all. plane_n (k, 3) unit, plane_c (k,), A (k, m, 3), b (k, m). Returns (vertices (k, V, 3),
    valid (k, V)), V = m (m - 1) / 2, in no order."""
    k, m, _ = A.shape
    i, j = np.triu_indices(m, 1)
    M = np.stack([np.broadcast_to(plane_n[:, None, :], (k, len(i), 3)), A[:, i, :], A[:, j, :]], axis=2)  # (k, V, 3, 3)
    rhs = np.stack([np.broadcast_to(plane_c[:, None], (k, len(i))), b[:, i], b[:, j]], axis=2)  # (k, V, 3)
    det = np.linalg.det(M)
    ok = np.abs(det) > 1e-12
    M_safe = np.where(ok[..., None, None], M, np.eye(3))
    x = np.linalg.solve(M_safe, rhs[..., None])[..., 0]  # (k, V, 3)
    slack = np.einsum("kmc,kvc->kvm", A, x) - b[:, None, :]  # (k, V, m)
    scale = 1.0 + np.abs(b).max(axis=1)[:, None, None]
    valid = ok & np.all(slack <= _TOL * scale, axis=2)
    return x, valid


def _integrate(x, valid, plane_n, p_grad, p_const):
    """Area, integral of p, first moment of p (integral of p x) over each polygon given as unordered
    vertices: ordered by angle about their mean in the plane, then fanned into triangles.
    x (k, V, 3), valid (k, V), plane_n (k, 3), p = p_grad . x + p_const. Returns (area (k,),
    P (k,), Px (k, 3))."""
    k, V, _ = x.shape
    cnt = valid.sum(axis=1)
    w = valid.astype(float)
    centre = np.einsum("kv,kvc->kc", w, x) / np.maximum(cnt, 1)[:, None]
    # an in-plane basis
    t = np.where(np.abs(plane_n[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    e1 = np.cross(plane_n, t)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(plane_n, e1)
    r = x - centre[:, None, :]
    ang = np.arctan2(np.einsum("kvc,kc->kv", r, e2), np.einsum("kvc,kc->kv", r, e1))
    ang = np.where(valid, ang, np.inf)  # invalid vertices sort last
    order = np.argsort(ang, axis=1)
    xs = np.take_along_axis(x, order[..., None], axis=1)
    vs = np.take_along_axis(valid, order, axis=1)
    nxt = np.roll(xs, -1, axis=1)
    # the edge from the last valid vertex closes back to the first
    last = np.maximum(cnt - 1, 0)
    first = xs[:, 0, :]
    is_last = np.arange(V)[None, :] == last[:, None]
    nxt = np.where(is_last[..., None], first[:, None, :], nxt)
    tri = vs & (cnt[:, None] >= 3)
    a_, b_, c_ = centre[:, None, :], xs, nxt
    tri_area = 0.5 * np.einsum("kvc,kc->kv", np.cross(b_ - a_, c_ - a_), plane_n)
    tri_area = np.where(tri, np.abs(tri_area), 0.0)
    pa = np.einsum("kc,kc->k", p_grad, centre) + p_const
    pb = np.einsum("kvc,kc->kv", b_, p_grad) + p_const[:, None]
    pc = np.einsum("kvc,kc->kv", c_, p_grad) + p_const[:, None]
    area = tri_area.sum(axis=1)
    P = (tri_area * (pa[:, None] + pb + pc) / 3.0).sum(axis=1)
    Px = np.einsum("kv,kvc->kc", tri_area / 12.0,
                   (pa[:, None] + pb + pc)[..., None] * (a_ + b_ + c_) + pa[:, None, None] * a_ + pb[..., None] * b_ + pc[..., None] * c_)
    return area, P, Px


def box_box_contact(p_AB, R_AB, h_A, h_B, modulus_A: float = 1e8, modulus_B: float | None = None) -> BoxContact:
    """The exact static hydroelastic contact of compliant boxes A and B at each pose (module
    docstring). p_AB (n, 3) [m], R_AB (n, 3, 3), h_A, h_B (3,) or (n, 3) half extents [m]; moduli
    [Pa] (B's defaults to A's)."""
    p_AB = np.atleast_2d(np.asarray(p_AB, dtype=float))
    R_AB = np.asarray(R_AB, dtype=float).reshape(-1, 3, 3)
    n = p_AB.shape[0]
    h_A = np.broadcast_to(np.asarray(h_A, dtype=float), (n, 3))
    h_B = np.broadcast_to(np.asarray(h_B, dtype=float), (n, 3))
    E_B = modulus_A if modulus_B is None else modulus_B
    lo_A, hi_A, lo_B, hi_B = _overlap_aabbs(p_AB, R_AB, h_A, h_B)
    apart = np.any(lo_A > hi_A, axis=1) | np.any(lo_B > hi_B, axis=1)
    cells_A = _aabb_prune(lo_A, hi_A, h_A) & ~apart[:, None]
    cells_B = _aabb_prune(lo_B, hi_B, h_B) & ~apart[:, None]
    force = np.zeros((n, 3))
    moment = np.zeros((n, 3))
    P_sum = np.zeros(n)
    Px_sum = np.zeros((n, 3))
    area = np.zeros(n)
    J = np.zeros((n, 3, 3))  # d(force)/d(depth) = J u for B moved by -u
    pieces = np.zeros(n, dtype=int)
    for f in range(6):
        aA, bA = _cell_halfspaces(h_A, f)
        gA, cA = _field_gradient(h_A, f, modulus_A)
        for g in range(6):
            rows = np.flatnonzero(cells_A[:, f] & cells_B[:, g])
            if not len(rows):
                continue
            p, R = p_AB[rows], R_AB[rows]
            aB_B, bB = _cell_halfspaces(h_B[rows], g)
            gB_B, cB_B = _field_gradient(h_B[rows], g, E_B)
            # B's cell and field in A's frame: x_B = R^T (x_A - p)
            aB = np.einsum("kmc,kdc->kmd", aB_B, R)  # a_B . R^T (x - p) = (R a_B) . x - (R a_B) . p
            bB_A = bB + np.einsum("kmd,kd->km", aB, p)
            gB = np.einsum("kdc,kc->kd", R, gB_B)
            cB = cB_B - np.einsum("kd,kd->k", gB, p)
            diff = gA[rows] - gB  # p_A - p_B = diff . x + (cA - cB)
            norm = np.linalg.norm(diff, axis=1)
            # fields that (nearly) coincide carry no surface (a volume of p_A = p_B: native/src/step_field.c)
            live = norm > 1e-6 * (np.linalg.norm(gA[rows], axis=1) + np.linalg.norm(gB, axis=1))
            if not live.any():
                continue
            rows, diff, norm = rows[live], diff[live], norm[live]
            aB, bB_A, gB, cB = aB[live], bB_A[live], gB[live], cB[live]
            m_hat = -diff / norm[:, None]  # unit normal of the plane, from A into B (p_B grows along it)
            plane_c = (cA[rows] - cB) / norm  # m_hat . x = plane_c  (diff . x = cB - cA, m_hat = -diff / norm)
            A_all = np.concatenate([aA[rows], aB], axis=1)
            b_all = np.concatenate([bA[rows], bB_A], axis=1)
            x, valid = _polygon(m_hat, plane_c, A_all, b_all)
            ar, P, Px = _integrate(x, valid, m_hat, gA[rows], cA[rows])
            has = ar > 0
            if not has.any():
                continue
            rows, ar, P, Px, m_hat, gB = rows[has], ar[has], P[has], Px[has], m_hat[has], gB[has]
            diff_h = diff[has]
            F_c = P[:, None] * m_hat
            np.add.at(force, rows, F_c)
            np.add.at(moment, rows, np.cross(Px, m_hat))
            np.add.at(P_sum, rows, P)
            np.add.at(Px_sum, rows, Px)
            np.add.at(area, rows, ar)
            np.add.at(pieces, rows, 1)
            # pressure rise per depth when B moves by -u (u: the contact's normal, below): for a unit
            # displacement of B by -u, p_B(x) rises by gB . u; the plane moves so that p_A = p_B:
            # dp/dd = (gA . m)(gB . u) / ((gA - gB) . m) with (gA - gB) . m = -|diff| along m_hat
            gA_m = np.einsum("kc,kc->k", gA[rows], m_hat)
            dF_unit = (gA_m / np.einsum("kc,kc->k", diff_h, m_hat))[:, None, None] * gB[:, None, :]  # (k, 1, 3): times u
            np.add.at(J, rows, (ar[:, None, None] * m_hat[:, :, None]) * dF_unit)  # (k, 3, 3)
    with np.errstate(invalid="ignore", divide="ignore"):
        normal = force / np.linalg.norm(force, axis=1, keepdims=True)
        cop = Px_sum / P_sum[:, None]
    has = area > 0
    normal[~has] = np.nan
    cop[~has] = np.nan
    dF_dd = np.einsum("nij,nj->ni", J, np.nan_to_num(normal))
    stiffness = np.where(has, np.einsum("ni,ni->n", dF_dd, np.nan_to_num(normal)), 0.0)
    return BoxContact(force, moment, cop, area, dF_dd, normal, stiffness, pieces)

