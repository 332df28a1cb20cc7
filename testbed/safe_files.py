"""Bounded, checked reading of the files the testbed is handed: the checks that come before
any parser (scenes and calibration parameter files, `--set` values, toss data, `--resume`
records).

- `read_bounded`: the path must be a regular file (a device such as /dev/zero, a FIFO, a
  socket or a directory is refused from `os.stat`, before it is opened) of at most `limit`
  bytes; it is read once, at most limit + 1 bytes, so a file that grows meanwhile is refused
  too and memory stays bounded by the limit.
- `check_regular_file`: the same two checks without reading (for readers that must open the
  file themselves, e.g. numpy's .npz reader).
- `BoundedYamlMixin`: mixed into a PyYAML SafeLoader: nesting at most MAX_YAML_DEPTH levels
  (Python's composer recurses once per level, so deeper flow brackets would end in a
  RecursionError), aliases adding at most MAX_YAML_ALIAS_NODES nodes once expanded (an
  anchor referenced ten times per level, nine levels deep, is 10**9 nodes), no alias inside
  the node it names (a structure containing itself never ends once expanded), and no key twice
  in one mapping (PyYAML keeps the last one silently). Violations raise `YamlLimitError`, a
  yaml.YAMLError with the line and column.
- `load_json`: JSON from a bounded file; no key twice in an object; nesting beyond the
  interpreter's recursion limit refused.

Every refusal is `error(path, field, problem)`: a TestbedError subclass taking (path, field,
problem), `InputFileError` unless the caller passes its own (e.g. ScenarioError), so the CLI
prints one line and exits 2. Sizes are in bytes.
"""

from __future__ import annotations

import json
import os
import stat
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import yaml

from testbed.errors import TestbedError

MAX_YAML_DEPTH = 64  # nesting levels; a scene needs about 7 (containers[0].box.contact.<value>)
MAX_YAML_ALIAS_NODES = 10_000  # nodes that alias references may add once expanded (per document)
MiB = 1 << 20


class InputFileError(TestbedError, ValueError):
    """An input file refused before parsing: names the file, the field (or '') and what was expected."""

    def __init__(self, path: object, field: str, problem: str):
        self.path, self.field, self.problem = str(path), field, problem
        where = f"{self.path}: {field}" if field else self.path
        super().__init__(f"{where}: {problem}".replace("\r", "\\r").replace("\n", "\\n"))


def _size_text(n: int) -> str:
    return f"{n / MiB:.3g} MiB" if n >= MiB else f"{n / 1024:.3g} KiB" if n >= 1024 else f"{n} bytes"


