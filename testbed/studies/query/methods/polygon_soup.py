"""Query-study methods of the paper's polygon-soup baseline (RAPID), rebuilt on python-fcl.

Each box is triangulated with N divisions per edge: N^2 squares and 2N^2 triangles per
face, 12 N^2 triangles per box (the paper's Table 3 column "Triangles/face" holds this
per-box count: 768 for N = 8). python-fcl (FCL 0.7, OBBRSS bounding-volume trees) finds
every intersecting triangle pair; the contact answer is then estimated from the pairs:

- point (estimator "centroids", the paper's way: only the list of colliding triangles
  is used, so the triangle size limits the accuracy): the centroids of the colliding
  triangles of both boxes are projected onto the plane normal to the estimated
  normal, their 2-D convex hull is taken, and the point is the hull's area centroid,
  lifted back to the mean height of the centroids along the normal. The centroids lie
  within a triangle size of the rim of the contact patch, so the point converges to
  the patch's area centroid (the centre of pressure of uniform-depth face contact)
  as N grows, with an error of the order of the triangle size.
- point (estimator "segments", what today's tools allow): the segment where each
  colliding pair of triangles crosses is computed (numpy, all pairs at once); its end
  points lie exactly on the rim, so the hull centroid is exact for flat patches at any
  N. FCL's own contact positions are not used: for triangle pairs they are triangle
  vertices, up to a triangle size off the rim.
  With fewer than 3 distinct points or a degenerate hull, their mean is used;
- normal: every colliding pair votes for the outward normal of its A triangle's face
  and for the reversed normal of its B triangle's face (expressed in A); the face
  normal with the most votes is the answer (A->B). For face and vertex contact one
  face is shared by all pairs; for edge-edge contact the answer is one of the four
  faces (up to 45 deg off), the baseline's inherent limit.

Frames: A is the reference box, at the origin of its own frame with its edges along
the axes; B's pose in A is (p_AB (3,) [m], R_AB (3, 3)). Results are in A's frame.

FCL does not expose its count of bounding-volume or leaf tests to Python. The paper's
Table 4 counts RAPID's triangle-intersection tests; `candidate_pairs` gives the
comparable figure of an ideal axis-aligned tree: the triangle pairs whose axis-aligned
bounds (in A) overlap, i.e. the leaf tests such a tree cannot avoid.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from testbed.errors import OptionalDependencyError
from testbed.studies.query.methods.base import ContactMethod, missing

ORDER = 20


def _fcl():
    try:
        import fcl
    except ImportError:  # pragma: no cover - depends on the environment
        raise OptionalDependencyError("python-fcl", "the polygon-soup baseline of the query study", "study") from None
    return fcl


def box_triangles(size, n: int):
    """Surface triangulation of a box of full extents `size` (3,) [m], centred at the origin.

    n: divisions per edge (every edge, whatever its length, as in the paper).
    Returns (vertices (6 (n+1)^2, 3) [m], triangles (12 n^2, 3) int, counter-clockwise
    seen from outside, normals (12 n^2, 3) outward unit face normals).
    """
    if n < 1:
        raise ValueError(f"need n >= 1 divisions per edge, got {n}")
    h = 0.5 * np.asarray(size, dtype=float)
    g = np.linspace(-1.0, 1.0, n + 1)
    U, V = np.meshgrid(g, g, indexing="ij")
    verts, tris, normals = [], [], []
    offset = 0
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for sign in (-1.0, 1.0):
            P = np.zeros((n + 1, n + 1, 3))
            P[..., axis] = sign * h[axis]
            P[..., u] = U * h[u]
            P[..., v] = V * h[v]
            idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1) + offset
            a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
            t = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])  # (2 n^2, 3)
            if sign < 0:  # (u, v, axis) is right-handed: flip winding on the negative face
                t = t[:, ::-1]
            nrm = np.zeros((len(t), 3))
            nrm[:, axis] = sign
            verts.append(P.reshape(-1, 3))
            tris.append(t)
            normals.append(nrm)
            offset += (n + 1) ** 2
    return np.concatenate(verts), np.concatenate(tris), np.concatenate(normals)


ESTIMATORS = ("centroids", "segments")
# Outward normals of the 6 faces in box_triangles' order (-x, +x, -y, +y, -z, +z).
FACE_NORMALS = np.array([[-1.0, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]])


class SoupAnswer(NamedTuple):
    """One polygon-soup query. point (3,) [m] and unit normal (3,) A->B in A's frame
    (NaN when no pair collides); n_pairs: colliding triangle pairs found."""

    point: np.ndarray
    normal: np.ndarray
    n_pairs: int


def _plane_crossing(tri, n, d):
    """End points of the segment where triangles tri (k, 3, 3) cross the planes
    {x : n.x = d} (n (k, 3), d (k,)). Returns (points (k, 3 edges, 3), valid (k, 3))."""
    s = np.einsum("kvi,ki->kv", tri, n) - d[:, None]  # (k, 3) signed distances
    i, j = np.array([0, 1, 2]), np.array([1, 2, 0])
    si, sj = s[:, i], s[:, j]
    denom = si - sj
    valid = (si * sj <= 0.0) & (denom != 0.0)
    w = np.where(valid, si / np.where(denom != 0.0, denom, 1.0), 0.0)  # (k, 3)
    pts = tri[:, i] + w[..., None] * (tri[:, j] - tri[:, i])
    return pts, valid


def crossing_segments(tri_a, tri_b) -> np.ndarray:
    """Segments where triangle pairs cross: tri_a, tri_b (k, 3, 3) [m] in one frame.

    Returns (k, 2, 3) [m]: the end points of each pair's crossing segment; NaN rows for
    pairs that do not cross or are coplanar (parallel planes).
    """
    n_a = np.cross(tri_a[:, 1] - tri_a[:, 0], tri_a[:, 2] - tri_a[:, 0])  # (k, 3)
    n_b = np.cross(tri_b[:, 1] - tri_b[:, 0], tri_b[:, 2] - tri_b[:, 0])
    line = np.cross(n_a, n_b)  # direction of the planes' common line
    ok = np.linalg.norm(line, axis=1) > 1e-12 * np.linalg.norm(n_a, axis=1) * np.linalg.norm(n_b, axis=1)
    pa, va = _plane_crossing(tri_a, n_b, np.einsum("ki,ki->k", n_b, tri_b[:, 0]))
    pb, vb = _plane_crossing(tri_b, n_a, np.einsum("ki,ki->k", n_a, tri_a[:, 0]))
    ta = np.einsum("kei,ki->ke", pa, line)  # (k, 3) positions along the line
    tb = np.einsum("kei,ki->ke", pb, line)
    big = np.inf
    a_lo, a_hi = np.where(va, ta, big).argmin(1), np.where(va, ta, -big).argmax(1)
    b_lo, b_hi = np.where(vb, tb, big).argmin(1), np.where(vb, tb, -big).argmax(1)
    r = np.arange(len(ta))
    lo = np.where((ta[r, a_lo] >= tb[r, b_lo])[:, None], pa[r, a_lo], pb[r, b_lo])
    hi = np.where((ta[r, a_hi] <= tb[r, b_hi])[:, None], pa[r, a_hi], pb[r, b_hi])
    t_lo = np.maximum(ta[r, a_lo], tb[r, b_lo])
    t_hi = np.minimum(ta[r, a_hi], tb[r, b_hi])
    ok &= va.any(1) & vb.any(1) & (t_lo <= t_hi)
    out = np.stack([lo, hi], axis=1)
    out[~ok] = np.nan
    return out


def _hull_2d(xy: np.ndarray) -> np.ndarray:
    """Indices of the convex hull of points xy (m, 2), counter-clockwise (monotone chain)."""
    order = np.lexsort((xy[:, 1], xy[:, 0]))
    pts = xy[order].tolist()

    def half(seq):
        out = []
        for i, (x, y) in seq:
            while len(out) >= 2:
                (_, (x1, y1)), (_, (x2, y2)) = out[-2], out[-1]
                if (x2 - x1) * (y - y1) - (y2 - y1) * (x - x1) > 0.0:
                    break
                out.pop()
            out.append((i, (x, y)))
        return out

    items = list(zip(order.tolist(), pts))
    lower, upper = half(items), half(items[::-1])
    return np.array([i for i, _ in lower[:-1] + upper[:-1]], dtype=np.intp)


def patch_centroid(points, normal) -> np.ndarray:
    """Area centroid (3,) [m] of the convex hull of `points` (k, 3) [m] seen along the
    unit `normal` (3,); the mean of the points when the hull is degenerate."""
    points = np.asarray(points, dtype=float)
    mean = points.mean(axis=0)
    if len(points) < 3 or not np.all(np.isfinite(normal)):
        return mean
    # orthonormal basis (e1, e2) of the plane normal to `normal`
    helper = np.array([1.0, 0, 0]) if abs(normal[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = helper - (helper @ normal) * normal
    e1 /= np.linalg.norm(e1)
    e2 = np.array([normal[1] * e1[2] - normal[2] * e1[1], normal[2] * e1[0] - normal[0] * e1[2],
                   normal[0] * e1[1] - normal[1] * e1[0]])
    rel = points - mean
    xy = np.stack([rel @ e1, rel @ e2], axis=1)  # (k, 2)
    hull = xy[_hull_2d(xy)]
    if len(hull) < 3:
        return mean
    x, y = hull[:, 0], hull[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = 0.5 * cross.sum()
    if abs(area) < 1e-12:
        return mean
    cx = ((x + xn) * cross).sum() / (6.0 * area)
    cy = ((y + yn) * cross).sum() / (6.0 * area)
    return mean + cx * e1 + cy * e2


@functools.lru_cache(maxsize=None)
def _mesh(size: tuple, n: int):
    fcl = _fcl()
    V, T, normals = box_triangles(size, n)
    model = fcl.BVHModel()
    model.beginModel(len(V), len(T))
    model.addSubModel(V, T)
    model.endModel()
    return model, V, T, normals


class PolygonSoupPair:
    """Two triangulated boxes A (fixed at the origin) and B (posed per query).

    size_A, size_B (3,): full extents [m]; n: divisions per edge. The BVH of each box is
    built once and shared by every pair of the same (size, n).
    """

    MAX_CONTACTS = 1_000_000  # large: every colliding pair is reported

    def __init__(self, size_A, size_B, n: int):
        fcl = _fcl()
        self.n = int(n)
        self._fcl = fcl
        model_a, self.V_A, self.T_A, self.normals_A = _mesh(tuple(map(float, size_A)), self.n)
        model_b, self.V_B, self.T_B, self.normals_B = _mesh(tuple(map(float, size_B)), self.n)
        self.centroids_A = self.V_A[self.T_A].mean(axis=1)  # (t, 3) [m] in A
        self.centroids_B = self.V_B[self.T_B].mean(axis=1)  # (t, 3) [m] in B
        self.obj_a = fcl.CollisionObject(model_a, fcl.Transform())
        self.obj_b = fcl.CollisionObject(model_b, fcl.Transform())
        self.request = fcl.CollisionRequest(num_max_contacts=self.MAX_CONTACTS, enable_contact=True)

    @property
    def triangles_per_box(self) -> int:
        return 12 * self.n**2

    def set_pose(self, p_AB, R_AB) -> None:
        """Places B at p_AB (3,) [m], R_AB (3, 3) in A's frame."""
        self.obj_b.setTransform(self._fcl.Transform(np.asarray(R_AB, dtype=float), np.asarray(p_AB, dtype=float)))

    def collide(self):
        """FCL's collision call alone (the 'kernel'): returns the list of fcl.Contact."""
        result = self._fcl.CollisionResult()
        self._fcl.collide(self.obj_a, self.obj_b, self.request, result)
        return result.contacts

    def query(self, p_AB, R_AB, estimator: str = "centroids") -> SoupAnswer:
        """Pose in, contact point and normal out; estimator "centroids" (the paper's
        triangle list) or "segments" (exact crossing segments), see the module docstring."""
        self.set_pose(p_AB, R_AB)
        contacts = self.collide()
        k = len(contacts)
        if k == 0:
            nan3 = np.full(3, np.nan)
            return SoupAnswer(nan3, nan3, 0)
        R_AB, p_AB = np.asarray(R_AB, dtype=float), np.asarray(p_AB, dtype=float)
        ia = np.fromiter((c.b1 for c in contacts), dtype=np.intp, count=k)
        ib = np.fromiter((c.b2 for c in contacts), dtype=np.intp, count=k)
        per_face = 2 * self.n**2
        face_a, face_b = ia // per_face, ib // per_face
        votes = np.concatenate([np.bincount(face_a, minlength=6), np.bincount(face_b, minlength=6)])  # (12,)
        best = int(np.argmax(votes))
        if best < 6:
            normal = FACE_NORMALS[best].copy()
        else:
            normal = -(R_AB @ FACE_NORMALS[best - 6])
        if estimator == "centroids":
            ua, ub = np.unique(ia), np.unique(ib)
            points = np.concatenate([self.centroids_A[ua], self.centroids_B[ub] @ R_AB.T + p_AB])
        elif estimator == "segments":
            tri_a = self.V_A[self.T_A[ia]]  # (k, 3, 3) [m] in A
            tri_b = self.V_B[self.T_B[ib]] @ R_AB.T + p_AB
            ends = crossing_segments(tri_a, tri_b)  # (k, 2, 3)
            points = ends[np.all(np.isfinite(ends), axis=(1, 2))].reshape(-1, 3)
            if len(points) == 0:
                return SoupAnswer(np.full(3, np.nan), normal, k)
        else:
            raise ValueError(f"unknown estimator {estimator!r}; expected one of: {', '.join(ESTIMATORS)}")
        return SoupAnswer(patch_centroid(points, normal), normal, k)

    def candidate_pairs(self, p_AB, R_AB) -> int:
        """Triangle pairs whose axis-aligned bounds in A overlap (the leaf tests of an
        ideal AABB tree; comparable to the paper's Table 4 "Max. test")."""
        R_AB, p_AB = np.asarray(R_AB, dtype=float), np.asarray(p_AB, dtype=float)
        tri_a = self.V_A[self.T_A]  # (t, 3 corners, 3)
        tri_b = self.V_B[self.T_B] @ R_AB.T + p_AB
        lo_a, hi_a = tri_a.min(1), tri_a.max(1)  # (t, 3)
        lo_b, hi_b = tri_b.min(1), tri_b.max(1)
        # keep triangles whose bounds reach the other box's bounds
        keep_a = np.all((lo_a <= hi_b.max(0)) & (hi_a >= lo_b.min(0)), axis=1)
        keep_b = np.all((lo_b <= hi_a.max(0)) & (hi_b >= lo_a.min(0)), axis=1)
        lo_a, hi_a, lo_b, hi_b = lo_a[keep_a], hi_a[keep_a], lo_b[keep_b], hi_b[keep_b]
        count = 0
        for s in range(0, len(lo_a), 256):
            la, ha = lo_a[s:s + 256, None, :], hi_a[s:s + 256, None, :]
            count += int(np.all((la <= hi_b[None]) & (ha >= lo_b[None]), axis=2).sum())
        return count


