"""Loading the shipped predictors' weights files (.npz): `load_weights`.

    load_weights("improved")           # shipped/weights.npz
    load_weights("paper")              # shipped/paper_weights.npz
    load_weights("my/weights.npz")     # the class named by the file's `kind` field

Every other source of a predictor (ONNX, Python objects) and the one function that takes
them all, `load_predictor`, are in learned_contact.sources.

A weights file is an .npz with: format_version (int, FORMAT_VERSION), kind ("improved"
or "paper"), supported_sizes (k, 3) full extents [m], meta (JSON string) and the network
under mlp/ (x_mean, x_std, activation, W0.., b0..; W_i (in, out)). An improved file may
carry a resting expert (learned_contact.model.expert): a second network of the same widths
under expert/ and its gate's bounds, expert/domain: (11,) learned_contact.model.expert.DOMAIN_FIELDS
(offsets per axis as fractions of the edge of support) in a file of format_version
SUPPORT_FORMAT_VERSION (3), or (9,) DOMAIN_FIELDS_V2 (one offset bound [m]) in a file of
EXPERT_FORMAT_VERSION (2); so no reader of version 1 answers without the expert and no
reader of version 2 reads fractions as metres. Files written before
`kind` existed are recognised by their arrays (the improved file has supported_sizes,
the paper file a 6-input network and no version).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from learned_contact.errors import WeightsError, weights_error
from learned_contact.model.expert import LAYOUTS, check_domain
from learned_contact.model.mlp import ACTIVATIONS, NumpyMLP
from learned_contact.predictors.base import EXPERT_FORMAT_VERSIONS, FORMAT_VERSION, FORMAT_VERSIONS
from learned_contact.predictors.improved import DEFAULT_WEIGHTS, SHIPPED_DIR, ContactPredictor
from learned_contact.predictors.paper import PaperPredictor
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.safe_files import load_npz


@dataclasses.dataclass(frozen=True)
class ShippedKind:
    """One kind of predictor the testbed ships: its name (a weights file's `kind`), its shipped
    weights file, its network's (input, output) widths, and the class a file of it loads into."""

    name: str
    weights: Path
    widths: tuple[int, int]
    predictor: type


# The one table of shipped kinds: every name, file and class below is read from here.
KINDS = {k.name: k for k in (
    ShippedKind("improved", DEFAULT_WEIGHTS, (91, 6), ContactPredictor),
    ShippedKind("paper", SHIPPED_DIR / "paper_weights.npz", (6, 4), PaperPredictor),
)}
SHIPPED = {name: k.weights for name, k in KINDS.items()}  # name -> shipped weights file
LEGACY_PAPER_TYPES = ("1CC", "1AA", "1AAA")  # the shipped paper file's training sizes
# The shipped improved file is ~60 kB; 64 MB (file and unpacked arrays) admits any MLP of this kind and
# refuses a runaway file or a zip bomb.
MAX_WEIGHTS_BYTES = 64 * 2**20


def resolve(name_or_path) -> Path:
    """The weights file of a predictor name ("improved", "paper") or path (None: improved)."""
    if name_or_path is None:
        return SHIPPED["improved"]
    if isinstance(name_or_path, str) and name_or_path in SHIPPED:
        return SHIPPED[name_or_path]
    return Path(name_or_path)


def _fail(path, field, problem, expected) -> WeightsError:
    return WeightsError(f"weights file {path}: field {field!r} {problem}; expected {expected}")


def read_arrays(path: Path) -> dict:
    if not path.exists():
        raise WeightsError(f"weights file {path} not found; give 'improved', 'paper' or the path of an .npz "
                           "(train one with learned_contact.training.train_default)")
    return load_npz(path, MAX_WEIGHTS_BYTES, MAX_WEIGHTS_BYTES, "weights .npz written by a predictor's save()",
                    weights_error)


def infer_kind(arrays: dict, path) -> str:
    """The recorded kind, or for files from before `kind` existed, the one their arrays show."""
    if "kind" in arrays:
        kind = str(arrays["kind"])
        if kind not in KINDS:
            raise _fail(path, "kind", f"is {kind!r}", f"one of {sorted(KINDS)}")
        return kind
    if "mlp/W0" not in arrays:
        raise _fail(path, "kind", "is missing and there is no network (mlp/W0)", "a predictor weights file")
    if "supported_sizes" in arrays:
        return "improved"
    if arrays["mlp/W0"].shape[0] == KINDS["paper"].widths[0]:
        return "paper"
    raise _fail(path, "kind", "is missing and cannot be inferred", f"one of {sorted(KINDS)}")


def _mlp(arrays: dict, path, kind: str, prefix: str = "mlp/") -> NumpyMLP:
    n = sum(1 for k in arrays if k.startswith(f"{prefix}W"))
    for field in [f"{prefix}x_mean", f"{prefix}x_std", f"{prefix}activation"] + [
            f"{prefix}{p}{i}" for i in range(n) for p in "Wb"]:
        if field not in arrays:
            raise _fail(path, field, "is missing", f"a {kind} network with {n} layers")
    activation = str(arrays[f"{prefix}activation"])
    if activation not in ACTIVATIONS:
        raise _fail(path, f"{prefix}activation", f"is {activation!r}", f"one of {sorted(ACTIVATIONS)}")
    width = KINDS[kind].widths[0]
    for i in range(n):
        W, b = arrays[f"{prefix}W{i}"], arrays[f"{prefix}b{i}"]
        if W.ndim != 2 or W.shape[0] != width or b.shape != (W.shape[1],):
            raise _fail(path, f"{prefix}W{i}", f"has shape {W.shape} (bias {b.shape})",
                        f"({width}, m) with bias (m,)")
        width = W.shape[1]
    if width != KINDS[kind].widths[1]:
        raise _fail(path, f"{prefix}W{n - 1}", f"has {width} outputs", f"{KINDS[kind].widths[1]} for kind {kind!r}")
    for field in (f"{prefix}x_mean", f"{prefix}x_std"):
        if arrays[field].shape != (KINDS[kind].widths[0],):
            raise _fail(path, field, f"has shape {arrays[field].shape}", f"({KINDS[kind].widths[0]},)")
    mlp = NumpyMLP.from_arrays(arrays, prefix)
    if not all(np.all(np.isfinite(a)) for a in (*mlp.weights, *mlp.biases, mlp.x_mean, mlp.x_std)):
        raise _fail(path, f"{prefix}*", "holds NaN or inf", "finite weights")
    return mlp


def _expert(arrays: dict, path, kind: str, version: int) -> dict:
    """{"expert": NumpyMLP, "expert_domain": (11,) or (9,)} of a file carrying a resting expert
    (format_version 3 or 2: the layout of expert/domain, learned_contact.model.expert.LAYOUTS), else {}."""
    has = any(k.startswith("expert/") for k in arrays)
    versions = " or ".join(map(str, EXPERT_FORMAT_VERSIONS))
    if not has:
        if version in EXPERT_FORMAT_VERSIONS:
            raise _fail(path, "expert/W0", f"is missing (format_version {version} carries a resting expert)",
                        f"expert/ arrays, or format_version {FORMAT_VERSION}")
        return {}
    if kind != "improved":
        raise _fail(path, "expert/*", f"is present in a {kind!r} file", "a resting expert only in an improved file")
    if version not in EXPERT_FORMAT_VERSIONS:
        raise _fail(path, "format_version", f"is {version} but the file carries a resting expert (expert/)", versions)
    n = len(LAYOUTS[version])
    if "expert/domain" not in arrays:
        raise _fail(path, "expert/domain", "is missing", f"({n},) the expert gate's bounds (learned_contact.model.expert)")
    problem = check_domain(arrays["expert/domain"], version)
    if problem:
        raise _fail(path, "expert/domain", problem,
                    f"the expert gate's bounds of format_version {version} (learned_contact.model.expert.LAYOUTS)")
    return {"expert": _mlp(arrays, path, kind, "expert/"),
            "expert_domain": np.asarray(arrays["expert/domain"], dtype=float)}


def load_weights(name_or_path=None, *, compiled: bool = True):
    """The predictor named ("improved", the default, or "paper") or stored in an .npz.

    compiled: run the native core (learned_contact.compiled; built at install) or,
    False, the numpy reference path. Raises WeightsError naming the file, the field and
    what was expected for a missing, unreadable, unknown-kind or wrong-version file.
    """
    path = resolve(name_or_path)
    arrays = read_arrays(path)
    kind = infer_kind(arrays, path)
    legacy_paper = kind == "paper" and "format_version" not in arrays
    version = int(arrays.get("format_version", FORMAT_VERSION if legacy_paper else -1))
    if version not in FORMAT_VERSIONS:
        raise _fail(path, "format_version", f"is {version}", " or ".join(map(str, FORMAT_VERSIONS)))
    mlp = _mlp(arrays, path, kind)
    extra = _expert(arrays, path, kind, version)
    if "supported_sizes" in arrays:
        sizes = np.asarray(arrays["supported_sizes"], dtype=float)
    elif legacy_paper:

        sizes = np.array([CONTAINER_TYPES[t].size for t in LEGACY_PAPER_TYPES], dtype=float)
    else:
        raise _fail(path, "supported_sizes", "is missing", "(k, 3) full extents [m]")
    if sizes.ndim != 2 or sizes.shape[1] != 3 or len(sizes) == 0 or not np.all(np.isfinite(sizes)):
        raise _fail(path, "supported_sizes", f"has shape {sizes.shape}", "(k, 3) finite full extents [m]")
    size_range = None
    if "size_range" in arrays:
        size_range = np.asarray(arrays["size_range"], dtype=float)
        if size_range.shape != (2, 3) or not np.all(np.isfinite(size_range)) or not np.all(
                (size_range[0] > 0) & (size_range[0] <= size_range[1])):
            raise _fail(path, "size_range", f"is {size_range.tolist()}",
                        "(2, 3) lowest then highest full extents [m], 0 < lowest <= highest")
    try:
        meta = json.loads(str(arrays["meta"])) if "meta" in arrays else {}
    except json.JSONDecodeError as exc:
        raise _fail(path, "meta", f"is not JSON ({exc})", "a JSON object") from exc
    return KINDS[kind].predictor(mlp=mlp, supported_sizes=sizes, meta=meta, compiled=compiled, size_range=size_range,
                                 **extra)
