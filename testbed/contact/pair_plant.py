"""A two-container MultibodyPlant for static contact queries (labels, query studies).

Container A sits at the world origin and B is posed per query, so world quantities
are A-frame quantities. Queries go through the QueryObject of the plant's
geometry-query input port (never a sampled output port: a fresh context would report
no contacts). The plant is continuous (time_step 0): nothing is simulated.
"""

import re

import numpy as np

from testbed.bodies.containers import container_type
from testbed.bodies.models import container_sdf


def _rigid(sdf: str) -> str:
    """A container SDF text made rigid_hydroelastic (its modulus dropped)."""
    sdf = re.sub(r"<drake:compliant_hydroelastic\s*/>", "<drake:rigid_hydroelastic/>", sdf)
    return re.sub(r"<drake:hydroelastic_modulus>[^<]*</drake:hydroelastic_modulus>", "", sdf)


class ContainerPair:
    """Containers A and B of ISO types type_a, type_b (e.g. "1CC") in one plant.

    rigid_b makes B rigid_hydroelastic (compliant-rigid hydroelastic contact); modulus [Pa]
    replaces the SDF's hydroelastic modulus on both (None: as shipped).
    Attributes: plant, context (the plant's), body_b, gid_a, gid_b (GeometryIds).
    """

    def __init__(self, type_a: str, type_b: str, *, rigid_b: bool = False, modulus: float | None = None):
        from pydrake.math import RigidTransform
        from pydrake.multibody.parsing import Parser
        from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, ContactModel
        from pydrake.systems.framework import DiagramBuilder

        builder = DiagramBuilder()
        plant, _ = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
        plant.set_contact_model(ContactModel.kHydroelasticWithFallback)
        parser = Parser(plant)
        models = []
        for name, code in (("A", type_a), ("B", type_b)):
            ctype = container_type(code)
            sdf = container_sdf(ctype, name=name, mass=ctype.tare_mass)
            if modulus is not None:
                sdf = re.sub(r"<drake:hydroelastic_modulus>[^<]*</drake:hydroelastic_modulus>",
                             f"<drake:hydroelastic_modulus>{float(modulus)!r}</drake:hydroelastic_modulus>", sdf)
            models.append(parser.AddModelsFromString(_rigid(sdf) if name == "B" and rigid_b else sdf, "sdf")[0])
        plant.Finalize()
        self.diagram = builder.Build()
        self._root = self.diagram.CreateDefaultContext()
        self.plant = plant
        self.context = plant.GetMyMutableContextFromRoot(self._root)
        bodies = [plant.GetBodyByName("body", m) for m in models]
        plant.SetFreeBodyPose(self.context, bodies[0], RigidTransform())
        self.body_b = bodies[1]
        self.gid_a = plant.GetCollisionGeometriesForBody(bodies[0])[0]
        self.gid_b = plant.GetCollisionGeometriesForBody(bodies[1])[0]
        self.port = plant.get_geometry_query_input_port()

    def set_pose(self, p_AB, R_AB):
        """Places B at p_AB (3,) [m] with orientation R_AB (3, 3) in A; returns the QueryObject."""
        from pydrake.math import RigidTransform, RotationMatrix

        X_AB = RigidTransform(RotationMatrix(np.asarray(R_AB, dtype=float)), np.asarray(p_AB, dtype=float))
        self.plant.SetFreeBodyPose(self.context, self.body_b, X_AB)
        return self.port.Eval(self.context)
