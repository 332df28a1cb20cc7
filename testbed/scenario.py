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

Effect lifecycle: `validate_scenario` constructs and checks the declared effects (a check
may load what the effect needs, e.g. learned_dynamics's predictor) and returns them;
`load_scenario` keeps them on the Scenario, and the builder takes those very objects
(`checked_effects`) while the scenario is unchanged since, once: an effect builds one
diagram. A copy (copy.deepcopy, pickling) carries no checked effects.
"""


import copy
import dataclasses
import difflib
import math
import typing
from pathlib import Path

import numpy as np
import yaml
from pydrake.common.schema import Transform
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.analysis import SimulatorConfig

from learned_contact.sources import SHIPPED_NAMES, source_of
from testbed.bodies.boxes import BOX_TYPE, BoxSpec, GroundSpec, validate_box, validate_ground
from testbed.bodies.containers import CONTAINER_TYPES, ContainerType
from testbed.bodies.models import GROUND_NAME
from testbed.bodies.yards import YardSpec, validate_yard, yard_slots
from testbed.effects import registry
from testbed.effects.contact import drake_approximation
from testbed.errors import ScenarioError
from testbed.safe_files import read_bounded, yaml_problem
from testbed.scene_yaml import SceneDumper, apply_override, check_raw, parse_override, parse_yaml

SCENES_DIR = Path(__file__).resolve().parent / "scenes"
# A scene file is at most 256 KiB (about 1,700 containers; the shipped scenes are under 1.1 KiB):
# PyYAML's pure-Python reader takes about 1.5 s per 256 KiB here, so a larger file is refused
# before parsing. Nesting, aliases and duplicate keys are bounded too (testbed/safe_files.py).
MAX_SCENE_BYTES = 256 * 1024


@dataclasses.dataclass
class ContainerSpec:
    """One container in a scene (see the module docstring for the YAML form), or a
    generic box: `type: box` with a `box:` block (size, density or inertia, contact)."""

    name: str = "container"
    type: str = "1CC"
    mass: typing.Optional[float] = None  # [kg] total; None = tare (box: density x volume)
    com_offset: typing.List[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    X_WC: Transform = dataclasses.field(default_factory=Transform)
    V_WC: typing.List[float] = dataclasses.field(default_factory=lambda: [0.0] * 6)
    fixed: bool = False
    box: typing.Optional[BoxSpec] = None  # only with type: box

    def total_mass(self) -> float:
        """[kg]"""
        if self.mass is not None:
            return float(self.mass)
        if self.type == BOX_TYPE:
            if self.box is None or self.box.density is None:
                return float("nan")
            return float(self.box.density * np.prod(self.box.size))
        return CONTAINER_TYPES[self.type].tare_mass

    def container_type(self) -> ContainerType:
        """The type's facts (size, colour, ...); for a box, made from its `box:` block."""
        if self.type != BOX_TYPE:
            return CONTAINER_TYPES[self.type]
        box = self.box or BoxSpec()
        return ContainerType(code=BOX_TYPE, description="generic rigid box", size=tuple(float(v) for v in box.size),
                             tare_mass=self.total_mass(), max_gross_mass=float("inf"), model_url="",
                             rgba=tuple(float(v) for v in box.rgba))

    def pose(self):
        """X_WC as a pydrake RigidTransform."""
        return self.X_WC.GetDeterministicValue()


def _effects_dataclass():
    """`Effects`: one optional field per registered effect, None = not declared."""
    fields = [
        (name, typing.Optional[cls.Config], dataclasses.field(default=None))
        for name, cls in registry().items()
    ]
    cls = dataclasses.make_dataclass("Effects", fields)
    cls.__module__ = __name__
    return cls


Effects = _effects_dataclass()


def _default_plant() -> MultibodyPlantConfig:
    # Drake's defaults except the time step (1 ms, the crane simulators' rate).
    # Sampled output ports stay on: the contact logger pairs each sampled result
    # with the state it came from, and unsampled ports would solve contact twice.
    # contact_model / discrete_contact_approximation mirror the default `contact` effect.
    # stiction_tolerance 1e-6 m/s, not Drake's 1e-4: the 'similar' approximation (the default
    # for hydroelastic contact) regularises friction with it, and at 1e-4 m/s a stack creeps
    # under a steady side load (windy_stack: 2.3 / 4.6 / 6.8 mm/min per tier; 1e-6: 0.08 / 0.22 /
    # 0.28, as SAP's 0.07 / 0.20 / 0.25; same cost; sdf/README.md). SAP does not use it.
    return MultibodyPlantConfig(
        time_step=1e-3, contact_model="hydroelastic_with_fallback", discrete_contact_approximation="similar",
        stiction_tolerance=1e-6,
    )


def _default_effects():
    return Effects(**{name: cls.Config() if cls.default_on else None for name, cls in registry().items()})


def _default_containers() -> list[ContainerSpec]:
    h = CONTAINER_TYPES["1CC"].size[2]
    return [ContainerSpec(name="box", type="1CC", mass=20000.0, X_WC=Transform(translation=[0, 0, h / 2]))]


TRUTH_REFERENCES = ("discrete", "continuous")


@dataclasses.dataclass
class TruthSpec:
    """The ground truth this scene's closed loop is judged against (docs/truth.md).

    reference: "discrete" (the scene's plant as given: Drake's discrete solver, each contact
    polygon's force at its centroid) or "continuous" (the converged rung: a continuous-time plant
    with triangle contact surfaces, whose moments Drake integrates exactly, RungeKutta3 with error
    control at `accuracy`; `testbed study truth` shows where the discrete answer is mesh- or
    step-sensitive and what the continuous one costs). The scene's own runs (`testbed run`) and
    Drake's runs in engine comparisons keep the discrete plant."""

    reference: str = "discrete"
    accuracy: float = 1e-3  # [-] the integrator's error-control accuracy (continuous only)


@dataclasses.dataclass
class Scenario:
    """A whole scene. `Scenario()` is the always-valid "defaults" scene."""

    name: str = "defaults"
    description: str = "One loaded 20 ft container resting on the quay."
    duration: float = 1.0  # [s] simulated
    ground: bool = True  # the quay slab (sdf/ground/quay_ground.sdf), or ground_surface when given
    ground_surface: typing.Optional[GroundSpec] = None  # a slab or half-space at a height; None = the quay slab
    overlap_tolerance: float = 5e-3  # [m] largest allowed penetration at t = 0
    plant: MultibodyPlantConfig = dataclasses.field(default_factory=_default_plant)
    simulator: SimulatorConfig = dataclasses.field(default_factory=SimulatorConfig)
    containers: typing.List[ContainerSpec] = dataclasses.field(default_factory=_default_containers)
    # yard blocks (testbed/bodies/yards.py), expanded into `containers` by validate_scenario
    yards: typing.List[YardSpec] = dataclasses.field(default_factory=list)
    effects: Effects = dataclasses.field(default_factory=_default_effects)
    truth: TruthSpec = dataclasses.field(default_factory=TruthSpec)

    def declared_effects(self) -> list[str]:
        """Names of the declared effects, in build order."""
        return [name for name in registry() if getattr(self.effects, name, None) is not None]

    def __getstate__(self) -> dict:
        """Copies and pickles leave the checked effects behind (they hold loaded predictors)."""
        return {k: v for k, v in self.__dict__.items() if k != _CHECKED}


_CHECKED = "_checked_effects"  # Scenario attribute: (dump_scenario text, {name: checked Effect})


# ----------------------------------------------------------------------------- loading

_DERIVED_PLANT_FIELDS = {"contact_model": "model", "discrete_contact_approximation": "approximation"}


def _typed_from_raw(data: dict, source) -> Scenario:
    """Raw YAML data -> Scenario, with field-path errors; plant contact fields must agree
    with effects.contact (they are derived from it)."""
    check_raw(data, Scenario, "", source)
    effects = data.get("effects")
    if effects is not None:
        data["effects"] = {k: (v if v is not None else {}) for k, v in effects.items()}

    contact = (data.get("effects") or {}).get("contact") or {}
    defaults = registry()["contact"].Config()
    derived = {k: contact.get(k, getattr(defaults, k)) for k in _DERIVED_PLANT_FIELDS.values()}
    derived["approximation"] = drake_approximation(derived["approximation"], derived["model"])  # 'auto' resolved
    for plant_key, contact_key in _DERIVED_PLANT_FIELDS.items():
        given = (data.get("plant") or {}).get(plant_key)
        if given is not None and given != derived[contact_key]:
            raise ScenarioError(source, f"plant.{plant_key}", f"is set from effects.contact.{contact_key}; set it there (got {given!r} here)")
    clean = yaml.dump(data, Dumper=SceneDumper, sort_keys=False)
    defaults = Scenario()
    if "effects" in data:  # declared effects replace the default set entirely
        defaults.effects = Effects()
    if "containers" in data or "yards" in data:  # a yard scene lists no container: not the default one
        defaults.containers = []
    try:
        scenario = yaml_load_typed(schema=Scenario, data=clean, defaults=defaults)
    except Exception as e:  # Drake's loader: RuntimeError/ValueError with a bare message
        first = " ".join(str(e).strip().splitlines()[0].split()) if str(e).strip() else type(e).__name__
        raise ScenarioError(source, "", f"does not match the scene schema: {first}") from None
    if scenario.effects.contact is not None:  # keep the dumped plant config truthful
        derive_plant(scenario)
    return scenario


def load_scenario(path: str | Path | None = None, *, text: str | None = None, overrides: typing.Sequence[str] = ()) -> Scenario:
    """Loads, overrides and validates a scene.

    path: a scene file, or a shipped scene name (see `shipped_scenes`);
    text: YAML text instead of a file; overrides: ['key.path=value', ...] applied to
    the fully resolved scene (so `containers[0].mass=25000` works on a scene that
    relies on defaults, and `effects.wind=null` removes a declared effect).
    Raises ScenarioError naming the file and field on any problem.

    Limits (testbed/safe_files.py), each refused with one ScenarioError before any parsing
    or simulation: the file must be a regular file (not a directory, device or FIFO) of at
    most MAX_SCENE_BYTES = 256 KiB, UTF-8; YAML nested at most 64 levels, aliases expanding
    to at most 10,000 nodes, each key at most once per mapping; a --set entry at most 4096
    characters. The checked data, written out without aliases, is what Drake's
    yaml_load_typed reads.
    """
    if text is None:
        if path is None:
            raise ValueError("give a path or text")
        path = resolve_scene_path(path)
        if not Path(path).exists():
            raise ScenarioError(path, "", f"cannot read the scene file (No such file or directory){_near_names(path)}")
        raw = read_bounded(path, MAX_SCENE_BYTES, "scene file", ScenarioError)  # regular file, size limit
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as e:
            line = raw[: e.start].count(b"\n") + 1
            raise ScenarioError(path, "", f"is not UTF-8 text (byte 0x{raw[e.start]:02x} at line {line}); "
                                          "save the scene as UTF-8") from None
        if not text.strip() or all(not ln.strip() or ln.lstrip().startswith("#") for ln in text.splitlines()):
            raise ScenarioError(path, "", "is empty; expected scene fields such as 'containers:' "
                                          "(the 'defaults' scene is `testbed run defaults`)")
    source = str(path) if path is not None else "<string>"
    scenario = _typed_from_raw(parse_yaml(text, source), source)
    _file_predictors(scenario, Path(path).resolve().parent if path is not None else Path.cwd(), source)
    if overrides:
        data = parse_yaml(yaml_dump_typed(scenario), source)
        for key in _DERIVED_PLANT_FIELDS:
            data.get("plant", {}).pop(key, None)
        source = source_label(source, overrides)  # every error from here on says the overrides are in play
        for override in overrides:
            try:
                parts, value = parse_override(override)
            except ValueError as e:
                raise ScenarioError(source, "--set", str(e)) from None
            except yaml.YAMLError as e:
                raise ScenarioError(source, "--set", f"{override[:80]!r}: {yaml_problem(e)}") from None
            apply_override(data, parts, value, source)
        scenario = _typed_from_raw(data, source)
    effects = validate_scenario(scenario, source)
    setattr(scenario, _CHECKED, (dump_scenario(scenario), effects))
    return scenario


def _file_predictors(scenario: Scenario, folder: Path, source) -> None:
    """A scene file is data, never code: an effect's `predictor` written in it may name a shipped
    predictor or a model file (.onnx, .npz; a relative path is taken from the scene's own folder
    and made absolute here), not `module:attribute`, which only the command line (--predictor,
    --set) and the Python API accept. ScenarioError naming the field otherwise."""
    for name in scenario.declared_effects():
        config = getattr(scenario.effects, name)
        value = getattr(config, "predictor", None)
        if not isinstance(value, str) or value in SHIPPED_NAMES:
            continue
        field = f"effects.{name}.predictor"
        path = Path(value) if Path(value).is_absolute() else folder / value
        if not value.lower().endswith((".onnx", ".npz")):
            kind = "a Python model (module:attribute)" if source_of(value).key == "python" else "neither a shipped predictor nor a model file"
            raise ScenarioError(source, field, f"{value!r} is {kind}; a scene file may name only {', '.join(SHIPPED_NAMES)} or "
                                               "a model file (.onnx, .npz, relative to the scene's folder): Python models run "
                                               "code and are accepted only from the command line (--predictor) or the Python API")
        config.predictor = str(path.resolve())


def source_label(path, overrides=()) -> str:
    """How errors name a scene: its file, plus ' (with --set overrides)' when any are given,
    so that a field an override set is not blamed on the file alone."""
    return f"{path} (with --set overrides)" if overrides else str(path)


def _near_names(path) -> str:
    """'; did you mean two_stack? ...' for a missing scene whose name is close to shipped ones
    (difflib), with where the shipped names are listed; '' for a path in a directory, or a
    file name with a suffix and no close shipped name."""
    p = Path(path)
    if len(p.parts) > 1:
        return ""
    close = difflib.get_close_matches(p.stem, list(shipped_scenes()), n=3, cutoff=0.6)
    if close:
        return f"; did you mean {' or '.join(close)}? (`testbed scenes` lists the shipped scenes)"
    return "" if p.suffix else "; no shipped scene has that name either (`testbed scenes` lists them)"


def checked_effects(scenario: Scenario, source: object = "<scenario>") -> dict:
    """{name: Effect} to build `scenario` with: the objects `load_scenario` checked, taken
    (once) if the scenario has not changed since, else newly constructed and checked."""
    held = scenario.__dict__.pop(_CHECKED, None)
    if held is not None and held[0] == dump_scenario(scenario):
        return held[1]
    return validate_scenario(scenario, source)


def validate_scenario(scenario: Scenario, source: object = "<scenario>") -> dict:
    """Physical and semantic checks that need no diagram (overlaps are checked by the builder).
    Returns the declared effects, constructed and checked: {name: Effect}, build order."""
    if not (scenario.duration > 0 and math.isfinite(scenario.duration)):
        raise ScenarioError(source, "duration", f"expected a positive number of seconds, got {scenario.duration}")
    if not scenario.plant.time_step > 0:
        raise ScenarioError(source, "plant.time_step", "expected a positive discrete time step [s] (continuous plants "
                                                       f"are not supported), got {scenario.plant.time_step}")
    if scenario.truth.reference not in TRUTH_REFERENCES:
        raise ScenarioError(source, "truth.reference", f"unknown {scenario.truth.reference!r}; expected one of: "
                                                       f"{', '.join(TRUTH_REFERENCES)}")
    if not 1e-8 <= scenario.truth.accuracy <= 0.1:
        raise ScenarioError(source, "truth.accuracy", f"expected an error-control accuracy in [1e-08, 0.1], got "
                                                      f"{scenario.truth.accuracy}")
    expand_yards(scenario, source)
    if not scenario.containers:
        raise ScenarioError(source, "containers", "expected at least one container")
    seen: set[str] = set()
    for i, c in enumerate(scenario.containers):
        where = f"containers[{i}]"
        if c.type not in CONTAINER_TYPES and c.type != BOX_TYPE:
            raise ScenarioError(source, f"{where}.type", f"unknown container type {c.type!r}; expected one of: {', '.join(CONTAINER_TYPES)}, {BOX_TYPE}")
        validate_box(c, where, source)
        if not c.name or not c.name.replace("_", "").isalnum():
            raise ScenarioError(source, f"{where}.name", f"expected a non-empty name of letters, digits and '_', got {c.name!r}")
        if c.name in seen or c.name == GROUND_NAME:
            raise ScenarioError(source, f"{where}.name", f"duplicate or reserved name {c.name!r}; names must be unique")
        seen.add(c.name)
        mass = c.total_mass()
        if not (math.isfinite(mass) and mass > 0):
            raise ScenarioError(source, f"{where}.mass", f"expected a positive mass [kg], got {mass}")
        if len(c.com_offset) != 3 or not np.all(np.isfinite(c.com_offset)):
            raise ScenarioError(source, f"{where}.com_offset", f"expected 3 finite numbers [m], got {c.com_offset}")
        half = c.container_type().half_size
        if np.any(np.abs(c.com_offset) >= half):
            raise ScenarioError(source, f"{where}.com_offset", f"centre of mass {c.com_offset} lies outside the {c.type} box (half extents {half.tolist()} m)")
        if len(c.V_WC) != 6 or not np.all(np.isfinite(c.V_WC)):
            raise ScenarioError(source, f"{where}.V_WC", f"expected 6 finite numbers [wx, wy, wz, vx, vy, vz], got {c.V_WC}")
        try:
            X = c.pose()
        except Exception as e:
            raise ScenarioError(source, f"{where}.X_WC", f"expected a fixed (deterministic) pose: {e}") from None
        if not np.all(np.isfinite(X.translation())):
            raise ScenarioError(source, f"{where}.X_WC", "expected a finite translation")
    _check_bounds(scenario, source)
    if scenario.ground_surface is not None:
        validate_ground(scenario.ground_surface, source)
    effects = {name: registry()[name](getattr(scenario.effects, name), scenario, source) for name in scenario.declared_effects()}
    for effect in effects.values():
        effect.check(effects)
    return effects


def expand_yards(scenario: Scenario, source: object = "<scenario>") -> None:
    """Validates `scenario.yards` and appends their containers to `scenario.containers`
    (after the listed ones, block by block), then empties `yards`: everything downstream,
    and a dumped scene, sees plain containers. Idempotent."""
    listed = {c.name for c in scenario.containers}
    for i, yard in enumerate(scenario.yards):
        validate_yard(yard, f"yards[{i}]", source)
        for slot in yard_slots(yard):
            if slot.name in listed or slot.name == GROUND_NAME:
                raise ScenarioError(source, f"yards[{i}].name", f"prefix {yard.name!r} makes the name {slot.name!r}, "
                                                                "which another container or yard already has; names must be unique")
            listed.add(slot.name)
            if max(abs(slot.p_WC[0]), abs(slot.p_WC[1])) > BOUNDS["position"]:
                raise ScenarioError(source, f"yards[{i}].origin", f"the block reaches {slot.p_WC[:2]} m, outside the supported "
                                                                  f"range |x|, |y| <= {BOUNDS['position']:g} m")
            X_WC = Transform(translation=list(slot.p_WC))
            if slot.yaw_deg:
                X_WC.set_rotation_rpy_deg([0.0, 0.0, slot.yaw_deg])
            scenario.containers.append(ContainerSpec(name=slot.name, type=slot.type, mass=slot.mass, X_WC=X_WC))
    scenario.yards = []


# Physically meaningful ranges. Values outside them are typos or unit mistakes, and they
# would otherwise reach the solver (a 1e9 m/s velocity, a 1e30 kg mass) and fail deep
# inside Drake or produce garbage. The ranges are wide on purpose: the stress suite puts a
# 32.5 kg box under a 32.5 t one, the calibration a 0.37 kg cube on a table.
BOUNDS = {
    "duration": (0.0, 3600.0),  # [s] an hour of simulated time at most
    "time_step": (1e-6, 0.1),  # [s]
    "mass": (1e-3, 1e6),  # [kg] 1 g to 1000 t (33x a fully loaded 40 ft container)
    "position": 1e3,  # [m] |p_WC| per axis; the quay slab is 400 m wide
    "speed": 100.0,  # [m/s] |v_WC|; a 500 m free fall reaches 99 m/s
    "spin": 100.0,  # [rad/s] |w_WC|
}


def _check_bounds(scenario: Scenario, source) -> None:
    """Raises ScenarioError for values outside BOUNDS (field path, value and range named)."""
    lo, hi = BOUNDS["duration"]
    if not scenario.duration <= hi:
        raise ScenarioError(source, "duration", f"{scenario.duration} s is outside the supported range (0, {hi:g}] s")
    lo, hi = BOUNDS["time_step"]
    if not lo <= scenario.plant.time_step <= hi:
        raise ScenarioError(source, "plant.time_step", f"{scenario.plant.time_step} s is outside the supported range [{lo:g}, {hi:g}] s")
    for i, c in enumerate(scenario.containers):
        where = f"containers[{i}]"
        lo, hi = BOUNDS["mass"]
        if not lo <= c.total_mass() <= hi:
            raise ScenarioError(source, f"{where}.mass", f"{c.total_mass():g} kg is outside the supported range [{lo:g}, {hi:g}] kg")
        p = np.asarray(c.pose().translation())
        if np.any(np.abs(p) > BOUNDS["position"]):
            raise ScenarioError(source, f"{where}.X_WC.translation", f"{p.tolist()} m is outside the supported range |x|, |y|, |z| <= {BOUNDS['position']:g} m")
        w, v = np.asarray(c.V_WC[:3], float), np.asarray(c.V_WC[3:], float)
        if np.linalg.norm(v) > BOUNDS["speed"]:
            raise ScenarioError(source, f"{where}.V_WC", f"speed {np.linalg.norm(v):g} m/s is above the supported {BOUNDS['speed']:g} m/s")
        if np.linalg.norm(w) > BOUNDS["spin"]:
            raise ScenarioError(source, f"{where}.V_WC", f"angular speed {np.linalg.norm(w):g} rad/s is above the supported {BOUNDS['spin']:g} rad/s")


def dump_scenario(scenario: Scenario) -> str:
    """The fully resolved scenario as YAML (every default written out).

    `effects.contact` is the one source of truth for the contact model: the plant's
    copies (contact_model, discrete_contact_approximation) are written derived from it,
    so a scenario whose effects were edited in code still loads back.
    """
    if scenario.effects.contact is not None:
        scenario = copy.deepcopy(scenario)
        derive_plant(scenario)
    return yaml_dump_typed(scenario)


def derive_plant(scenario: Scenario) -> None:
    """The plant's copies of the contact effect's model and (resolved) approximation."""
    contact = scenario.effects.contact
    scenario.plant.contact_model = contact.model
    scenario.plant.discrete_contact_approximation = drake_approximation(contact.approximation, contact.model)


def shipped_scenes() -> dict[str, Path]:
    """Shipped scene name -> file, from testbed/scenes/."""
    return {p.stem: p for p in sorted(SCENES_DIR.glob("*.yaml"))}


def resolve_scene_path(path: str | Path) -> Path:
    """A file path, or the name of a shipped scene ('five_stack')."""
    p = Path(path)
    if p.exists() or p.suffix in (".yaml", ".yml"):
        return p
    return shipped_scenes().get(str(path), p)
