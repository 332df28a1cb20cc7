"""The one catalogue of where a predictor can come from, and `load_predictor`.

    load_predictor()                      # "improved": the shipped default
    load_predictor("paper")               # the paper's MLP, shipped
    load_predictor("my/weights.npz")      # a weights file of one of those two kinds
    load_predictor("my_model.onnx")       # any ONNX model with the contract (onnx_model.py)
    load_predictor("my_pkg.models:make")  # any Python object or factory (python_model.py)

Every command option, effect field, gate and study that names a predictor takes these
strings and nothing else lists them: help texts use HELP, labels use `label`. Which source
a string is: a shipped name; else `module:attribute` when it reads so and is not an
existing file; else a path, by suffix (.onnx, else a weights .npz). A bare word that is no
file ('improoved') is refused as a name, with the closest shipped names and the other forms
(unknown_name).
"""

from __future__ import annotations

import dataclasses
import os
import re
from pathlib import Path
from typing import Callable

import numpy as np

from learned_contact.errors import WeightsError
from learned_contact.interface import check_numpy
from learned_contact.predictors import limits
from learned_contact.predictors.loading import SHIPPED, load_weights
from learned_contact.predictors.onnx_model import check_file, load_onnx
from learned_contact.predictors.python_model import is_python_spec, load_python
from testbed.errors import one_of

DEFAULT = "improved"
SHIPPED_NAMES = tuple(SHIPPED)  # ("improved", "paper")


@dataclasses.dataclass(frozen=True)
class Source:
    """One kind of predictor source: its key, how it is written, and how it loads."""

    key: str  # "shipped", "weights", "onnx", "python"
    written: str  # how a user writes it
    load: Callable  # (spec: str, compiled: bool) -> Predictor


SOURCES = (
    Source("shipped", " | ".join(SHIPPED_NAMES), lambda spec, compiled: load_weights(spec, compiled=compiled)),
    Source("python", "module:attribute", lambda spec, compiled: load_python(spec)),
    Source("onnx", "PATH.onnx", lambda spec, compiled: load_onnx(spec)),
    Source("weights", "PATH.npz", lambda spec, compiled: load_weights(spec, compiled=compiled)),
)
BY_KEY = {s.key: s for s in SOURCES}
HELP = ("improved (shipped default), paper, a weights file (.npz), an ONNX model (.onnx, the contract in "
        "docs/bench.md) or module:attribute (a Python factory)")


def source_of(spec) -> Source:
    """The Source a predictor string names (see the module docstring)."""
    if spec is None or spec in SHIPPED_NAMES:
        return BY_KEY["shipped"]
    spec = str(spec)
    if is_python_spec(spec) and not Path(spec).exists():
        return BY_KEY["python"]
    if spec.lower().endswith(".onnx"):
        return BY_KEY["onnx"]
    return BY_KEY["weights"]


OTHER_FORMS = "or a file (PATH.npz: weights, PATH.onnx: an ONNX model) or module:attribute (a Python factory)"


def looks_like_a_name(spec: str) -> bool:
    """Whether `spec`, read as a weights path, is rather a mistyped name: no such file, no
    folder in it and no file suffix ('improoved', not 'my/weights.npz')."""
    path = Path(spec)
    return not path.exists() and not path.suffix and len(path.parts) == 1 and "/" not in spec and "\\" not in spec


def unknown_name(spec: str) -> str:
    """One line for a predictor string that names nothing: "'improoved' is not a predictor:
    did you mean 'improved'? expected one of: improved, paper; or a file (...) or module:attribute"."""
    return f"{spec!r} is not a predictor: {one_of(spec, SHIPPED_NAMES)}; {OTHER_FORMS}"


def label(spec) -> str:
    """A short, file-name-safe name for tables and directories: the shipped name, the
    file's stem, or the Python attribute."""
    if spec is None:
        return DEFAULT
    spec = str(spec)
    key = source_of(spec).key
    if key == "shipped":
        return spec
    name = spec.rpartition(":")[2].replace(".", "_") if key == "python" else Path(spec).stem
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", name) or "model"


