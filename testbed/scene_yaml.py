"""Scene YAML below the typed loader: PyYAML with Drake's !Tags kept, raw data checked
against the scene schema with field paths in every error, and --set overrides.

testbed/scenario/ turns the checked data into a Scenario (Drake's yaml_load_typed);
this module knows only the schema's shape (dataclass fields, pydrake config fields).
"""

from __future__ import annotations

import dataclasses
import typing

import yaml
from pydrake.common.schema import Transform

from testbed.errors import ScenarioError, one_of
from testbed.safe_files import BoundedYamlMixin, yaml_problem

MAX_OVERRIDE_CHARS = 4096  # one --set value; a scene field's value is a few dozen characters


class _Tagged:
    """A YAML node with a `!Tag` kept through PyYAML round trips (e.g. !Rpy)."""

    def __init__(self, tag, value):
        self.tag, self.value = tag, value


class SceneLoader(BoundedYamlMixin, yaml.SafeLoader):
    """SafeLoader with Drake's !Tags kept and testbed.safe_files' bounds: nesting depth,
    alias expansion, no duplicate keys."""


class SceneDumper(yaml.SafeDumper):
    """Writes shared objects out in full (no &anchors): the text handed to Drake's typed
    loader holds no aliases (their expansion is bounded when the scene is read)."""

    def ignore_aliases(self, data):
        return True


def _construct_tagged(loader, tag_suffix, node):
    if isinstance(node, yaml.MappingNode):
        value = loader.construct_mapping(node, deep=True)
    elif isinstance(node, yaml.SequenceNode):
        value = loader.construct_sequence(node, deep=True)
    else:
        value = loader.construct_scalar(node)
    return _Tagged("!" + tag_suffix, value)


SceneLoader.add_multi_constructor("!", _construct_tagged)
SceneDumper.add_representer(
    _Tagged,
    lambda dumper, t: (
        dumper.represent_mapping(t.tag, t.value)
        if isinstance(t.value, dict)
        else dumper.represent_sequence(t.tag, t.value)
        if isinstance(t.value, list)
        else dumper.represent_scalar(t.tag, t.value)
    ),
)


def _fields_of(schema) -> dict[str, object] | None:
    """Field name -> type for a Python dataclass or a pydrake config class; else None."""
    if dataclasses.is_dataclass(schema):
        return typing.get_type_hints(schema)
    if hasattr(schema, "__fields__") and isinstance(schema.__fields__, tuple):
        return {f.name: f.type for f in schema.__fields__}
    return None


def _is_number(value) -> bool:
    """A YAML number, or a string PyYAML left unparsed that reads as one ('1e7')."""
    if isinstance(value, bool):
        return False
    if isinstance(value, (int, float)):
        return True
    if isinstance(value, str):
        try:
            float(value)
            return True
        except ValueError:
            return False
    return False


def _join(path: str, key) -> str:
    return f"{path}[{key}]" if isinstance(key, int) else (f"{path}.{key}" if path else str(key))


