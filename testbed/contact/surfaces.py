"""Vectorised geometry of Drake contact outputs: centroids, centres of pressure, normals.

Conventions used across the testbed (records, labels, comparison):
- A contact pair is ordered (a, b); the normal n points out of a into b, and forces
  are the force *on b*. In scene records, a is the body that comes first in the
  plant (the ground before every container, then containers in scene order).
- Points and normals are in the world frame W unless a name says otherwise.

The centre of pressure is the exact integral of Drake's pressure field over Drake's own
contact surface: inside each polygon the pressure is linear, so each polygon is fanned into
triangles and each triangle's first moment integrated in closed form (`face_moments`). Drake's
discrete solver instead applies each polygon's force at its centroid (the one-point rule:
it drops each polygon's second moment of area times the pressure gradient), which on a
tilted face puts the centre of pressure 2/3 of the way to the exact one; that answer stays
available as `StaticPressure.cop_one_point`, and the distance between the two is the
truth's own discretisation error. Force and normal are integrated exactly by both rules.

Drake 1.51.1's Python bindings give no bulk array view of a contact-surface mesh (the
polygon mesh's vertices are not shared between faces either), so `surface_face_arrays`
reads each polygon with four binding calls and each vertex with two (~0.3 ms for a
30-polygon container surface); every computation after that is numpy on whole arrays.
Callers that need it every step hold the result (testbed.contact.extraction.StaticHold).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class SurfaceFaces(NamedTuple):
    """Per-face data of one hydroelastic contact surface, in W.

    area (f,) [m^2]; normal (f, 3) unit, out of geometry N into M; centroid (f, 3) [m];
    pressure (f,) [Pa] at the face centroid; moment (f, 3) [N m]: the exact first moment
    of the pressure over the face, integral of p x dA with x in W (the one-point rule's is
    area * pressure * centroid).
    """

    area: np.ndarray
    normal: np.ndarray
    centroid: np.ndarray
    pressure: np.ndarray
    moment: np.ndarray


class StaticPressure(NamedTuple):
    """The static (no dissipation, no friction) answer of a contact surface, in W.

    cop (3,) [m]: centre of pressure, the exact integral of p x dA over integral of p dA.
    normal (3,): unit, normalised pressure-weighted face normal, out of N into M.
    force (3,) [N]: integral of p n dA, the elastic force on M.
    area [m^2]; centroid (3,) [m]: area-weighted centroid.
    cop_one_point (3,) [m]: the centre of pressure of Drake's one-point rule (each
    polygon's force at its centroid: what Drake's discrete solver applies);
    |cop - cop_one_point| is the truth's own discretisation error.
    """

    cop: np.ndarray
    normal: np.ndarray
    force: np.ndarray
    area: float
    centroid: np.ndarray
    cop_one_point: np.ndarray


def surface_face_arrays(surface) -> SurfaceFaces:
    """Reads a pydrake ContactSurface (polygon or triangle representation) into arrays."""
    if surface.is_triangle():
        mesh, field = surface.tri_mesh_W(), surface.tri_e_MN()
        polygons = [[t.vertex(k) for k in range(3)] for t in mesh.triangles()]
    else:
        mesh, field = surface.poly_mesh_W(), surface.poly_e_MN()
        polygons = _polygons(mesh.face_data())
    area, normal, centroid, evaluate = mesh.area, mesh.face_normal, mesh.element_centroid, field.EvaluateCartesian
    rows = [(area(f), normal(f), c, evaluate(f, c)) for f in range(mesh.num_elements()) for c in (centroid(f),)]
    if not rows:
        z = np.zeros((0, 3))
        return SurfaceFaces(np.zeros(0), z, z, np.zeros(0), z)
    area, normal, centroid, pressure = zip(*rows)
    n_v = mesh.num_vertices()
    p_WV = np.array([mesh.vertex(v) for v in range(n_v)], dtype=float).reshape(n_v, 3)  # (v, 3) [m]
    p_V = np.array([field.EvaluateAtVertex(v) for v in range(n_v)], dtype=float)  # (v,) [Pa]
    return SurfaceFaces(
        np.asarray(area), np.asarray(normal), np.asarray(centroid), np.asarray(pressure),
        face_moments(p_WV, p_V, polygons),
    )


def _polygons(face_data) -> list[list[int]]:
    """Vertex indices of each polygon from PolygonSurfaceMesh.face_data() ([n0, v.., n1, v.., ...])."""
    out, i = [], 0
    while i < len(face_data):
        count = face_data[i]
        out.append(list(face_data[i + 1:i + 1 + count]))
        i += 1 + count
    return out


def face_moments(p_WV, p_V, polygons) -> np.ndarray:
    """(f, 3) [N m] exact integral of p x dA over each convex planar polygon, p linear on it.

    p_WV (v, 3) [m] vertex positions; p_V (v,) [Pa] the pressure at each vertex; polygons:
    f lists of vertex indices (counter-clockwise or clockwise, convex). Each polygon is fanned
    from its first vertex; a triangle (a, b, c) of area A contributes
    A/12 [(p_a + p_b + p_c)(x_a + x_b + x_c) + p_a x_a + p_b x_b + p_c x_c]
    (the degree-2 integral of a linear function times a linear function over a triangle).
    """
    face, ia, ib, ic = [], [], [], []
    for f, poly in enumerate(polygons):
        for k in range(1, len(poly) - 1):
            face.append(f)
            ia.append(poly[0])
            ib.append(poly[k])
            ic.append(poly[k + 1])
    out = np.zeros((len(polygons), 3))
    if not face:
        return out
    x_a, x_b, x_c = p_WV[ia], p_WV[ib], p_WV[ic]  # (t, 3) each
    p_a, p_b, p_c = p_V[ia], p_V[ib], p_V[ic]
    area = 0.5 * np.linalg.norm(cross(x_b - x_a, x_c - x_a), axis=1)  # (t,)
    moment = (area / 12.0)[:, None] * ((p_a + p_b + p_c)[:, None] * (x_a + x_b + x_c)
                                       + p_a[:, None] * x_a + p_b[:, None] * x_b + p_c[:, None] * x_c)
    np.add.at(out, np.asarray(face), moment)
    return out


def static_pressure(faces: SurfaceFaces) -> StaticPressure:
    """Pressure-weighted centroid and normal of one surface (see StaticPressure)."""
    area = float(faces.area.sum())
    if area <= 0.0:
        nan3 = np.full(3, np.nan)
        return StaticPressure(nan3, nan3, np.zeros(3), 0.0, nan3, nan3)
    # Weighted sums as numpy reductions, never `@`: a (f,) @ (f, 3) product is BLAS's dgemv, whose
    # kernel OpenBLAS picks at run time by CPU (SkylakeX on an AVX-512 Zen 4, Haswell on a Zen 5 it
    # does not know), each summing in its own order (and a 1-D linalg.norm is its ddot): the labels' normals differed in the last bit
    # on 63-85 % of poses between kernels (docs/testing.md). numpy's own sum is the same everywhere.
    def wsum(w, v):  # (f,), (f, 3) -> (3,)
        return (w[:, None] * v).sum(axis=0)

    weight = faces.area * faces.pressure  # (f,) [N]: integral of p dA, exact for a linear p
    w_sum = weight.sum()
    centroid = wsum(faces.area, faces.centroid) / area
    if w_sum <= 0.0:  # zero pressure everywhere (touching at the margin): fall back to area
        weight, w_sum = faces.area, area
        cop = one_point = centroid
    else:
        cop = faces.moment.sum(axis=0) / w_sum
        one_point = wsum(weight, faces.centroid) / w_sum
    force = wsum(faces.area * faces.pressure, faces.normal)  # (3,)
    direction = wsum(weight, faces.normal)
    normal = direction / np.sqrt((direction * direction).sum())  # not linalg.norm: a 1-D norm is BLAS's ddot
    return StaticPressure(cop, normal, force, area, centroid, one_point)


# The truth's own error: the centre of pressure is the exact integral of Drake's pressure field over
# Drake's contact surface, held to an independent per-triangle Gauss quadrature, to Drake's triangle
# tessellation and to the linear-foundation closed form in tests/learned/test_exact_truth.py (1e-9 m);
# the normal is integrated exactly by both rules (1.3e-10 deg between refined meshes, measured). No
# gate on these figures can resolve below them.
EXACT_LABEL_TOLERANCE_M = 1e-9
EXACT_NORMAL_TOLERANCE_DEG = 1e-9

_NEXT, _PREV = [1, 2, 0], [2, 0, 1]


def cross(u, v) -> np.ndarray:
    """Cross product of (..., 3) arrays; np.cross costs ~30 us of overhead on tiny arrays."""
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    return u[..., _NEXT] * v[..., _PREV] - u[..., _PREV] * v[..., _NEXT]


def point_on_line_of_action(p_WC, f_W, tau_W) -> np.ndarray:
    """Centre of pressure of a wrench: the point of its line of action nearest C.

    p_WC (..., 3): the point C the torque is about [m]; f_W, tau_W (..., 3): force [N]
    and torque about C [N m]. Returns (..., 3): C + (f x tau) / |f|^2; C where f = 0.
    """
    f_W = np.asarray(f_W, dtype=float)
    f2 = np.einsum("...i,...i->...", f_W, f_W)[..., None]
    shift = cross(f_W, tau_W) / np.where(f2 > 0.0, f2, 1.0)
    return np.asarray(p_WC) + np.where(f2 > 0.0, shift, 0.0)


def split_force(f_W, n_W):
    """Splits forces into normal magnitude and tangential vector.

    f_W (..., 3) [N], n_W (..., 3) unit. Returns fn (...,) [N] = f . n and
    ft (..., 3) [N] = f - fn n.
    """
    fn = np.einsum("...i,...i->...", f_W, n_W)
    return fn, f_W - fn[..., None] * n_W


def angle_between(u, v) -> np.ndarray:
    """Angle [rad] between unit vectors u, v (..., 3), robust near 0 and pi."""
    sine = np.linalg.norm(cross(u, v), axis=-1)
    dot = np.einsum("...i,...i->...", u, v)
    return np.arctan2(sine, dot)
