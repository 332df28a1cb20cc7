"""Turns Drake's per-step contact outputs into record rows (column arrays).

Pair order and signs follow testbed/contact/surfaces.py: the pair (a, b) has
a < b in plant order (ground first), the normal points out of a into b, forces
are the force on b. One call handles all contacts of one step; every column is
an array whose first axis is the contact.

Columns (k contacts):
  a, b            (k,) int     body indices into the run's body_names
  kind            (k,) int     0 = hydroelastic surface, 1 = point pair
  p_W_centroid    (k, 3) [m]   hydroelastic: area-weighted surface centroid; point: contact point
  p_W_cop         (k, 3) [m]   centre of pressure: the point of the contact wrench's line of
                               action nearest the centroid (point: the contact point)
  p_W_cop_static  (k, 3) [m]   centre of pressure of the elastic pressure: the exact integral of
                               Drake's pressure field over the surface (the learned labels'
                               definition; point: the contact point)
  p_W_cop_one_point (k, 3) [m] the same by Drake's one-point rule (each polygon's pressure at its
                               centroid: what Drake's discrete solver applies); its distance to
                               p_W_cop_static is the truth's own discretisation error (point:
                               the contact point)
  n_W             (k, 3)       unit normal, a -> b (hydroelastic: pressure-weighted)
  static_age      (k,)   int   steps since p_W_cop_static and n_W were computed from the
                               surface's faces: 0 = on this row's state; k > 0 = held from
                               k steps earlier (the contact log reads a pair's faces every
                               `static_every_steps` steps, see StaticHold); always 0 for
                               point pairs and shadow rows
  f_W             (k, 3) [N]   contact force on b (static/elastic part for shadow rows)
  fn              (k,)   [N]   f_W . n_W
  ft_W            (k, 3) [N]   f_W - fn n_W
  area            (k,) [m^2]   contact surface area (0 for point pairs)
  phi             (k,)   [m]   signed distance of the pair (negative = penetration)
"""

from __future__ import annotations

import numpy as np
from pydrake.geometry import HydroelasticContactRepresentation

from testbed.contact.surfaces import point_on_line_of_action, split_force, static_pressure, surface_face_arrays
from testbed.geometry.boxes import QueryBoxes

HYDRO, POINT = 0, 1
VECTOR_COLUMNS = ("p_W_centroid", "p_W_cop", "p_W_cop_static", "p_W_cop_one_point", "n_W", "f_W", "ft_W")
SCALAR_COLUMNS = ("a", "b", "kind", "fn", "area", "phi", "static_age")
INT_COLUMNS = ("a", "b", "kind", "static_age")


def empty_columns() -> dict[str, np.ndarray]:
    out = {k: np.zeros((0, 3)) for k in VECTOR_COLUMNS}
    out.update({k: np.zeros(0, dtype=int if k in INT_COLUMNS else float) for k in SCALAR_COLUMNS})
    return out


def _assemble(rows: list[tuple], ages=None) -> dict[str, np.ndarray]:
    """rows: (a, b, kind, centroid, cop, cop_static, cop_one_point, n, f, area, phi), already
    oriented a -> b; ages: static_age per row (None: all 0). Three array conversions in all (a
    step's record is a few rows: per-call overhead is what costs)."""
    if not rows:
        return empty_columns()
    cols = tuple(zip(*rows))
    ints = np.array(cols[0:3], dtype=int)  # (3, k)
    vec = np.array(cols[3:9], dtype=float).reshape(6, -1, 3)  # (6, k, 3)
    scal = np.array(cols[9:11], dtype=float)  # (2, k)
    f, n = vec[5], vec[4]
    fn, ft = split_force(f, n)
    return {
        "a": ints[0], "b": ints[1], "kind": ints[2],
        "p_W_centroid": vec[0], "p_W_cop": vec[1], "p_W_cop_static": vec[2], "p_W_cop_one_point": vec[3],
        "n_W": n, "f_W": f, "fn": fn, "ft_W": ft, "area": scal[0], "phi": scal[1],
        "static_age": np.zeros(len(ints[0]), dtype=int) if ages is None else np.array(ages, dtype=int),
    }


class StaticHold:
    """Each pair's static columns (exact and one-point CoP, normal a -> b), read from its
    surface's faces at most every `every` steps and held in between.

    Drake 1.51's bindings read a contact surface one face at a time (four calls per face,
    testbed.contact.surfaces.surface_face_arrays): ~0.15 ms for a 70-face
    container-container surface, more than everything else a step's record costs. The
    driving answer (centroid, wrench, CoP on its line of action, area) stays exact every
    step; `static_age` says how old the static columns of a row are. every=1 reads the
    faces every step. A pair seen for the first time (or again after a gap of `every`
    steps or more) is read at once.
    """

    def __init__(self, every: int = 1):
        self.every = max(int(every), 1)
        self._held: dict = {}  # (a, b) -> (step, cop (3,), cop_one_point (3,), normal (3,) a -> b)

    def get(self, key, step: int, surface, sign: float):
        """(cop (3,) [m], cop_one_point (3,) [m], normal (3,) a -> b, age [steps]) of pair `key`
        at `step`."""
        held = self._held.get(key)
        if held is None or not 0 <= step - held[0] < self.every:
            static = static_pressure(surface_face_arrays(surface))
            held = self._held[key] = (step, static.cop, static.cop_one_point, sign * static.normal)
        return held[1], held[2], held[3], step - held[0]


