"""The rungs of the truth ladder: one scene run under one truth, measured alike.

  polygon      the scene as shipped: its discrete plant, its time step h, Drake's polygon
               contact surfaces (each polygon's force at its centroid)
  triangle     the same, contact_surface_representation: triangle
  half_step    polygon at h / 2 (shows whether the time step decides the answer)
  refined_L1   polygon, every container's compliant box replaced by Drake's own box mesh
  refined_L2   refined 1 / 2 levels (8x / 64x the tetrahedra, the same pressure field;
               mesh_refine.py), generated into the study's cache directory
  continuous   time_step 0, triangle surfaces, RungeKutta3 with error control at each
               accuracy given (e.g. 1e-3 and 1e-4): rung names continuous_a1e-03, ...

Every rung runs Drake's contact alone (no learned loop, no observers or viewers:
testbed.variants.physics_only(learned=False)) with the contact log on at every step of h
(the continuous plant: its records at the same period h), for the same duration [s].
A rung whose diagram Drake refuses or whose simulation fails is kept with status 'failed',
its error and no quantities (the crane scenes' continuous rung: the crane's force output is
declared direct-feedthrough from the plant's contact results, an algebraic loop once the
plant is continuous).
"""

from __future__ import annotations

import time
import warnings

from testbed import variants
from testbed.builder import build_scene
from testbed.errors import SimulationError
from testbed.simulation import simulate
from testbed.studies.truth.mesh_refine import cached_mesh_file
from testbed.studies.truth.quantities import quantities

RUNGS = ("polygon", "triangle", "half_step", "refined_L1", "refined_L2", "continuous")
DEFAULT_ACCURACIES = (1e-3, 1e-4)  # [-] error-control accuracies of the continuous rung


def continuous_name(accuracy: float) -> str:
    """The rung name of the continuous plant at `accuracy`, e.g. continuous_a1e-04."""
    return f"continuous_a{accuracy:.0e}"


def expand(rungs, accuracies=DEFAULT_ACCURACIES) -> list[tuple[str, str, float | None]]:
    """[(rung name, kind, accuracy or None)] in ladder order: 'continuous' becomes one rung
    per accuracy, coarsest (largest) first."""
    out = []
    for kind in RUNGS:
        if kind not in rungs:
            continue
        if kind == "continuous":
            out += [(continuous_name(a), kind, float(a)) for a in sorted(accuracies, reverse=True)]
        else:
            out.append((kind, kind, None))
    return out


def base_scenario(scenario, duration: float):
    """The scene as every rung starts from it: Drake's contact only, logged every step."""
    return variants.derive(scenario, variants.physics_only(learned=False), variants.log_contacts(1),
                           variants.timing(duration=duration))


def build(kind: str, base, *, accuracy: float | None, cache_dir, source: object):
    """The BuiltScene of rung `kind` from the prepared scenario `base` (base_scenario)."""
    if kind == "polygon":
        return build_scene(variants.derive(base), source)
    if kind == "triangle":
        s = variants.derive(base)
        s.plant.contact_surface_representation = "triangle"
        return build_scene(s, source)
    if kind == "half_step":
        s = variants.derive(base, variants.timing(time_step=base.plant.time_step / 2), variants.log_contacts(1))
        return build_scene(s, source)
    if kind.startswith("refined_L"):
        level = int(kind[len("refined_L"):])
        sizes = {tuple(float(v) for v in c.container_type().size) for c in base.containers}
        meshes = {size: cached_mesh_file(size, level, cache_dir) for size in sizes}
        return build_scene(variants.derive(base), source, meshes=meshes)
    if kind == "continuous":
        return build_scene(variants.derive(base), source, continuous_accuracy=float(accuracy))
    raise ValueError(f"unknown rung {kind!r}")


def run_rung(name: str, kind: str, base, *, accuracy: float | None, cache_dir, source: object = "<scenario>") -> dict:
    """One rung: {'rung', 'kind', 'accuracy', 'time_step_s', 'status' ('ok' | 'failed'),
    'error', 'build_s', 'wall_s' (wall time of the stepping alone [s]), 'wall_per_sim_s'
    [s / simulated s], 'quantities' ({name: value}; {} when failed)}."""
    start = time.perf_counter()
    row = {"rung": name, "kind": kind, "accuracy": accuracy, "time_step_s": 0.0 if kind == "continuous" else None,
           "status": "ok", "error": "", "build_s": None, "wall_s": None, "wall_per_sim_s": None, "quantities": {}}
    try:
        scene = build(kind, base, accuracy=accuracy, cache_dir=cache_dir, source=source)
    except RuntimeError as e:  # Drake refuses the diagram (e.g. an effect's algebraic loop on a continuous plant)
        return {**row, "status": "failed", "error": "build: " + " ".join(str(e).split())[:300]}
    row.update(build_s=time.perf_counter() - start, time_step_s=scene.plant.time_step())
    try:
        with warnings.catch_warnings():  # the contact log's phi is NaN for mesh pairs (no box closed form)
            warnings.simplefilter("ignore", RuntimeWarning)
            result = simulate(scene, duration=base.duration)
    except SimulationError as e:
        return {**row, "status": "failed", "error": str(e)[:300]}
    wall = float(result.summary["wall_time_s"])
    return {**row, "wall_s": wall, "wall_per_sim_s": wall / base.duration,
            "quantities": quantities(scene.scenario, result.body_names, result.tables)}