UNTRUSTED = ("onnx", "python")  # sources whose code is not the testbed's: vetted in a child (limits.py)
_loaded: dict = {}  # (spec, compiled, file identity, limits) -> predictor: each model loaded once per process


def _identity(spec: str, key: str):
    """What makes a loaded model current: the file's (device, inode, size, mtime) for files."""
    if key == "python":
        return None
    try:
        st = os.stat(SHIPPED[spec] if key == "shipped" else spec)
    except OSError:
        return "missing"
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


def load_unvetted(spec: str, compiled: bool = True):
    """The predictor `spec` names, loaded in this process without the child-process vetting
    (learned_contact.vet's own call; everything else uses load_predictor)."""
    return source_of(spec).load(spec, compiled)


def load_predictor(spec=None, *, compiled: bool = True):
    """The predictor `spec` names (None: "improved"); see the module docstring.

    compiled: for the shipped kinds, run the native core (True) or the numpy reference
    (False); other sources run as they are. An ONNX or Python model is first loaded and
    probed in a child process under learned_contact.predictors.limits' bounds (time, memory, nodes), and
    runs here under its per-call bound. A shipped kind is loaded and warmed (`warmed`) as the
    testbed's own work, never counted against such a bound. A model is loaded once per process:
    the same spec (and the same file, unchanged) returns the same object. Raises WeightsError naming the file (or
    module:attribute), the field or bound and what was expected.
    """
    if spec is not None and not isinstance(spec, (str, Path)):
        raise WeightsError(f"predictor {spec!r}: expected a string, {HELP}")
    if spec is not None and str(spec).strip() == "":
        raise WeightsError(f"predictor '': expected {HELP}")
    source = source_of(spec)
    spec = DEFAULT if spec is None else str(spec)
    if source.key == "weights" and looks_like_a_name(spec):
        raise WeightsError(unknown_name(spec))
    key = (spec, compiled, _identity(spec, source.key), limits.limits())
    if key not in _loaded:
        if source.key in UNTRUSTED:
            if source.key == "onnx":  # refusals that need no child (file kind, size, nodes, external data)
                check_file(spec)
            limits.vet_in_child(spec)
            _loaded[key] = source.load(spec, compiled)
        else:
            with limits.project_work():  # the testbed's own: never counted against a user's model's bound
                _loaded[key] = warmed(source.load(spec, compiled))
    return _loaded[key]


def warmed(predictor):
    """`predictor` (a shipped kind) after answering and giving the depth of two resting poses of its
    first supported size: as one batch, as a strided view (reversed, as the load-time probe asks)
    and one at a time, each as given and as the checks of a user's model hand them on
    (learned_contact.interface.check_numpy: read-only size arrays). Whatever its first calls load
    (the native model's packing; nothing compiles since the native core) is done here, at load, where
    load_predictor runs it as the testbed's own work (limits.project_work), not inside the first
    calls of a user's model that wraps it (testbed.validation.sensitivity). A failure is left to
    the first real call, which reports it with its context."""
    try:
        size = np.asarray(predictor.supported_sizes, dtype=float).reshape(-1, 3)[0]
        p = np.array([[0.0, 0.0, size[2] - 0.005], [0.3, -0.2, size[2] - 0.004]])  # [m] B resting on A
        R, sizes = np.repeat(np.eye(3)[None], 2, axis=0), np.tile(size, (2, 1))
        back = slice(None, None, -1)
        for given in ((p, R, sizes, sizes), (p[back], R[back], sizes[back], sizes[back]), (p[0], R[0], size, size)):
            checked = check_numpy(given[0], given[1], given[2], given[3], predictor.supported_sizes)[:4]
            for args in (given, checked):
                predictor.predict(args[0], args[1], size_A=args[2], size_B=args[3])
                predictor.depth(args[0], args[1], size_A=args[2], size_B=args[3])
    except Exception:  # noqa: BLE001 - see the docstring
        pass
    return predictor
