"""What the MLP-based predictors share: input checks, the compiled/numpy dispatch,
`depth`, `in_domain` and saving with the recorded `kind` (the loader's key).

A subclass sets `kind` and implements `_predict_numpy` (the reference); the compiled path is
the native core (learned_contact.compiled: one C call per predict or depth, on a Model of
the predictor's networks packed once, at construction; a subclass with more than the main
network overrides `_native_model`). Where the native core was not built, a predictor asked
for the compiled path answers on the numpy path and says so once per process on stderr.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import ClassVar

import numpy as np

from learned_contact.compiled import (
    NATIVE_AVAILABLE,
    native_answer,
    native_depth,
    native_depth_of,
    native_model,
    native_predict,
    say_not_built,
)
from learned_contact.interface import DOMAIN_DEPTH, check_numpy, check_outside, check_poses, check_size_shape, domain_error, raise_for_status
from learned_contact.model.mlp import NumpyMLP
from testbed.geometry.boxes import sat_normal

FORMAT_VERSION = 1
# version 2: an improved predictor's file that carries a resting expert (expert/...); a
# reader of version 1 would ignore those arrays and answer without the expert
EXPERT_FORMAT_VERSION = 2
# version 3: the expert's gate bounds its offsets per axis as fractions of the edge of
# support (learned_contact.model.expert.DOMAIN_FIELDS, 11 values; version 2: DOMAIN_FIELDS_V2, 9);
# a reader of version 2 would read them as metres
SUPPORT_FORMAT_VERSION = 3
EXPERT_FORMAT_VERSIONS = (EXPERT_FORMAT_VERSION, SUPPORT_FORMAT_VERSION)  # the versions that carry an expert
FORMAT_VERSIONS = (FORMAT_VERSION, EXPERT_FORMAT_VERSION, SUPPORT_FORMAT_VERSION)


@dataclasses.dataclass(frozen=True)
class MLPPredictor:
    """mlp: the network; supported_sizes (k, 3): full extents [m] it answers; meta:
    training config and provenance (JSON-able dict); compiled: run the native core
    (True; False where it was not built) or the numpy reference (False)."""

    kind: ClassVar[str] = ""
    mlp: NumpyMLP
    supported_sizes: np.ndarray
    meta: dict
    compiled: bool = False
    size_range: np.ndarray | None = None  # (2, 3) lowest, highest full extents [m]: any box inside answers too

    def __post_init__(self):
        sizes = np.ascontiguousarray(self.supported_sizes, dtype=float).reshape(-1, 3)
        object.__setattr__(self, "supported_sizes", sizes)
        if self.size_range is not None:
            object.__setattr__(self, "size_range", np.ascontiguousarray(self.size_range, dtype=float).reshape(2, 3))
        if self.compiled:
            if NATIVE_AVAILABLE:
                object.__setattr__(self, "_native", self._native_model())
            else:
                say_not_built()
                object.__setattr__(self, "compiled", False)

    @property
    def native_model(self):
        """The learned_contact._native.Model this predictor answers with (the native core's
        cc_model over its networks), or None on the numpy path: what the learned contact step
        hands to the core so that the predictor runs inside it (cc_contact_step)."""
        return getattr(self, "_native", None) if self.compiled else None

    def __reduce__(self):
        """Copies and pickles rebuild the predictor from its fields (the native Model it holds
        is rebuilt, not copied)."""
        return _rebuild, (type(self), {f.name: getattr(self, f.name) for f in dataclasses.fields(self)})

    def with_compiled(self, compiled: bool):
        """The same predictor on the other inference path."""
        return dataclasses.replace(self, compiled=compiled)

    # ------------------------------------------------------------------ interface
    def predict(self, p_AB, R_AB, *, size_A, size_B, outside: str = "clip"):
        """Contact point and normal for B at (p_AB, R_AB) in A's frame.

        p_AB (n, 3) or (3,): B's centre in A [m]; R_AB (n, 3, 3) or (3, 3): B's
        orientation in A; size_A, size_B (3,) or (n, 3): full box extents [m], each
        one of `supported_sizes` or inside `size_range`. Returns (point_A (n, 3) [m] in A's frame, normal_A
        (n, 3) unit, A towards B); (3,) each for a single pose. Raises
        PredictorInputError for bad shapes, non-finite values or unsupported sizes.

        Poses outside the trained range (separating-axis depth outside DOMAIN_DEPTH)
        are answered within a documented bound when outside="clip" (the default): the
        point is clamped into A's box grown by CLIP_MARGIN and the normal is a unit
        vector. outside="raise" refuses them with PredictorDomainError instead.
        """
        if self.compiled and (outside == "clip" or outside == "raise"):
            # the fast path: numpy inputs of the interface's shapes go straight to the core
            answer = native_answer(self._native, p_AB, R_AB, size_A, size_B, outside == "raise")
            if answer is not None and answer[0] == 0:
                _, _, point, normal, depth, n_outside = answer
                if n_outside:
                    raise domain_error(depth)
                return point, normal
        check_outside(outside)
        if not self.compiled:
            p, R, sA, sB, single = check_numpy(p_AB, R_AB, size_A, size_B, self.supported_sizes, self.size_range)
            point, normal, depth = self._predict_numpy(p, R, sA, sB, outside == "raise")
        else:
            p, R, single = check_poses(p_AB, R_AB)
            sA, sB = check_size_shape("size_A", size_A, len(p)), check_size_shape("size_B", size_B, len(p))
            point, normal, depth, status, row = native_predict(self._native, p, R, sA, sB, outside == "raise")
            if status:
                self._refuse(status, row, p_AB, R_AB, size_A, size_B)
        if outside == "raise" and np.any((depth < DOMAIN_DEPTH[0]) | (depth > DOMAIN_DEPTH[1])):
            raise domain_error(depth)
        return (point[0], normal[0]) if single else (point, normal)

    def depth(self, p_AB, R_AB, *, size_A, size_B):
        """(n,) separating-axis penetration depth [m] (negative = separated by that
        much); a float for a single pose. The closed-loop force law's depth."""
        if self.compiled:
            answer = native_depth_of(self._native, p_AB, R_AB, size_A, size_B)
            if answer is not None and answer[0] == 0:
                return answer[2]
            p, R, single = check_poses(p_AB, R_AB)
            sA, sB = check_size_shape("size_A", size_A, len(p)), check_size_shape("size_B", size_B, len(p))
            depth, status, row = native_depth(self._native, p, R, sA, sB)
            if status:
                self._refuse(status, row, p_AB, R_AB, size_A, size_B)
        else:
            p, R, sA, sB, single = check_numpy(p_AB, R_AB, size_A, size_B, self.supported_sizes, self.size_range)
            depth = sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1]
        return float(depth[0]) if single else depth

    def in_domain(self, p_AB, R_AB, *, size_A, size_B):
        """(n,) bool (a bool for a single pose): whether each pose lies in the range
        answered as trained (DOMAIN_DEPTH)."""
        d = np.asarray(self.depth(p_AB, R_AB, size_A=size_A, size_B=size_B))
        ok = (d >= DOMAIN_DEPTH[0]) & (d <= DOMAIN_DEPTH[1])
        return bool(ok) if ok.ndim == 0 else ok

    def save(self, path) -> Path:
        """Writes the predictor to an .npz file: format_version, kind, supported_sizes,
        size_range (where it has one), meta (JSON), the network under mlp/ and a subclass's extra arrays
        (learned_contact.predictors.loading reads it)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        version, extra = self._extra_arrays()
        ranged = {} if self.size_range is None else {"size_range": self.size_range}
        np.savez(path, format_version=np.array(version), kind=np.array(self.kind),
                 supported_sizes=self.supported_sizes, meta=np.array(json.dumps(self.meta)),
                 **ranged, **self.mlp.to_arrays("mlp/"), **extra)
        return path

    # ------------------------------------------------------------- for subclasses
    def _extra_arrays(self) -> tuple[int, dict]:
        """(format_version, arrays beyond the main network) that save() writes."""
        return FORMAT_VERSION, {}

    def _predict_numpy(self, p, R, sA, sB, with_depth: bool):
        """(point (n, 3), normal (n, 3), depth (n,)) on checked (n, ...) arrays."""
        raise NotImplementedError

    def _native_model(self):
        """The native core's Model of this predictor (learned_contact.compiled.native_model)."""
        return native_model(self.kind, self.supported_sizes, self.mlp, size_range=self.size_range)

    def _refuse(self, status: int, row: int, p_AB, R_AB, size_A, size_B):
        """Raises the numpy path's error for the native core's status (1-6): the reference
        checks run on the same inputs and raise it (same class, same message); should they
        pass, the status's error from learned_contact.interface.raise_for_status."""
        check_numpy(p_AB, R_AB, size_A, size_B, self.supported_sizes, self.size_range)
        if status not in range(1, 7):
            raise RuntimeError(f"the native core answered status {status} (a bad argument) on checked inputs")
        p, R, _ = check_poses(p_AB, R_AB)
        sA, sB = check_size_shape("size_A", size_A, len(p)), check_size_shape("size_B", size_B, len(p))
        raise_for_status(status, row, p, sA, sB, self.supported_sizes, R, self.size_range)


def _rebuild(cls, fields: dict):
    """A predictor of class cls from its dataclass fields (MLPPredictor.__reduce__)."""
    return cls(**fields)
