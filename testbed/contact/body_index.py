"""Which body a Drake collision geometry belongs to, as an index into a scene's body list.

Shared by the builder (initial overlap check), the contact effects (record rows name
bodies by index) and the viewer overlays; it lives below all of them so that no effect
imports the builder above it.
"""

from __future__ import annotations


def geometry_body_index(scene_or_assembly, query_object) -> dict:
    """GeometryId -> index into body_names, for every collision geometry.

    scene_or_assembly: anything with `.plant` (a finalised MultibodyPlant) and `.bodies`
    (name -> Body, in body_names order), e.g. BuiltScene or SceneAssembly;
    query_object: the scene graph's QueryObject (for its inspector).
    """
    plant = scene_or_assembly.plant
    inspector = query_object.inspector()
    index_of = {body.index(): i for i, body in enumerate(scene_or_assembly.bodies.values())}
    out = {}
    for gid in inspector.GetAllGeometryIds():
        body = plant.GetBodyFromFrameId(inspector.GetFrameId(gid))
        if body is not None and body.index() in index_of:
            out[gid] = index_of[body.index()]
    return out
