"""The improved contact predictor (kind "improved"): geometric estimate + learned correction.

    pred = learned_contact.load_predictor()      # shipped default (learned_contact.predictors.loading)
    point_A, normal_A = pred.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)

Pipeline (fixed cost per pair): canonicalise the pose into A's positive octant
(encodings.canonicalise), compute the geometric estimate and features
(encodings.features), let the MLP correct the estimate (point += POINT_STEP * y[:3],
normal = normalise(estimate + y[3:6])), reflect back. Within encodings.SYMMETRY_BAND of
one of A's reflection planes the answer is blended with the same pose answered in the
neighbouring octant's frame (encodings.frame_blend), so that it is continuous across
the plane by construction. Where stacks rest (learned_contact.model.expert's gate) a second
network of the same shape, the resting expert, gives the correction instead, with a
smooth hand-over at its domain's edges. The numpy path below is the
reference; the native core (native/src/predict.c, called through learned_contact.compiled
when compiled=True) is the same pipeline in C.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from learned_contact.compiled import native_model
from learned_contact.interface import CLIP_MARGIN, DOMAIN_DEPTH, SIZE_TOLERANCE
from learned_contact.model.encodings import features, frame_blend, reflect
from learned_contact.model.expert import LAYOUTS, layout, weights
from learned_contact.model.mlp import NumpyMLP
from learned_contact.model.quadrature import NORMAL_TILT, POINT_TILT, face_on_face, hand_over
from learned_contact.predictors.base import EXPERT_FORMAT_VERSION, FORMAT_VERSION, SUPPORT_FORMAT_VERSION, MLPPredictor
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.geometry.boxes import sat_normal

SHIPPED_DIR = Path(__file__).resolve().parents[1] / "shipped"
DEFAULT_WEIGHTS = SHIPPED_DIR / "weights.npz"
POINT_STEP = 0.5  # [m] per unit of the MLP's point outputs
# (2, 3) [m] lowest, highest full extents of any box the shipped predictor answers besides the ISO types
# (testbed/bench/size_classes.py measures it per size class): lengths of 10 to 45 ft boxes,
# heights from half heights to high cubes, and the one width of ISO 668 series 1. The network was fitted
# on that width alone, so its input standardisation has no spread there (x_std floored at 1e-6): a
# 2.5 m wide box is answered metres off (measured: point median 8 m on general poses), so no other
# width is answered until a network is fitted on varied widths.
ANSWERED_SIZE_RANGE = np.array([[2.9, 2.438, 1.2], [13.8, 2.438, 3.0]])

__all__ = ["CLIP_MARGIN", "DEFAULT_WEIGHTS", "DOMAIN_DEPTH", "EXPERT_FORMAT_VERSION", "FORMAT_VERSION", "POINT_STEP", "SHIPPED_DIR",
           "SIZE_TOLERANCE", "SUPPORT_FORMAT_VERSION", "ANSWERED_SIZE_RANGE", "ContactPredictor", "answered_sizes"]


def answered_sizes() -> np.ndarray:
    """(k, 3) full extents [m] of every ISO type in the catalogue (testbed.bodies.containers), the
    shipped predictor's supported_sizes."""
    return np.array([t.size for t in CONTAINER_TYPES.values()], dtype=float)


