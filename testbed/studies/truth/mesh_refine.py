"""Drake's own compliant box mesh, refined, written as a legacy .vtk file.

Why: Drake's discrete plant applies each contact polygon's force at its centroid, so the
coarse box mesh (18 vertices, 44 tetrahedra: the medial-axis mesh Drake makes for a
compliant Box) decides how a tilted face's pressure turns into a moment. Refining the
mesh makes the polygons smaller without changing the pressure field: a compliant .vtk
mesh gets Drake's field E d(v) / max d, d the distance of vertex v to the mesh's boundary,
and d is linear inside each of the Box mesh's tetrahedra, so the field of any refinement
that keeps the original vertices (the 4 medial ones among them) is the Box's own field.

Refinement: Bey's red refinement, each tetrahedron split into 8 at its edge midpoints (4
corner tetrahedra and the inner octahedron cut along its m02-m13 diagonal); every child is
oriented like Drake's elements (positive signed volume, (v1 - v0) x (v2 - v0) . (v3 - v0) > 0
as checked on the parent). Level k has 44 x 8^k tetrahedra and the same volume.

Frames and units: vertices are in the box's geometry frame G (origin at the centre, axes
along the edges) [m]; the container SDFs put the collision box at the body origin, so G is
the body frame C. Files are written under a cache directory the caller owns (the study's
output or a temporary directory), never into the repository.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def drake_box_mesh(size) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (n, 3) [m] in G, tetrahedra (m, 4) int) of the volume mesh Drake makes for a
    compliant hydroelastic Box of full extents `size` (3,) [m] (SceneGraphInspector.
    maybe_get_hydroelastic_mesh on a throw-away SceneGraph)."""
    from pydrake.geometry import AddCompliantHydroelasticProperties, Box, GeometryInstance, ProximityProperties, SceneGraph
    from pydrake.math import RigidTransform

    graph = SceneGraph()
    source = graph.RegisterSource("truth_mesh")
    instance = GeometryInstance(RigidTransform(), Box(*[float(v) for v in size]), "box")
    props = ProximityProperties()
    AddCompliantHydroelasticProperties(1.0, 1.0e9, props)  # resolution hint unused for a Box
    instance.set_proximity_properties(props)
    gid = graph.RegisterAnchoredGeometry(source, instance)
    mesh = graph.model_inspector().maybe_get_hydroelastic_mesh(gid)
    vertices = np.array([mesh.vertex(i) for i in range(mesh.num_vertices())], dtype=float).reshape(-1, 3)
    tets = np.array([[mesh.element(e).vertex(k) for k in range(4)] for e in range(mesh.num_elements())], dtype=int)
    return vertices, tets


def signed_volumes(vertices: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """(m,) signed volume [m^3] of each tetrahedron: ((v1 - v0) x (v2 - v0)) . (v3 - v0) / 6."""
    v = vertices[tets]  # (m, 4, 3)
    return np.einsum("ij,ij->i", np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), v[:, 3] - v[:, 0]) / 6.0


def refine(vertices: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One level of red refinement: (vertices, tetrahedra) with 8x the tetrahedra. The
    original vertices keep their indices; each edge's midpoint is added once."""
    points = [tuple(p) for p in np.asarray(vertices, dtype=float)]
    midpoint: dict[tuple[int, int], int] = {}

    def mid(a: int, b: int) -> int:
        key = (a, b) if a < b else (b, a)
        if key not in midpoint:
            midpoint[key] = len(points)
            points.append(tuple(0.5 * (np.asarray(points[a]) + np.asarray(points[b]))))
        return midpoint[key]

    children = []
    for v0, v1, v2, v3 in np.asarray(tets, dtype=int).tolist():
        m01, m02, m03, m12, m13, m23 = mid(v0, v1), mid(v0, v2), mid(v0, v3), mid(v1, v2), mid(v1, v3), mid(v2, v3)
        children += [(v0, m01, m02, m03), (m01, v1, m12, m13), (m02, m12, v2, m23), (m03, m13, m23, v3),
                     (m01, m02, m03, m13), (m01, m02, m12, m13), (m02, m03, m13, m23), (m02, m12, m13, m23)]
    out_v = np.array(points, dtype=float)
    out_t = np.array(children, dtype=int)
    parent_sign = np.repeat(np.sign(signed_volumes(np.asarray(vertices, float), np.asarray(tets, int))), 8)
    flip = np.sign(signed_volumes(out_v, out_t)) != parent_sign
    out_t[flip] = out_t[flip][:, [0, 2, 1, 3]]  # swap two vertices: the child's orientation matches its parent's
    return out_v, out_t


def refined_box_mesh(size, levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Drake's Box mesh for `size` [m], refined `levels` times (0: Drake's own)."""
    vertices, tets = drake_box_mesh(size)
    for _ in range(int(levels)):
        vertices, tets = refine(vertices, tets)
    return vertices, tets


def vtk_text(vertices: np.ndarray, tets: np.ndarray, title: str = "refined box") -> str:
    """Legacy ASCII VTK (version 3.0) unstructured grid of tetrahedra (cell type 10), the
    format Drake reads for a compliant hydroelastic mesh; coordinates at full precision."""
    lines = ["# vtk DataFile Version 3.0", title[:200], "ASCII", "DATASET UNSTRUCTURED_GRID",
             f"POINTS {len(vertices)} double"]
    lines += [" ".join(repr(float(c)) for c in p) for p in vertices]
    lines.append(f"CELLS {len(tets)} {5 * len(tets)}")
    lines += ["4 " + " ".join(str(int(i)) for i in t) for t in tets]
    lines.append(f"CELL_TYPES {len(tets)}")
    lines += ["10"] * len(tets)
    return "\n".join(lines) + "\n"


def cached_mesh_file(size, levels: int, cache_dir: str | Path) -> Path:
    """Path of the .vtk file of the `levels`-refined Box mesh of `size` [m] under
    `cache_dir`, written there on first use (name from the size in mm and the level)."""
    size = [float(v) for v in size]
    cache = Path(cache_dir)
    cache.mkdir(parents=True, exist_ok=True)
    path = cache / ("box_" + "x".join(f"{v * 1e3:.1f}" for v in size) + f"_L{int(levels)}.vtk")
    if not path.is_file():
        vertices, tets = refined_box_mesh(size, levels)
        tmp = path.with_name(path.name + ".partial")
        tmp.write_text(vtk_text(vertices, tets, f"Drake box mesh {size} m refined {levels} levels"))
        tmp.replace(path)
    return path
