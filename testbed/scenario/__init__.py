"""Scenes: the typed `Scenario`, its YAML loading, overrides and validation.

A scene file is YAML in Drake's conventions (pydrake.common.yaml.yaml_load_typed):

    name: two_stack
    duration: 2.0                      # simulated time [s]
    plant: {time_step: 0.001}          # Drake's MultibodyPlantConfig
    containers:
    - name: bottom
      type: 1CC                        # 1CC | 1AA | 1AAA (testbed/bodies/containers.py)
      mass: 20000                      # total mass [kg]; omitted = tare
      com_offset: [0.5, 0, 0]          # COM from the geometric centre, frame C [m]
      X_WC: {translation: [0, 0, 1.2955]}  # pose of C in world; rotation: !Rpy {deg: [..]}
      V_WC: [0, 0, 0, 0, 0, 0]         # [wx wy wz vx vy vz] in W [rad/s, m/s]
      fixed: false                     # true = welded to the world
    yards: []                          # yard blocks: rows x bays x tiers (testbed/bodies/yards.py)
    effects:                           # only these are built (testbed/effects/)
      contact: {model: hydroelastic, approximation: sap}
      friction: {}

The contact model and discrete approximation are set in `effects.contact`;
`plant.contact_model` and `plant.discrete_contact_approximation` are derived from
it (a file may repeat them, as dumped runs do, but they must agree). Everything a run used is written back with
`dump_scenario` next to its output.

The package, by concept (everything below is importable from `testbed.scenario`):
- spec.py: the dataclasses (Scenario, ContainerSpec, TruthSpec, Effects) and their defaults;
- loading.py: `load_scenario` (files, text, --set overrides), `dump_scenario`, the checked
  effects' lifecycle (`checked_effects`);
- validation.py: `validate_scenario`, the checks of every field, BOUNDS, yard expansion;
- shipped.py: the shipped scenes (testbed/scenes/) and scene-name lookup.
"""

from testbed.scenario.loading import MAX_SCENE_BYTES, checked_effects, dump_scenario, load_scenario, source_label
from testbed.scenario.shipped import SCENES_DIR, resolve_scene_path, shipped_scenes
from testbed.scenario.spec import TRUTH_REFERENCES, ContainerSpec, Effects, Scenario, TruthSpec, derive_plant
from testbed.scenario.validation import BOUNDS, expand_yards, validate_scenario

__all__ = ["BOUNDS", "MAX_SCENE_BYTES", "SCENES_DIR", "TRUTH_REFERENCES", "ContainerSpec", "Effects", "Scenario", "TruthSpec",
           "checked_effects", "derive_plant", "dump_scenario", "expand_yards", "load_scenario", "resolve_scene_path",
           "shipped_scenes", "source_label", "validate_scenario"]
