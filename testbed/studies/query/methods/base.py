"""The `ContactMethod` interface: one way of answering a contact query for a pose set.

A method family (one module in this package) turns a PoseSet into ContactMethods with
`build(poses, scenes, options)`. A method whose optional package or weights file is
missing comes back with available=False and the reason: it is listed, not fatal.
"""

from __future__ import annotations

import dataclasses
from typing import Callable, Optional

INSTALL = "pip install -e '.[study]'"
PINS = {"python-fcl": "0.7.0.11", "mujoco": "4.0.0", "matplotlib": "3.11.2", "threadpoolctl": "3.8.0"}


@dataclasses.dataclass
class ContactMethod:
    """One way of answering a contact query, bound to the poses of one set.

    single(i) -> (point (3,) [m], normal (3,) unit A->B, count) for pose i of the set
    (A's frame), count being an int reported per pose (Drake surface faces or point
    pairs, colliding triangle pairs, MuJoCo contacts) or None; or batched() ->
    (points (n, 3), normals (n, 3)) for the whole set; prepare_kernel(i): poses the
    scene for pose i and returns the zero-argument library call to time alone (None:
    no kernel time); candidates(i) -> int: the leaf tests an ideal bounding-volume tree
    must make for pose i (polygon soup only). available False (with reason) when a
    package or weights file is missing.
    """

    name: str
    label: str
    family: str
    available: bool = True
    reason: str = ""
    single: Optional[Callable] = None
    batched: Optional[Callable] = None
    prepare_kernel: Optional[Callable] = None
    candidates: Optional[Callable] = None
    extra: dict = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class MethodOptions:
    """What the families need besides the poses.

    soup_ns: polygon-soup resolutions N (divisions per box edge) to run;
    predictor, paper_weights: weights files of the improved predictor and the paper MLP
    (None: the shipped ones); extra_predictors: more predictors (learned_contact.sources
    strings: ONNX models, Python objects, weights files), each a pair of methods."""

    soup_ns: tuple = ()
    predictor: object = None
    paper_weights: object = None
    extra_predictors: tuple = ()


class Scenes:
    """Lazily built per-type-pair scenes (Drake plants, FCL meshes, MuJoCo models),
    shared by all pose sets of a study: get(key, make) builds once per key."""

    def __init__(self):
        self._cache = {}

    def get(self, key: tuple, make: Callable):
        if key not in self._cache:
            self._cache[key] = make()
        return self._cache[key]


def missing(module: str, package: str) -> str:
    """'' when `module` imports, else the reason naming the install command."""
    try:
        __import__(module)
    except ImportError:
        return f"{package} not installed ({INSTALL})"
    return ""