def check_regular_file(path: str | Path, limit: int, what: str, error=InputFileError) -> int:
    """Refuses anything but an existing regular file of at most `limit` bytes; returns its size."""
    try:
        st = os.stat(path)
    except OSError as e:
        raise error(path, "", f"cannot read the {what} ({e.strerror}); expected a regular file") from None
    if stat.S_ISDIR(st.st_mode):
        raise error(path, "", f"is a directory; expected a {what} (a regular file)")
    if not stat.S_ISREG(st.st_mode):
        kind = ("a FIFO (named pipe)" if stat.S_ISFIFO(st.st_mode) else "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)
                else "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
        raise error(path, "", f"is {kind}; expected a {what} (a regular file)")
    if st.st_size > limit:
        raise error(path, "", f"is {_size_text(st.st_size)}; expected a {what} of at most {_size_text(limit)}")
    return st.st_size


def read_bounded(path: str | Path, limit: int, what: str, error=InputFileError) -> bytes:
    """The bytes of a regular file of at most `limit` bytes (see the module docstring)."""
    check_regular_file(path, limit, what, error)
    try:
        with open(path, "rb") as f:
            data = f.read(limit + 1)
    except OSError as e:
        raise error(path, "", f"cannot read the {what} ({e.strerror})") from None
    if len(data) > limit:
        raise error(path, "", f"grew past {_size_text(limit)} while being read; expected a {what} of at most {_size_text(limit)}")
    return data


class YamlLimitError(yaml.MarkedYAMLError):
    """Nesting too deep, aliases expanding too far, or a duplicate key (with its position)."""


if TYPE_CHECKING:  # the mixin's methods call the loader's: checked as its subclass
    from yaml import SafeLoader as _LoaderBase
else:
    _LoaderBase = object


class BoundedYamlMixin(_LoaderBase):
    """Put before yaml.SafeLoader (or a subclass) in the bases: `class L(BoundedYamlMixin, yaml.SafeLoader)`.

    Tracks, per document, the nesting depth and each node's expanded size (nodes, counting
    what aliases stand for); an alias adds its anchor's expanded size to a per-document
    count, which must stay <= max_alias_nodes. Cost: one dict entry per node."""

    max_depth = MAX_YAML_DEPTH
    max_alias_nodes = MAX_YAML_ALIAS_NODES

    def compose_document(self):
        self._weights: dict = {}  # id(node) -> expanded size
        self._depth, self._alias_nodes, self._open_anchors = 0, 0, []
        try:
            return super().compose_document()
        finally:
            self._weights = {}

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            target = self.anchors.get(event.anchor)
            if event.anchor in self._open_anchors:  # a node containing itself: endless once expanded
                raise YamlLimitError(None, None, f"the alias *{event.anchor} refers to a node that contains it; "
                                     "expected no self-reference", event.start_mark)
            if target is not None:
                self._alias_nodes += self._weights.get(id(target), 1)
                if self._alias_nodes > self.max_alias_nodes:
                    raise YamlLimitError(None, None, f"aliases expand to more than {self.max_alias_nodes} nodes "
                                         f"(*{event.anchor}); expected aliases that stand for at most that many",
                                         event.start_mark)
            return super().compose_node(parent, index)
        self._depth += 1
        if self._depth > self.max_depth:
            mark = self.peek_event().start_mark
            raise YamlLimitError(None, None, f"nested deeper than {self.max_depth} levels; expected at most {self.max_depth}", mark)
        anchor = getattr(self.peek_event(), "anchor", None)
        if anchor is not None:
            self._open_anchors.append(anchor)
        try:
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
            if anchor is not None:
                self._open_anchors.pop()
        if isinstance(node, yaml.SequenceNode):
            weight = 1 + sum(self._weights.get(id(n), 1) for n in node.value)
        elif isinstance(node, yaml.MappingNode):
            weight = 1 + sum(self._weights.get(id(k), 1) + self._weights.get(id(v), 1) for k, v in node.value)
        else:
            weight = 1
        self._weights[id(node)] = weight
        return node

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = set()
            for key_node, _ in node.value:
                if not isinstance(key_node, yaml.ScalarNode) or key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = (key_node.tag, key_node.value)
                if key in seen:
                    raise YamlLimitError("while reading a mapping", node.start_mark,
                                         f"found the key {key_node.value!r} twice; expected each key once", key_node.start_mark)
                seen.add(key)
        return super().construct_mapping(node, deep=deep)


class SafeYamlLoader(BoundedYamlMixin, yaml.SafeLoader):
    """yaml.SafeLoader with the bounds above."""


def yaml_problem(e: yaml.YAMLError) -> str:
    """One line for a PyYAML error: 'malformed YAML at line L, column C: problem (context)',
    or 'refused YAML at ...' for a YamlLimitError."""
    mark = getattr(e, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
    problem = " ".join(str(getattr(e, "problem", None) or e).split())
    context = getattr(e, "context", None)
    kind = "refused YAML" if isinstance(e, YamlLimitError) else "malformed YAML"
    return f"{kind}{where}: {problem}" + (f" ({context})" if context else "")


def load_yaml_text(text: str, source: object, loader=SafeYamlLoader, error=InputFileError):
    """PyYAML `load` with `loader` (a BoundedYamlMixin loader); any YAML error -> error(source, '', one line)."""
    try:
        return yaml.load(text, Loader=loader)
    except yaml.YAMLError as e:
        raise error(source, "", yaml_problem(e)) from None
    except RecursionError:  # a loader without the mixin, or a constructor recursing on its own
        raise error(source, "", f"refused YAML: nested too deeply; expected at most {MAX_YAML_DEPTH} levels") from None


def load_json(path: str | Path, limit: int, what: str, error=InputFileError):
    """JSON from a regular file of at most `limit` bytes, UTF-8, no key twice in an object;
    anything else -> error(path, '', one line)."""
    raw = read_bounded(path, limit, what, error)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise error(path, "", f"is not UTF-8 text (byte 0x{raw[e.start]:02x} at offset {e.start}); expected a {what} in JSON") from None

    def pairs(items):
        out = {}
        for k, v in items:
            if k in out:
                raise ValueError(f"found the key {k!r} twice in one object; expected each key once")
            out[k] = v
        return out

    try:
        return json.loads(text, object_pairs_hook=pairs)
    except json.JSONDecodeError as e:
        raise error(path, "", f"not valid JSON (line {e.lineno}, column {e.colno}: {e.msg}); expected a {what}") from None
    except ValueError as e:
        raise error(path, "", f"refused JSON: {e}") from None
    except RecursionError:  # the C decoder stops at the interpreter's recursion limit (~1000 levels)
        raise error(path, "", f"refused JSON: nested too deeply; expected a {what}") from None


def load_npz(path: str | Path, limit: int, unpacked_limit: int, what: str, error=InputFileError) -> dict:
    """{name: array} of a .npz that is a regular file of at most `limit` bytes whose arrays
    unpack to at most `unpacked_limit` bytes (summed from the zip directory before any array
    is read, so a zip bomb costs nothing); pickled objects are refused (allow_pickle=False)."""
    check_regular_file(path, limit, what, error)
    try:
        with zipfile.ZipFile(path) as z:
            unpacked = sum(info.file_size for info in z.infolist())
            if unpacked <= unpacked_limit:
                for info in z.infolist():
                    _check_npy_header(z, info, path, what, error)
    except (OSError, zipfile.BadZipFile, EOFError) as e:
        raise error(path, "", f"not a readable .npz file ({e}); expected a {what}") from None
    if unpacked > unpacked_limit:
        raise error(path, "", f"its arrays unpack to {_size_text(unpacked)}; expected at most {_size_text(unpacked_limit)}")
    try:
        with np.load(path, allow_pickle=False) as f:
            return {k: f[k] for k in f.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError, MemoryError) as e:
        raise error(path, "", f"not a readable .npz file ({type(e).__name__}: {str(e)[:200]}); expected a {what}") from None


def _check_npy_header(z: zipfile.ZipFile, info: zipfile.ZipInfo, path, what: str, error) -> None:
    """Refuses a member whose .npy header claims more data than the member holds (numpy would
    allocate what the header claims before reading: a 10^7 x 10^7 header is 800 TB)."""
    if not info.filename.endswith(".npy"):
        return
    field = info.filename[:-4]
    try:
        with z.open(info) as f:
            version = np.lib.format.read_magic(f)
            reader = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            shape, _, dtype = reader(f, max_header_size=10_000)
            start = f.tell()
    except (ValueError, TypeError) as e:
        raise error(path, field, f"has no readable array header ({str(e)[:200]}); expected a {what}") from None
    claimed = int(np.prod(shape, dtype=object)) * max(dtype.itemsize, 1)
    if claimed > info.file_size - start:
        raise error(path, field, f"claims a {shape} array of {_size_text(claimed)} but holds {_size_text(info.file_size - start)}; "
                                 f"expected a {what}")