@dataclasses.dataclass(frozen=True)
class ContactPredictor(MLPPredictor):
    """Predicts the static hydroelastic contact answer of a container pair (see the
    module docstring); the interface is learned_contact.interface.Predictor.

    expert: the resting expert (same input and output widths as mlp) or None;
    expert_domain (11,) or (9,): its gate's bounds (learned_contact.model.expert.DOMAIN_FIELDS,
    offsets as fractions of the edge of support, saved as format_version 3; or the issue-20
    layout DOMAIN_FIELDS_V2, absolute offsets [m], format_version 2), given exactly when
    expert is."""

    kind = "improved"
    expert: NumpyMLP | None = None
    expert_domain: np.ndarray | None = None

    def __post_init__(self):
        if (self.expert is None) != (self.expert_domain is None):
            raise ValueError("expert and expert_domain go together: give both or neither")
        if self.expert is not None:
            object.__setattr__(self, "expert_domain", np.asarray(self.expert_domain, dtype=float).copy())
            layout(self.expert_domain)  # 9 or 11 values, else ValueError
        super().__post_init__()

    def _native_model(self):
        """The native core's Model: the main network, and the resting expert with its gate's bounds."""
        return native_model(self.kind, self.supported_sizes, self.mlp, self.expert, self.expert_domain,
                            size_range=self.size_range)

    def _correction(self, x, p_c, R_c, h_A, h_B, depth, overlap):
        """(n, 6) the correction for features x (n, F) of canonical poses p_c (n, 3) [m],
        R_c (n, 3, 3), half extents (n, 3) [m], depth (n,) [m], overlaps (n, 15) [m]: the
        main network's, where the expert's gate is open blended with the expert's, all
        scaled by the slab scale (0 where B's face is parallel to A's: the prior's answer
        exactly; learned_contact.model.expert.weights); each network only where it counts."""
        w_main, w_expert = weights(p_c, R_c, h_A, h_B, depth, self.expert_domain, overlap)
        y = np.zeros((len(x), 6))
        main, expert = w_main > 0.0, w_expert > 0.0
        y[main] = w_main[main, None] * self.mlp(x[main])
        if np.any(expert):
            y[expert] += w_expert[expert, None] * self.expert(x[expert])
        return y

    def _extra_arrays(self):
        if self.expert is None:
            return FORMAT_VERSION, {}
        version = next(v for v, fields in LAYOUTS.items() if fields is layout(self.expert_domain))
        return version, {**self.expert.to_arrays("expert/"), "expert/domain": self.expert_domain}

    def _predict_numpy(self, p, R, sA, sB, with_depth: bool):
        h_A, h_B = 0.5 * sA, 0.5 * sB
        sat_n, depth, _ = sat_normal(p, R, h_A, h_B)
        # the faces meet: overlap over A's face (weight > 0); no upper depth bound (the quadrature
        # holds while the overlap is thin against the tetrahedra, a half width deep, and its point
        # lies on A's face, inside the clip box), so nothing jumps at DOMAIN_DEPTH[1]
        q_point, q_normal, q_weight, tilt = face_on_face(p, R, h_A, h_B, sat_n)
        faces_meet = (depth >= DOMAIN_DEPTH[0]) & (q_weight > 0.0)
        f_point = np.where(faces_meet, hand_over(tilt, POINT_TILT), 0.0)  # (n,)
        f_normal = np.where(faces_meet, hand_over(tilt, NORMAL_TILT), 0.0)
        point, normal = q_point.copy(), q_normal.copy()
        rest = np.flatnonzero((f_point < 1.0) | (f_normal < 1.0))  # the learned pipeline answers these
        if len(rest):
            pp, pn = self._learned(p[rest], R[rest], h_A[rest], h_B[rest], sat_n[rest], depth[rest])
            fp, fn = f_point[rest, None], f_normal[rest, None]
            point[rest] = np.where(fp > 0.0, fp * q_point[rest] + (1.0 - fp) * pp, pp)
            mixed = np.where(fn > 0.0, fn * q_normal[rest] + (1.0 - fn) * pn, pn)
            normal[rest] = mixed / np.linalg.norm(mixed, axis=1, keepdims=True)
        return point, normal, depth

    def _learned(self, p, R, h_A, h_B, sat_n, depth):
        """(point (n, 3) [m], normal (n, 3) unit A->B): the geometric estimate corrected by
        the networks, in the octant frames of encodings.frame_blend, clipped outside
        DOMAIN_DEPTH (the answer where the faces do not meet face on face)."""
        out = (depth < DOMAIN_DEPTH[0]) | (depth > DOMAIN_DEPTH[1])
        point, normal = np.zeros_like(p), np.zeros_like(p)
        for sigma, coef in frame_blend(p):  # the octant frame, and its neighbours near a plane
            rows = np.flatnonzero(coef > 0.0)
            if len(rows) == 0:
                continue
            p_c, R_c = reflect(sigma[rows], p[rows], R[rows])
            x, point_est, normal_est, overlap = features(p_c, R_c, h_A[rows], h_B[rows], with_overlap=True)
            y = self._correction(x, p_c, R_c, h_A[rows], h_B[rows], depth[rows], overlap)
            c = coef[rows, None]
            point[rows] += c * (sigma[rows] * (point_est + POINT_STEP * y[:, :3]))
            normal[rows] += c * (sigma[rows] * (normal_est + y[:, 3:6]))
        length = np.linalg.norm(normal, axis=1, keepdims=True)
        ok = np.isfinite(length) & (length > 1e-9)
        normal = np.where(ok, normal / np.where(ok, length, 1.0), sat_n)
        if np.any(out):
            bound = h_A + CLIP_MARGIN
            point = np.where(out[:, None], np.clip(point, -bound, bound), point)
        return point, normal