NEAR_DISTANCE = 1e-3  # [m] pairs closer than this get a signed distance each step
_BOXES: dict = {}  # geometry-id tuple -> testbed.geometry.boxes.QueryBoxes (read once per scene)


def near_distances(query) -> dict:
    """{frozenset(GeometryId, GeometryId): signed distance [m]} for pairs within NEAR_DISTANCE.

    Closed-form box geometry (testbed/geometry/boxes.py), bounded time per call: Drake's
    generic ComputeSignedDistancePairwiseClosestPoints hangs (FCL GJK) or raises (libccd)
    against the quay slab once a container slides. Penetrating pairs get the exact depth;
    a separated box-box pair gets the separating-axis lower bound on its distance.
    """
    key = tuple(query.inspector().GetAllGeometryIds())
    boxes = _BOXES.get(key)
    if boxes is None:
        if len(_BOXES) > 64:  # many scenes in one process (studies): keep the cache small
            _BOXES.clear()
        boxes = _BOXES[key] = QueryBoxes(query)
    return boxes.near(query, NEAR_DISTANCE)


def _signed_distance(distances: dict, id_1, id_2) -> float:
    return distances.get(frozenset((id_1, id_2)), np.nan)


def _orient(owner, id_from, id_to):
    """(a, b, sign): sign +1 if id_from belongs to a (so 'from -> to' is 'a -> b')."""
    i, j = owner[id_from], owner[id_to]
    return (i, j, 1.0) if i < j else (j, i, -1.0)


def from_contact_results(results, distances: dict, owner: dict, *, hold: StaticHold | None = None,
                         step: int = 0) -> dict[str, np.ndarray]:
    """Rows of the driving model's answer, from a ContactResults and `near_distances` of
    the same state. hold: where the static columns come from (None: the faces of every
    surface, every call); step: this state's step number (for hold)."""
    rows, ages = [], []
    for i in range(results.num_hydroelastic_contacts()):
        info = results.hydroelastic_contact_info(i)
        surface = info.contact_surface()
        id_M, id_N = surface.id_M(), surface.id_N()
        a, b, sign = _orient(owner, id_N, id_M)  # normals point out of N into M
        F = info.F_Ac_W()  # on M's body, at the centroid
        f_M = F.translational()
        centroid = surface.centroid()
        if hold is None:
            static = static_pressure(surface_face_arrays(surface))
            cop_static, one_point, normal, age = static.cop, static.cop_one_point, sign * static.normal, 0
        else:
            cop_static, one_point, normal, age = hold.get((a, b), step, surface, sign)
        # the p_W_cop slot carries the torque on b about the centroid until _assemble is done
        rows.append((a, b, HYDRO, centroid, sign * F.rotational(), cop_static, one_point, normal, sign * f_M,
                     surface.total_area(), _signed_distance(distances, id_M, id_N)))
        ages.append(age)
    for i in range(results.num_point_pair_contacts()):
        info = results.point_pair_contact_info(i)
        pair = info.point_pair()
        a, b, sign = _orient(owner, pair.id_B, pair.id_A)  # nhat_BA_W: out of B into A
        point = info.contact_point()
        f_B = info.contact_force()  # on B
        rows.append((a, b, POINT, point, point, point, point, sign * pair.nhat_BA_W, -sign * f_B, 0.0, -pair.depth))
        ages.append(0)
    out = _assemble(rows, ages)
    h = out["kind"] == HYDRO  # centres of pressure of the hydroelastic rows, one vectorised call
    if np.any(h):
        out["p_W_cop"][h] = point_on_line_of_action(out["p_W_centroid"][h], out["f_W"][h], out["p_W_cop"][h])
    return out


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
        rows.append((a, b, POINT, point, point, point, point, n, k * pair.depth * n, 0.0, -pair.depth))
    return _assemble(rows)


def hydro_surfaces_from_query(query, owner: dict) -> dict[str, np.ndarray]:
    """Static hydroelastic answer on the current state (for shadows and labels)."""
    rows, distances = [], near_distances(query)
    for surface in query.ComputeContactSurfaces(HydroelasticContactRepresentation.kPolygon):
        id_M, id_N = surface.id_M(), surface.id_N()
        a, b, sign = _orient(owner, id_N, id_M)
        static = static_pressure(surface_face_arrays(surface))
        # static.force is the elastic force on M; on b it is sign * force.
        rows.append((a, b, HYDRO, static.centroid, static.cop, static.cop, static.cop_one_point, sign * static.normal,
                     sign * static.force,
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
