"""Vectorised geometry of Drake contact outputs: centroids, centres of pressure, normals.

Conventions used across the testbed (records, labels, comparison):
- A contact pair is ordered (a, b); the normal n points out of a into b, and forces
  are the force *on b*. In scene records, a is the body that comes first in the
  plant (the ground before every container, then containers in scene order).
- Points and normals are in the world frame W unless a name says otherwise.

Drake 1.51.1's Python bindings give no bulk array view of a contact-surface mesh (the
polygon mesh's vertices are not shared between faces either, so reading vertices costs
as much), so `surface_face_arrays` reads each polygon with four binding calls (~2 us
per face); every computation after that is numpy on whole arrays. Callers that need it
every step hold the result (testbed.contact.extraction.StaticHold).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class SurfaceFaces(NamedTuple):
    """Per-face data of one hydroelastic contact surface, in W.

    area (f,) [m^2]; normal (f, 3) unit, out of geometry N into M; centroid (f, 3) [m];
    pressure (f,) [Pa] at the face centroid.
    """

    area: np.ndarray
    normal: np.ndarray
    centroid: np.ndarray
    pressure: np.ndarray


class StaticPressure(NamedTuple):
    """The static (no dissipation, no friction) answer of a contact surface, in W.

    cop (3,) [m]: pressure-weighted centroid (centre of pressure).
    normal (3,): unit, normalised pressure-weighted face normal, out of N into M.
    force (3,) [N]: integral of p n dA, the elastic force on M.
    area [m^2]; centroid (3,) [m]: area-weighted centroid.
    """

    cop: np.ndarray
    normal: np.ndarray
    force: np.ndarray
    area: float
    centroid: np.ndarray


def surface_face_arrays(surface) -> SurfaceFaces:
    """Reads a pydrake ContactSurface (polygon or triangle representation) into arrays."""
    if surface.is_triangle():
        mesh, field = surface.tri_mesh_W(), surface.tri_e_MN()
    else:
        mesh, field = surface.poly_mesh_W(), surface.poly_e_MN()
    area, normal, centroid, evaluate = mesh.area, mesh.face_normal, mesh.element_centroid, field.EvaluateCartesian
    rows = [(area(f), normal(f), c, evaluate(f, c)) for f in range(mesh.num_elements()) for c in (centroid(f),)]
    if not rows:
        z = np.zeros((0, 3))
        return SurfaceFaces(np.zeros(0), z, z, np.zeros(0))
    area, normal, centroid, pressure = zip(*rows)
    return SurfaceFaces(
        np.asarray(area), np.asarray(normal), np.asarray(centroid), np.asarray(pressure)
    )


def static_pressure(faces: SurfaceFaces) -> StaticPressure:
    """Pressure-weighted centroid and normal of one surface (see StaticPressure)."""
    area = float(faces.area.sum())
    if area <= 0.0:
        nan3 = np.full(3, np.nan)
        return StaticPressure(nan3, nan3, np.zeros(3), 0.0, nan3)
    weight = faces.area * faces.pressure  # (f,) [N]
    w_sum = weight.sum()
    centroid = faces.area @ faces.centroid / area
    if w_sum <= 0.0:  # zero pressure everywhere (touching at the margin): fall back to area
        weight, w_sum = faces.area, area
    cop = weight @ faces.centroid / w_sum
    force = (faces.area * faces.pressure) @ faces.normal  # (3,)
    direction = weight @ faces.normal
    normal = direction / np.linalg.norm(direction)
    return StaticPressure(cop, normal, force, area, centroid)


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
