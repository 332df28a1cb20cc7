"""Cube-toss parameters <-> a scene fragment (params.yaml) that a scene or `--set` can use.

The fragment is an ordinary scene (testbed/scenario/): the cube is a generic box
(`type: box`, testbed/bodies/boxes.py) resting on a table slab (`ground_surface`) whose top is at
the fitted height, both carrying the same contact values, as the rollouts had them.
Loading goes through `load_scenario`, so a params file is checked like any scene.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import yaml

from testbed.calibration.data import CUBE_INERTIA, CUBE_MASS, CUBE_WIDTH
from testbed.calibration.rollout import CubeTossParams
from testbed.errors import ScenarioError, TestbedError
from testbed.scenario import load_scenario

TABLE_SIZE = (20.0, 20.0, 1.0)  # [m] the rollouts' table slab (a half-space would use another box-plane routine)
_GROUND_KEYS = ("mu_dynamic", "mu_static", "point_contact_stiffness", "hunt_crossley_dissipation", "relaxation_time")


def to_fragment(params: CubeTossParams, comment: str = "") -> str:
    """YAML text of the scene fragment for `params` (comment lines first, if given)."""
    contact = params.proximity()
    scene = {
        "name": "cube_toss",
        "description": "0.1048 m cube on a table; contact values fitted to real tosses (testbed calibrate)",
        "duration": 1.0,
        "plant": {"time_step": float(params.time_step), "stiction_tolerance": float(params.stiction_tolerance),
                  **({"contact_surface_representation": params.contact_surface_representation}
                     if params.contact_surface_representation != "polygon" else {})},
        "ground_surface": {"shape": "slab", "height": float(params.table_height), "size": list(TABLE_SIZE),
                           "contact": {k: float(contact[k]) for k in _GROUND_KEYS}},
        "containers": [{
            "name": "cube", "type": "box", "mass": CUBE_MASS,
            "X_WC": {"translation": [0.0, 0.0, float(params.table_height + CUBE_WIDTH / 2)]},
            "box": {"size": [CUBE_WIDTH] * 3, "inertia": [CUBE_INERTIA] * 3,
                    "corner_spheres": float(params.corner_spheres) if params.model == "point" else 0.0,
                    "contact": {k: float(v) for k, v in contact.items()}},
        }],
        "effects": {"contact": {"model": params.model, "approximation": params.approximation}, "friction": {}},
    }
    header = "".join(f"# {line}\n" for line in comment.splitlines())
    return header + yaml.safe_dump(scene, sort_keys=False, default_flow_style=None)


def from_fragment(path: str | Path) -> CubeTossParams:
    """Reads a params file written by `to_fragment` (or any scene of that shape).
    Raises ScenarioError (file, field, expectation) if it is not one."""
    path = Path(path)
    scenario = load_scenario(path)
    source = str(path)
    boxes = [c for c in scenario.containers if c.type == "box"]
    if len(boxes) != 1:
        raise ScenarioError(source, "containers", f"expected exactly one 'type: box' entry (the cube), found {len(boxes)}")
    cube = boxes[0]
    size = [float(v) for v in cube.box.size]
    if max(abs(v - CUBE_WIDTH) for v in size) > 1e-6:
        raise ScenarioError(source, "containers[0].box.size", f"expected the data's cube, {[CUBE_WIDTH] * 3} m, got {size}")
    if scenario.ground_surface is None:
        raise ScenarioError(source, "ground_surface", "expected the table: {shape: slab, height: ..., contact: {...}}")
    contact = cube.box.contact.given()
    ground = scenario.ground_surface.contact.given()
    for key in _GROUND_KEYS:
        if key not in contact:
            raise ScenarioError(source, f"containers[0].box.contact.{key}", "expected a value (the rollout needs every contact value)")
        if ground.get(key) != contact[key]:
            raise ScenarioError(source, f"ground_surface.contact.{key}",
                                f"expected the cube's value {contact[key]!r} (the rollouts set the same values on both), got {ground.get(key)!r}")
    if contact["mu_static"] != contact["mu_dynamic"]:
        raise ScenarioError(source, "containers[0].box.contact.mu_static", "expected mu_static = mu_dynamic (the fit varies one friction)")
    defaults = CubeTossParams()
    params = CubeTossParams(
        model=scenario.effects.contact.model, approximation=scenario.effects.contact.approximation,
        time_step=scenario.plant.time_step, stiction_tolerance=scenario.plant.stiction_tolerance, mu=contact["mu_dynamic"],
        point_contact_stiffness=contact["point_contact_stiffness"],
        hydroelastic_modulus=contact.get("hydroelastic_modulus", defaults.hydroelastic_modulus),
        relaxation_time=contact["relaxation_time"], hunt_crossley_dissipation=contact["hunt_crossley_dissipation"],
        hydroelastic_margin=contact.get("hydroelastic_margin", 0.0), table_height=scenario.ground_surface.height,
        corner_spheres=cube.box.corner_spheres,
        contact_surface_representation=scenario.plant.contact_surface_representation)
    try:
        params.check()
    except TestbedError as e:
        raise ScenarioError(source, "", f"not usable for a cube-toss rollout: {e}") from None
    return params


def params_dict(params: CubeTossParams) -> dict:
    return dataclasses.asdict(params)
