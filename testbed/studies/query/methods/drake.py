"""Query-study methods of Drake: point contact and hydroelastic (static CoP) for one pair.

A two-body MultibodyPlant (time_step 0, no simulation) holds container A at the world
origin and B posed per query, so world quantities are A-frame quantities. Queries go
through the QueryObject from the plant's geometry-query input port (not a sampled
output port), as learned_contact/data/labels.py does.

Modes
- "point": QueryObject.ComputePointPairPenetration; box-box goes to FCL's port of ODE's
  dBoxBox, which keeps the deepest of up to 4 points. Point = midpoint of the witness
  points p_WCa, p_WCb; normal = -nhat_BA_W when Drake's A is our A.
- "hydro_cc": both boxes compliant_hydroelastic (the SDF models as shipped: E = 1e9 Pa);
  QueryObject.ComputeContactSurfaces(kPolygon) and the centre of pressure and
  pressure-weighted normal of testbed.contact.surfaces.static_pressure. This is the
  study's reference model.
- "hydro_cr": B made rigid_hydroelastic in a second plant (compliant A, rigid B).
Point and normal: (3,) in A's frame [m], normal unit from A into B.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from testbed.contact.pair_plant import ContainerPair
from testbed.contact.surfaces import static_pressure, surface_face_arrays
from testbed.studies.query.methods.base import ContactMethod

ORDER = 10
METHODS = (  # name, label, mode, rigid B
    ("drake_point", "Drake point contact", "point", False),
    ("drake_hydro_cc", "Drake hydroelastic compliant-compliant", "hydro_cc", False),
    ("drake_hydro_cr", "Drake hydroelastic compliant-rigid", "hydro_cr", True),
)


class DrakeAnswer(NamedTuple):
    """point (3,) [m], unit normal (3,) A->B in A's frame (NaN without contact);
    n_faces: contact-surface polygons (hydroelastic) or point pairs (point)."""

    point: np.ndarray
    normal: np.ndarray
    n_faces: int


class DrakeBoxPair(ContainerPair):
    """A and B of ISO types type_a, type_b (e.g. "1CC") in one plant; rigid_b makes B
    rigid_hydroelastic (for "hydro_cr")."""

    def __init__(self, type_a: str, type_b: str, *, rigid_b: bool = False):
        super().__init__(type_a, type_b, rigid_b=rigid_b)
        from pydrake.geometry import HydroelasticContactRepresentation

        self._poly = HydroelasticContactRepresentation.kPolygon

    def kernel(self, query, mode: str):
        """Drake's query call alone (no Python post-processing)."""
        if mode == "point":
            return query.ComputePointPairPenetration()
        return query.ComputeContactSurfaces(self._poly)

    def answer(self, query, mode: str) -> DrakeAnswer:
        """Runs the mode's query on a posed QueryObject and reduces it to one answer."""
        nan3 = np.full(3, np.nan)
        if mode == "point":
            pairs = query.ComputePointPairPenetration()
            if not pairs:
                return DrakeAnswer(nan3, nan3, 0)
            pp = pairs[0]
            flip = -1.0 if pp.id_A == self.gid_a else 1.0  # nhat_BA_W: out of Drake's B into its A
            return DrakeAnswer(0.5 * (pp.p_WCa + pp.p_WCb), flip * pp.nhat_BA_W, len(pairs))

        surfaces = query.ComputeContactSurfaces(self._poly)
        if not surfaces:
            return DrakeAnswer(nan3, nan3, 0)
        surface = surfaces[0]
        faces = surface_face_arrays(surface)
        sp = static_pressure(faces)
        flip = 1.0 if surface.id_M() == self.gid_b else -1.0  # face normals: out of N into M
        return DrakeAnswer(sp.cop, flip * sp.normal, len(faces.area))

    def query(self, p_AB, R_AB, mode: str) -> DrakeAnswer:
        """Pose in, contact point and normal out."""
        return self.answer(self.set_pose(p_AB, R_AB), mode)


def build(poses, scenes, options) -> list[ContactMethod]:
    """drake_point, drake_hydro_cc (the study's reference), drake_hydro_cr."""
    P, R, TA, TB = poses.p_AB, poses.R_AB, poses.type_a, poses.type_b

    def bind(mode, rigid):
        def scene(i):
            a, b = str(TA[i]), str(TB[i])
            return scenes.get(("drake", a, b, rigid), lambda: DrakeBoxPair(a, b, rigid_b=rigid))

        def single(i):
            answer = scene(i).query(P[i], R[i], mode)
            return answer.point, answer.normal, answer.n_faces

        def prepare_kernel(i):
            pair = scene(i)
            query_object = pair.set_pose(P[i], R[i])
            return lambda: pair.kernel(query_object, mode)

        return single, prepare_kernel

    methods = []
    for name, label, mode, rigid in METHODS:
        single, prepare_kernel = bind(mode, rigid)
        methods.append(ContactMethod(name, label, "drake", single=single, prepare_kernel=prepare_kernel))
    return methods
