"""One bench model: a predictor string resolved once, and what it declares.

`resolve(spec)` loads the predictor (learned_contact.sources.load_predictor: a bad file fails
here, WeightsError) and returns a BenchModel that every section of the bench takes: its spec
(the string, for what must name it: a scene's effect config, a fresh process's first call),
its label (an ONNX model's metadata `name`, else the spec's short name: label_of), kind and name, the loaded predictor and the container sizes it declares
(`supported_sizes`, (k, 3) full extents [m]) with the shipped container types they are.
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import re

import numpy as np

from learned_contact.data.sampling import DEFAULT_TYPES, types_of_sizes
from learned_contact.interface import SIZE_TOLERANCE
from learned_contact.sources import label, load_predictor
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.scenario import load_scenario


@dataclasses.dataclass(frozen=True, eq=False)
class BenchModel:
    """A predictor as the bench judges it.

    spec: the learned_contact.sources string; label: its short name; kind, name: the predictor's;
    predictor: the loaded object (predict(p_AB, R_AB, *, size_A, size_B) -> (point_A, normal_A));
    declared_sizes: (k, 3) [m] its supported_sizes; types: the shipped container types
    (learned_contact.data.sampling.DEFAULT_TYPES) among them, in that order: the accuracy sets
    are drawn over their ordered pairs."""

    spec: str
    label: str
    kind: str
    name: str
    predictor: object
    declared_sizes: np.ndarray
    types: tuple[str, ...]

    @property
    def every_size(self) -> bool:
        """True when the model declares every shipped container type (the sets and scenes are the gates')."""
        return self.types == tuple(DEFAULT_TYPES)

    def uncovered(self, scene: str) -> str | None:
        """None, or why `scene` is not judged (its first container of a size the model does not declare)."""
        return uncovered(self.declared_sizes, scene)

    def sizes_text(self) -> str:
        """'1AA (12.192 x 2.438 x 2.591 m)', the declared sizes by type (a size of no shipped type as is)."""
        out = []
        for size in self.declared_sizes:
            code = next((t for t, c in CONTAINER_TYPES.items()
                         if np.abs(np.asarray(c.size) - size).max() <= SIZE_TOLERANCE), None)
            dims = " x ".join(f"{v:g}" for v in size)
            out.append(f"{code} ({dims} m)" if code else f"{dims} m (no shipped type)")
        return ", ".join(out)


def resolve(model) -> BenchModel:
    """The BenchModel of a predictor string (loaded once per process: load_predictor), or `model`
    itself when it is one already."""
    if isinstance(model, BenchModel):
        return model
    spec = str(model)
    predictor = load_predictor(spec)
    sizes = np.asarray(predictor.supported_sizes, dtype=float).reshape(-1, 3)
    kind, name = getattr(predictor, "kind", "?"), getattr(predictor, "name", label(spec))
    return BenchModel(spec=spec, label=label_of(spec, kind, name), kind=kind, name=name, predictor=predictor,
                      declared_sizes=sizes, types=types_of_sizes(sizes))


def label_of(spec: str, kind: str, name: str | None) -> str:
    """The model's label on the bench: an ONNX model's metadata `name` (docs/bench.md's contract;
    the loader falls back to the file's stem without one), made file-name safe; any other source's
    learned_contact.sources.label (the shipped name, the Python attribute, the weights file's stem)."""
    if kind == "onnx" and name:
        return re.sub(r"[^A-Za-z0-9_.+-]", "_", str(name)).strip("._") or label(spec)
    return label(spec)


def distinct_labels(models: list) -> list:
    """The BenchModels with distinct labels: models whose metadata names collide are labelled by
    their file's stem instead (learned_contact.sources.label); a collision left after that is the
    caller's to refuse."""
    counts = collections.Counter(m.label for m in models)
    return [dataclasses.replace(m, label=label(m.spec)) if counts[m.label] > 1 else m for m in models]


@functools.lru_cache(maxsize=None)
def scene_containers(scene: str) -> tuple[tuple[str, str, tuple[float, float, float]], ...]:
    """((name, type, size (3,) [m]), ...) of a scene's containers, from its Scenario."""
    return tuple((c.name, c.type, tuple(float(v) for v in c.container_type().size))
                 for c in load_scenario(scene).containers)


def uncovered(sizes, scene: str) -> str | None:
    """None, or "SCENE: container 'NAME' (type T, size (x, y, z) m) is not a size the model
    declares" for the first container of `scene` whose size is not among `sizes` ((k, 3) [m],
    within learned_contact.interface.SIZE_TOLERANCE per axis)."""
    supported = np.asarray(sizes, dtype=float).reshape(-1, 3)
    for name, type_name, size in scene_containers(scene):
        if not len(supported) or np.abs(supported - np.asarray(size)).max(axis=1).min() > SIZE_TOLERANCE:
            return (f"{scene}: container '{name}' (type {type_name}, size {tuple(round(v, 3) for v in size)} m) "
                    "is not a size the model declares")
    return None
