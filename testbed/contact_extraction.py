"""Turns Drake's per-step contact outputs into record rows (column arrays).

Pair order and signs follow testbed/contact_geometry.py: the pair (a, b) has
a < b in plant order (ground first), the normal points out of a into b, forces
are the force on b. One call handles all contacts of one step; every column is
an array whose first axis is the contact.

Columns (k contacts):
  a, b            (k,) int     body indices into the run's body_names
  kind            (k,) int     0 = hydroelastic surface, 1 = point pair
  p_W_centroid    (k, 3) [m]   hydroelastic: area-weighted surface centroid; point: contact point
  p_W_cop         (k, 3) [m]   centre of pressure: the point of the contact wrench's line of
                               action nearest the centroid (point: the contact point)
  p_W_cop_static  (k, 3) [m]   pressure-weighted centroid of the surface (elastic pressure only,
                               the learned labels' definition; point: the contact point)
  n_W             (k, 3)       unit normal, a -> b (hydroelastic: pressure-weighted)
  f_W             (k, 3) [N]   contact force on b (static/elastic part for shadow rows)
  fn              (k,)   [N]   f_W . n_W
  ft_W            (k, 3) [N]   f_W - fn n_W
  area            (k,) [m^2]   contact surface area (0 for point pairs)
  phi             (k,)   [m]   signed distance of the pair (negative = penetration)
"""

from __future__ import annotations

import numpy as np
from pydrake.geometry import HydroelasticContactRepresentation

from testbed.contact_geometry import point_on_line_of_action, split_force, static_pressure, surface_face_arrays

HYDRO, POINT = 0, 1
VECTOR_COLUMNS = ("p_W_centroid", "p_W_cop", "p_W_cop_static", "n_W", "f_W", "ft_W")
SCALAR_COLUMNS = ("a", "b", "kind", "fn", "area", "phi")


def empty_columns() -> dict[str, np.ndarray]:
    out = {k: np.zeros((0, 3)) for k in VECTOR_COLUMNS}
    out.update({k: np.zeros(0) for k in SCALAR_COLUMNS})
    out["a"] = out["a"].astype(int)
    out["b"] = out["b"].astype(int)
    out["kind"] = out["kind"].astype(int)
    return out


def _assemble(rows: list[tuple]) -> dict[str, np.ndarray]:
    """rows: (a, b, kind, centroid, cop, cop_static, n, f, area, phi), already oriented a -> b."""
    if not rows:
        return empty_columns()
    a, b, kind, centroid, cop, cop_static, n, f, area, phi = (np.asarray(c) for c in zip(*rows))
    fn, ft = split_force(f, n)
    return {
        "a": a.astype(int), "b": b.astype(int), "kind": kind.astype(int),
        "p_W_centroid": centroid.reshape(-1, 3), "p_W_cop": cop.reshape(-1, 3),
        "p_W_cop_static": cop_static.reshape(-1, 3),
        "n_W": n.reshape(-1, 3), "f_W": f.reshape(-1, 3), "fn": fn, "ft_W": ft.reshape(-1, 3),
        "area": area.astype(float), "phi": phi.astype(float),
    }


NEAR_DISTANCE = 1e-3  # [m] pairs closer than this get a signed distance each step


def near_distances(query) -> dict:
    """{frozenset(GeometryId, GeometryId): signed distance [m]} for pairs within NEAR_DISTANCE."""
    return {
        frozenset((pair.id_A, pair.id_B)): pair.distance
        for pair in query.ComputeSignedDistancePairwiseClosestPoints(NEAR_DISTANCE)
    }


def _signed_distance(distances: dict, id_1, id_2) -> float:
    return distances.get(frozenset((id_1, id_2)), np.nan)


def _orient(owner, id_from, id_to):
    """(a, b, sign): sign +1 if id_from belongs to a (so 'from -> to' is 'a -> b')."""
    i, j = owner[id_from], owner[id_to]
    return (i, j, 1.0) if i < j else (j, i, -1.0)


def from_contact_results(results, distances: dict, owner: dict) -> dict[str, np.ndarray]:
    """Rows of the driving model's answer, from a ContactResults and `near_distances` of
    the same state."""
    rows = []
    for i in range(results.num_hydroelastic_contacts()):
        info = results.hydroelastic_contact_info(i)
        surface = info.contact_surface()
        id_M, id_N = surface.id_M(), surface.id_N()
        a, b, sign = _orient(owner, id_N, id_M)  # normals point out of N into M
        F = info.F_Ac_W()  # on M's body, at the centroid
        f_M, tau_M = F.translational(), F.rotational()
        centroid = surface.centroid()
        cop = point_on_line_of_action(centroid, f_M, tau_M)
        static = static_pressure(surface_face_arrays(surface))
        rows.append((a, b, HYDRO, centroid, cop, static.cop, sign * static.normal, sign * f_M,
                     surface.total_area(), _signed_distance(distances, id_M, id_N)))
    for i in range(results.num_point_pair_contacts()):
        info = results.point_pair_contact_info(i)
        pair = info.point_pair()
        a, b, sign = _orient(owner, pair.id_B, pair.id_A)  # nhat_BA_W: out of B into A
        point = info.contact_point()
        f_B = info.contact_force()  # on B
        rows.append((a, b, POINT, point, point, point, sign * pair.nhat_BA_W, -sign * f_B, 0.0, -pair.depth))
    return _assemble(rows)


def point_pairs_from_query(query, owner: dict, stiffness: dict) -> dict[str, np.ndarray]:
    """Point-contact answer on the current state (for shadows): point, normal, depth.

    The force is the elastic point-contact force k * depth along the normal, with k
    the series combination of the two geometries' point_contact_stiffness (`stiffness`:
    GeometryId -> N/m); Drake's dissipation and friction are not part of a static answer.
    """
    rows = []
    for pair in query.ComputePointPairPenetration():
        a, b, sign = _orient(owner, pair.id_B, pair.id_A)
        n = sign * pair.nhat_BA_W
        k_1, k_2 = stiffness[pair.id_A], stiffness[pair.id_B]
        k = k_1 * k_2 / (k_1 + k_2)
        point = 0.5 * (pair.p_WCa + pair.p_WCb)
        rows.append((a, b, POINT, point, point, point, n, k * pair.depth * n, 0.0, -pair.depth))
    return _assemble(rows)


def hydro_surfaces_from_query(query, owner: dict) -> dict[str, np.ndarray]:
    """Static hydroelastic answer on the current state (for shadows and labels)."""
    rows, distances = [], near_distances(query)
    for surface in query.ComputeContactSurfaces(HydroelasticContactRepresentation.kPolygon):
        id_M, id_N = surface.id_M(), surface.id_N()
        a, b, sign = _orient(owner, id_N, id_M)
        static = static_pressure(surface_face_arrays(surface))
        # static.force is the elastic force on M; on b it is sign * force.
        rows.append((a, b, HYDRO, static.centroid, static.cop, static.cop, sign * static.normal, sign * static.force,
                     static.area, _signed_distance(distances, id_M, id_N)))
    return _assemble(rows)


def point_stiffness(query) -> dict:
    """GeometryId -> point_contact_stiffness [N/m] of every proximity geometry."""
    inspector = query.inspector()
    out = {}
    for gid in inspector.GetAllGeometryIds():
        props = inspector.GetProximityProperties(gid)
        if props is not None and props.HasProperty("material", "point_contact_stiffness"):
            out[gid] = props.GetProperty("material", "point_contact_stiffness")
    return out