def check_raw(value, schema, path: str, source) -> None:
    """Checks raw YAML data against `schema`, naming the field path on any mismatch."""
    fields = _fields_of(schema)
    origin = typing.get_origin(schema)
    if fields is not None:
        if schema is Transform:
            if not isinstance(value, dict):
                raise ScenarioError(source, path, "expected a transform mapping {translation: [x, y, z], rotation: !Rpy {deg: [r, p, y]}}")
            unknown = set(value) - set(fields)
            if unknown:
                raise ScenarioError(source, _join(path, sorted(unknown)[0]), f"unknown field; {one_of(sorted(unknown)[0], fields)}")
            t = value.get("translation")
            if t is not None and not (isinstance(t, list) and len(t) == 3 and all(_is_number(x) for x in t)):
                raise ScenarioError(source, _join(path, "translation"), f"expected 3 numbers [x, y, z] in metres, got {t!r}")
            return  # Drake checks the rotation variants itself
        if not isinstance(value, dict):
            raise ScenarioError(source, path, f"expected a mapping with fields ({', '.join(fields)}), got {type(value).__name__} {value!r}")
        for key, sub in value.items():
            if key not in fields:
                what = "unknown effect" if path == "effects" else "unknown field"
                raise ScenarioError(source, _join(path, key), f"{what} {key!r}; {one_of(key, fields)}")
            check_raw(sub, fields[key], _join(path, key), source)
        return
    if origin is typing.Union:
        args = [a for a in typing.get_args(schema) if a is not type(None)]
        if value is None:
            return
        if len(args) == 1:
            check_raw(value, args[0], path, source)
        return
    if origin in (list, typing.List):
        if not isinstance(value, list):
            raise ScenarioError(source, path, f"expected a list, got {value!r}")
        (item,) = typing.get_args(schema)
        for i, sub in enumerate(value):
            check_raw(sub, item, _join(path, i), source)
        return
    if schema is float:
        if not _is_number(value):
            raise ScenarioError(source, path, f"expected a number, got {value!r}")
    elif schema is bool and not isinstance(value, bool):
        raise ScenarioError(source, path, f"expected true or false, got {value!r}")
    elif schema is int and (not isinstance(value, int) or isinstance(value, bool)):
        raise ScenarioError(source, path, f"expected an integer, got {value!r}")
    elif schema is str and not isinstance(value, str):
        raise ScenarioError(source, path, f"expected a string, got {value!r}")


def parse_override(text: str):
    """'a.b[2].c=value' -> (['a', 'b', 2, 'c'], parsed YAML value). ValueError if malformed."""
    if "=" not in text:
        raise ValueError(f"override {text!r} is not of the form key=value")
    key, raw = text.split("=", 1)
    if len(text) > MAX_OVERRIDE_CHARS:
        raise ValueError(f"override of {len(text)} characters; expected at most {MAX_OVERRIDE_CHARS}")
    parts: list = []
    for piece in key.strip().split("."):
        name, *indices = piece.replace("]", "").split("[")
        if not name:
            raise ValueError(f"override key {key!r} has an empty part")
        parts.append(name)
        parts.extend(int(i) for i in indices)
    return parts, yaml.load(raw, Loader=SceneLoader)


def apply_override(data: dict, parts: list, value, source) -> None:
    node = data
    field = ""
    for depth, part in enumerate(parts):
        field = _join(field, part)
        if isinstance(node, _Tagged) and isinstance(node.value, dict):  # a tagged mapping: !Rpy {deg: [...]}
            node = node.value
        if isinstance(part, int):
            if not isinstance(node, list) or not -len(node) <= part < len(node):
                size = f"{len(node)} entries" if isinstance(node, list) else "not a list"
                raise ScenarioError(source, field, f"--set: list index out of range ({size})")
        elif not isinstance(node, dict):
            raise ScenarioError(source, field, "--set: the parent is not a mapping")
        if depth == len(parts) - 1:
            if value is None and len(parts) == 2 and parts[0] == "effects":
                node.pop(part, None)  # --set effects.<name>=null removes a declared effect
            else:
                node[part] = value
        else:
            if part == "rotation" and parts[depth + 1] == "deg":  # a rotation set by its roll-pitch-yaw angles
                now = node.get(part)
                if now is None or now == {}:  # none, or the identity: roll-pitch-yaw from zero
                    node[part] = _Tagged("!Rpy", {"deg": [0.0, 0.0, 0.0]})
                elif not (isinstance(now, _Tagged) and now.tag == "!Rpy"):
                    raise ScenarioError(source, _join(field, "deg"), "--set: the rotation is not given as !Rpy {deg: [...]}; "
                                        "set the whole rotation instead")
            elif isinstance(part, str) and node.get(part) is None:
                node[part] = {}
            node = node[part]


def parse_yaml(text: str, source) -> dict:
    try:
        data = yaml.load(text, Loader=SceneLoader)
    except yaml.YAMLError as e:
        raise ScenarioError(source, "", yaml_problem(e)) from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ScenarioError(source, "", f"expected a mapping of scene fields at the top level, got {type(data).__name__}")
    return data
