"""What the MLP-based predictors share: input checks, the compiled/numpy dispatch,
`depth`, `in_domain` and saving with the recorded `kind` (the loader's key).

A subclass sets `kind` and implements `_predict_numpy` (the reference) and
`_predict_compiled` (a learned_contact.compiled kernel call).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import ClassVar

import numpy as np

from learned_contact.interface import DOMAIN_DEPTH, check_numpy, check_outside, check_poses, check_size_shape, domain_error, raise_for_status
from learned_contact.model.mlp import NumpyMLP
from testbed.geometry.boxes import sat_normal

FORMAT_VERSION = 1
# version 2: an improved predictor's file that carries a resting expert (expert/...); a
# reader of version 1 would ignore those arrays and answer without the expert
EXPERT_FORMAT_VERSION = 2
# version 3 (issue 30): the expert's gate bounds its offsets per axis as fractions of the edge of
# support (learned_contact.model.expert.DOMAIN_FIELDS, 11 values; version 2: DOMAIN_FIELDS_V2, 9);
# a reader of version 2 would read them as metres
SUPPORT_FORMAT_VERSION = 3
EXPERT_FORMAT_VERSIONS = (EXPERT_FORMAT_VERSION, SUPPORT_FORMAT_VERSION)  # the versions that carry an expert
FORMAT_VERSIONS = (FORMAT_VERSION, EXPERT_FORMAT_VERSION, SUPPORT_FORMAT_VERSION)


@dataclasses.dataclass(frozen=True)
class MLPPredictor:
    """mlp: the network; supported_sizes (k, 3): full extents [m] it answers; meta:
    training config and provenance (JSON-able dict); compiled: run the numba kernels
    (True) or the numpy reference (False)."""

    kind: ClassVar[str] = ""
    mlp: NumpyMLP
    supported_sizes: np.ndarray
    meta: dict
    compiled: bool = False

    def __post_init__(self):
        sizes = np.ascontiguousarray(self.supported_sizes, dtype=float).reshape(-1, 3)
        object.__setattr__(self, "supported_sizes", sizes)
        if self.compiled:
            from learned_contact.compiled import box_depth, pack_mlp

            object.__setattr__(self, "_packed", pack_mlp(self.mlp))
            # load (or, with an empty numba cache, compile) the kernels now, at load time,
            # so that no later call inside a timed loop pays for it
            size = sizes[:1]
            p, R = np.array([[0.0, 0.0, size[0, 2]]]), np.eye(3)[None]
            self._predict_compiled(p, R, size, size, True)
            box_depth(p, R, size, size, sizes)

    def with_compiled(self, compiled: bool):
        """The same predictor on the other inference path."""
        return dataclasses.replace(self, compiled=compiled)

    # ------------------------------------------------------------------ interface
    def predict(self, p_AB, R_AB, *, size_A, size_B, outside: str = "clip"):
        """Contact point and normal for B at (p_AB, R_AB) in A's frame.

        p_AB (n, 3) or (3,): B's centre in A [m]; R_AB (n, 3, 3) or (3, 3): B's
        orientation in A; size_A, size_B (3,) or (n, 3): full box extents [m], each
        one of `supported_sizes`. Returns (point_A (n, 3) [m] in A's frame, normal_A
        (n, 3) unit, A towards B); (3,) each for a single pose. Raises
        PredictorInputError for bad shapes, non-finite values or unsupported sizes.

        Poses outside the trained range (separating-axis depth outside DOMAIN_DEPTH)
        are answered within a documented bound when outside="clip" (the default): the
        point is clamped into A's box grown by CLIP_MARGIN and the normal is a unit
        vector. outside="raise" refuses them with PredictorDomainError instead.
        """
        check_outside(outside)
        if not self.compiled:
            p, R, sA, sB, single = check_numpy(p_AB, R_AB, size_A, size_B, self.supported_sizes)
            point, normal, depth = self._predict_numpy(p, R, sA, sB, outside == "raise")
        else:
            p, R, single = check_poses(p_AB, R_AB)
            sA, sB = check_size_shape("size_A", size_A, len(p)), check_size_shape("size_B", size_B, len(p))
            point, normal, depth, status, row = self._predict_compiled(p, R, sA, sB, outside == "raise")
            if status:
                raise_for_status(status, row, p, sA, sB, self.supported_sizes, R)
        if outside == "raise" and np.any((depth < DOMAIN_DEPTH[0]) | (depth > DOMAIN_DEPTH[1])):
            raise domain_error(depth)
        return (point[0], normal[0]) if single else (point, normal)

    def depth(self, p_AB, R_AB, *, size_A, size_B):
        """(n,) separating-axis penetration depth [m] (negative = separated by that
        much); a float for a single pose. The closed-loop force law's depth."""
        if self.compiled:
            from learned_contact.compiled import box_depth

            p, R, single = check_poses(p_AB, R_AB)
            sA, sB = check_size_shape("size_A", size_A, len(p)), check_size_shape("size_B", size_B, len(p))
            depth, status, row = box_depth(p, R, sA, sB, self.supported_sizes)
            if status:
                raise_for_status(status, row, p, sA, sB, self.supported_sizes, R)
        else:
            p, R, sA, sB, single = check_numpy(p_AB, R_AB, size_A, size_B, self.supported_sizes)
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
        meta (JSON), the network under mlp/ and a subclass's extra arrays
        (learned_contact.predictors.loading reads it)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        version, extra = self._extra_arrays()
        np.savez(path, format_version=np.array(version), kind=np.array(self.kind),
                 supported_sizes=self.supported_sizes, meta=np.array(json.dumps(self.meta)),
                 **self.mlp.to_arrays("mlp/"), **extra)
        return path

    # ------------------------------------------------------------- for subclasses
    def _extra_arrays(self) -> tuple[int, dict]:
        """(format_version, arrays beyond the main network) that save() writes."""
        return FORMAT_VERSION, {}

    def _predict_numpy(self, p, R, sA, sB, with_depth: bool):
        """(point (n, 3), normal (n, 3), depth (n,)) on checked (n, ...) arrays."""
        raise NotImplementedError

    def _predict_compiled(self, p, R, sA, sB, with_depth: bool):
        """(point, normal, depth, status, row) from a compiled kernel."""
        raise NotImplementedError
