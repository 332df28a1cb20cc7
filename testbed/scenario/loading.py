"""Loading a scene: `load_scenario` (a file, a shipped scene's name or YAML text, then --set
overrides), `dump_scenario` (the fully resolved scene as YAML) and the checked effects.

Effect lifecycle: `validate_scenario` constructs and checks the declared effects (a check
may load what the effect needs, e.g. learned_dynamics's predictor) and returns them;
`load_scenario` keeps them on the Scenario, and the builder takes those very objects
(`checked_effects`) while the scenario is unchanged since, once: an effect builds one
diagram. A copy (copy.deepcopy, pickling) carries no checked effects.
"""

import copy
import typing
from pathlib import Path

import yaml
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from learned_contact.sources import SHIPPED_NAMES, source_of
from testbed.effects import registry
from testbed.effects.contact import drake_approximation
from testbed.errors import ScenarioError
from testbed.safe_files import read_bounded, yaml_problem
from testbed.scenario.shipped import near_names, resolve_scene_path
from testbed.scenario.spec import _CHECKED, Effects, Scenario, derive_plant
from testbed.scenario.validation import validate_scenario
from testbed.scene_yaml import SceneDumper, apply_override, check_raw, parse_override, parse_yaml

# A scene file is at most 256 KiB (about 1,700 containers; the shipped scenes are under 1.1 KiB):
# PyYAML's pure-Python reader takes about 1.5 s per 256 KiB here, so a larger file is refused
# before parsing. Nesting, aliases and duplicate keys are bounded too (testbed/safe_files.py).
MAX_SCENE_BYTES = 256 * 1024


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
            raise ScenarioError(path, "", f"cannot read the scene file (No such file or directory){near_names(path)}")
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



def checked_effects(scenario: Scenario, source: object = "<scenario>") -> dict:
    """{name: Effect} to build `scenario` with: the objects `load_scenario` checked, taken
    (once) if the scenario has not changed since, else newly constructed and checked."""
    held = scenario.__dict__.pop(_CHECKED, None)
    if held is not None and held[0] == dump_scenario(scenario):
        return held[1]
    return validate_scenario(scenario, source)


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