def build(poses, scenes, options) -> list[ContactMethod]:
    """soup_N<N> for N in options.soup_ns (centroid estimator) and soup_segments_N8
    (exact crossing segments); unavailable when python-fcl is missing."""
    reason = missing("fcl", "python-fcl")
    P, R, SA, SB = poses.p_AB, poses.R_AB, poses.size_A, poses.size_B

    def bind(n, estimator):
        def scene(i):
            a, b = tuple(SA[i]), tuple(SB[i])
            return scenes.get(("soup", a, b, n), lambda: PolygonSoupPair(a, b, n))

        def single(i):
            answer = scene(i).query(P[i], R[i], estimator)
            return answer.point, answer.normal, answer.n_pairs

        def prepare_kernel(i):
            pair = scene(i)
            pair.set_pose(P[i], R[i])
            return pair.collide

        def candidates(i):
            return PolygonSoupPair(SA[i], SB[i], n).candidate_pairs(P[i], R[i])

        return dict(single=single, prepare_kernel=prepare_kernel, candidates=candidates)

    methods = []
    for n in options.soup_ns:
        methods.append(ContactMethod(f"soup_N{n}", f"polygon soup N={n} (python-fcl)", "polygon_soup", not reason, reason,
                                     **bind(n, "centroids"), extra={"N": n, "triangles_per_box": 12 * n * n}))
    segments = bind(8, "segments")
    segments.pop("candidates")  # the candidate count is a figure of the N sweep only
    methods.append(ContactMethod("soup_segments_N8", "polygon soup N=8, exact crossing segments", "polygon_soup",
                                 not reason, reason, **segments, extra={"N": 8, "triangles_per_box": 768}))
    return methods
