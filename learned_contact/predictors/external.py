"""Predictors the testbed did not ship: any model behind the Predictor interface.

`ExternalPredictor` wraps a raw answer function (an ONNX session, a user's Python
object) and gives it exactly the behaviour the shipped predictors have, so the bench,
the effects, the gates and the closed loop treat every model alike:

- inputs checked as the numpy reference path checks them (interface.check_numpy):
  shapes, finiteness, proper rotations, sizes among `supported_sizes`;
- outputs checked at run time (`check_answers`): shapes (n, 3), finite values and unit
  normals; a batch with NaN/inf outputs or a normal whose length is further than
  NORMAL_LENGTH_TOLERANCE from 1 is refused with PredictorOutputError naming how many
  poses; normals within the tolerance are normalised;
- depth: the model's own `depth` answer when it gives one, else the separating-axis
  depth of the two boxes (testbed.geometry.boxes.sat_normal), the same figure the shipped
  predictors report;
- poses outside DOMAIN_DEPTH: outside="clip" clamps the point into A's box grown by
  CLIP_MARGIN (as the shipped predictors do), outside="raise" refuses them;
- force (optional): a model may answer its own elastic contact force (`contact_force`: the
  normal force magnitude along its normal, its normal stiffness and the contact area, at
  FORCE_MODULUS); the bench judges it against Drake's and the closed loop applies it in place
  of the testbed's exact field force. Without one, the testbed's force drives it.

Frames and units as learned_contact.interface: p_AB (n, 3) [m] B's centre in A, R_AB
(n, 3, 3) B's orientation in A, size_A/size_B full extents [m]; point_A (n, 3) [m] in
A, normal_A (n, 3) unit from A into B.
"""

from __future__ import annotations

import contextlib
from typing import Callable, ContextManager, Optional

import numpy as np

from learned_contact.compiled import NATIVE_AVAILABLE, box_depth, native_check
from learned_contact.errors import PredictorOutputError, WeightsError
from learned_contact.interface import (
    CLIP_MARGIN,
    DOMAIN_DEPTH,
    check_numpy,
    check_outside,
    check_poses,
    check_size_shape,
    domain_error,
)
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.geometry.boxes import sat_normal

# A model's normals are accepted within this distance of unit length and normalised: a
# float32 network normalising its own output is unit to ~1e-7; 1e-3 admits a model that
# does not normalise but was trained towards unit vectors, and refuses one that is wrong.
NORMAL_LENGTH_TOLERANCE = 1e-3
# The load-time probe's bounds. Answers to the same pose asked in one batch, alone and again
# must agree within this [m] (points) and [-] (normal components): a float32 network over
# 12 m boxes rounds at ~1e-6 m, and batched and one-by-one kernels may round differently;
# 1e-4 m is 100x that and refuses a model whose answer depends on the rest of its batch or
# on chance (a batch mean, +-5 cm noise).
CONSISTENCY_TOLERANCE = 1e-4
# An in-domain answer's point must lie within both boxes grown by this [m]: the predicted
# point is where two boxes touch, so one further than half a metre outside either box is
# not a contact point of these boxes (the paper's MLP, the worst shipped model, stays within).
REACH_MARGIN = 0.5
MAX_SUPPORTED_SIZES = 64  # the probe asks every pair of sizes: 64 sizes are 4,096 poses
SINGLE_POSES = 6  # poses of the probe also asked one at a time

# (p (n, 3), R (n, 3, 3), size_A (n, 3), size_B (n, 3)) -> (point (n, 3), normal (n, 3), depth (n,) or None)
AnswerFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], tuple]
# the same arguments -> a function of no arguments that runs the model's own call alone on them
OwnCallFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], Callable[[], object]]
# calls -> a context bounding that many own calls in a row (learned_contact.predictors.limits)
OwnRoundFn = Callable[[int], ContextManager]


def default_sizes() -> np.ndarray:
    """(k, 3) full extents [m] of every container type the testbed simulates: what a
    model that states no `supported_sizes` is asked to answer."""

    return np.array([t.size for t in CONTAINER_TYPES.values()], dtype=float)


def check_answers(source: str, point, normal, depth, n: int):
    """(point (n, 3), normal (n, 3) unit, depth (n,) or None) as float arrays, or
    PredictorOutputError naming the source and what is wrong (shape, NaN/inf count,
    normals off unit length count)."""
    point = np.asarray(point, dtype=float)
    normal = np.asarray(normal, dtype=float)
    for name, value in (("point_A", point), ("normal_A", normal)):
        if value.shape != (n, 3):
            raise PredictorOutputError(f"{source}: output {name} has shape {value.shape} for {n} poses; "
                                       f"expected ({n}, 3)")
    if depth is not None:
        depth = np.asarray(depth, dtype=float).reshape(-1)
        if depth.shape != (n,):
            raise PredictorOutputError(f"{source}: output depth has shape {np.shape(depth)} for {n} poses; "
                                       f"expected ({n},)")
    bad = ~(np.isfinite(point).all(axis=1) & np.isfinite(normal).all(axis=1))
    if depth is not None:
        bad |= ~np.isfinite(depth)
    if np.any(bad):
        raise PredictorOutputError(f"{source}: {int(bad.sum())} of {n} answers hold NaN or inf (first at pose "
                                   f"{int(np.argmax(bad))}); expected finite point_A, normal_A and depth")
    length = np.linalg.norm(normal, axis=1)
    off = np.abs(length - 1.0) > NORMAL_LENGTH_TOLERANCE
    if np.any(off):
        worst = float(length[off][np.argmax(np.abs(length[off] - 1.0))])
        raise PredictorOutputError(f"{source}: {int(off.sum())} of {n} normals are not unit length (worst "
                                   f"|normal_A| = {worst:.6g}); expected unit vectors within "
                                   f"{NORMAL_LENGTH_TOLERANCE:g}")
    return point, normal / length[:, None], depth


FORCE_MODULUS = 1.0e8  # [Pa] the modulus a model's own force is stated at (the law's; linear in it)


def check_force(source: str, force_n, stiffness, area, n: int) -> np.ndarray:
    """(n, 3) rows (F [N], dF/dd [N/m], area [m^2]) of a model's force answer, or
    PredictorOutputError naming what is wrong (shapes (n,), finite, F, dF/dd and area >= 0)."""
    rows = np.zeros((n, 3))
    for col, (name, value) in enumerate((("force_n", force_n), ("stiffness", stiffness), ("area", area))):
        if value is None and name == "area":
            continue
        v = np.asarray(value, dtype=float).reshape(-1)
        if v.shape != (n,) or not np.all(np.isfinite(v)) or np.any(v < 0):
            raise PredictorOutputError(f"{source}: output {name} has shape {np.shape(value)} for {n} poses or values "
                                       f"not finite and >= 0; expected ({n},) finite values >= 0")
        rows[:, col] = v
    return rows


class ExternalPredictor:
    """A model the testbed did not ship, behind learned_contact.interface.Predictor.

    kind: its catalogue source ("onnx", "python"); name: what the bench and reports call
    it; answer: the raw answer function (AnswerFn: the model's call under its per-call bound,
    inputs converted, outputs as arrays); own_call: OwnCallFn, the model's own call alone
    (see `own_call`; default: the answer function) and own_round: OwnRoundFn, the bound on a
    round of them (see `own_round`; default: none, the answer function bounds each call);
    supported_sizes (k, 3) full extents
    [m]; source: the file or module:attribute it came from (named in every error).
    `compiled` is False: the native core is the shipped predictors' own.
    """

    compiled = False

    def __init__(self, *, kind: str, name: str, answer: AnswerFn, supported_sizes, source: str,
                 depth_fn: Optional[AnswerFn] = None, own_call: Optional[OwnCallFn] = None,
                 own_round: Optional[OwnRoundFn] = None, force_fn: Optional[AnswerFn] = None):
        self.kind, self.source = kind, source
        self._force_fn = force_fn  # (p, R, sA, sB) -> (force_n, stiffness, area or None)
        self.name = "".join(ch if ch.isprintable() else "_" for ch in str(name))[:80]  # shown in tables and lines
        self._answer, self._depth_fn = answer, depth_fn
        self._own_call = own_call if own_call is not None else (lambda p, R, sA, sB: lambda: answer(p, R, sA, sB))
        self._own_round = own_round if own_call is not None and own_round is not None else \
            (lambda calls: contextlib.nullcontext())
        self.supported_sizes = np.ascontiguousarray(supported_sizes, dtype=float).reshape(-1, 3)
        self.meta = {"source": source, "name": name}

    @property
    def answer_function(self) -> AnswerFn:
        """The model's raw answer function (its call under the per-call bound, inputs converted;
        no checks, depth or clipping)."""
        return self._answer

    def own_call(self, p_AB, R_AB, size_A, size_B) -> Callable[[], object]:
        """A function of no arguments that runs the model's own call alone on these poses
        (p_AB (n, 3) [m], R_AB (n, 3, 3), size_A and size_B (n, 3) full extents [m]), the inputs
        prepared beforehand as the model takes them: onnxruntime's session.run on the converted
        feed, a Python model's predict; no bound, conversion, checks, depth or clipping. What an
        integrator calling the model directly pays, which the bench times beside the full
        predict (learned_contact.evaluation.cost.predictor_cost). Run them inside `own_round`."""
        return self._own_call(*(np.asarray(v, dtype=float) for v in (p_AB, R_AB, size_A, size_B)))

    def own_round(self, calls: int) -> ContextManager:
        """A context inside which `calls` own calls (own_call) run in a row, bounded as a whole at
        calls x --model-call-timeout (limits: the watchdog for ONNX, SIGALRM for Python), so that a
        model is never run unbounded, at the cost of one bound per round, not per call."""
        return self._own_round(calls)

    def __repr__(self) -> str:
        return f"ExternalPredictor(kind={self.kind!r}, name={self.name!r}, source={self.source!r})"

    def _checked(self, p_AB, R_AB, size_A, size_B):
        """check_numpy's answer: (p (n, 3), R (n, 3, 3), size_A (n, 3), size_B (n, 3), single).
        The value checks run in the native core where it is built (a few us against ~80 us of
        numpy on small arrays, which a tiny model's own call does not cost); where they find
        anything, check_numpy runs and raises the reference's error."""
        if NATIVE_AVAILABLE:
            p, R, single = check_poses(p_AB, R_AB)
            sA, sB = check_size_shape("size_A", size_A, len(p)), check_size_shape("size_B", size_B, len(p))
            if native_check(self.supported_sizes, p, R, sA, sB) == 0:
                full = lambda s: s if len(s) == len(p) else np.repeat(s, len(p), axis=0)  # noqa: E731
                return p, R, full(sA), full(sB), single
        return check_numpy(p_AB, R_AB, size_A, size_B, self.supported_sizes)

    def _raw(self, p, R, sA, sB):
        point, normal, depth = self._answer(p, R, sA, sB)
        point, normal, depth = check_answers(self.source, point, normal, depth, len(p))
        if depth is None:
            depth = self._depth_of(p, R, sA, sB)
        return point, normal, depth

    def _depth_of(self, p, R, sA, sB) -> np.ndarray:
        if self._depth_fn is not None:
            depth = np.asarray(self._depth_fn(p, R, sA, sB), dtype=float).reshape(-1)
            if depth.shape != (len(p),) or not np.all(np.isfinite(depth)):
                raise PredictorOutputError(f"{self.source}: depth answered shape {depth.shape} or non-finite "
                                           f"values for {len(p)} poses; expected ({len(p)},) finite [m]")
            return depth
        if NATIVE_AVAILABLE:  # the same separating-axis depth in C: ~1 us instead of ~100 us of numpy per call
            return box_depth(p, R, sA, sB)
        return sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1]

    def predict(self, p_AB, R_AB, *, size_A, size_B, outside: str = "clip"):
        """(point_A (n, 3) [m], normal_A (n, 3) unit), (3,) each for a single pose; see
        learned_contact.interface.Predictor.predict."""
        check_outside(outside)
        p, R, sA, sB, single = self._checked(p_AB, R_AB, size_A, size_B)
        point, normal, depth = self._raw(p, R, sA, sB)
        out = (depth < DOMAIN_DEPTH[0]) | (depth > DOMAIN_DEPTH[1])
        if np.any(out):
            if outside == "raise":
                raise domain_error(depth)
            bound = 0.5 * sA + CLIP_MARGIN
            point = np.where(out[:, None], np.clip(point, -bound, bound), point)
        return (point[0], normal[0]) if single else (point, normal)

    def depth(self, p_AB, R_AB, *, size_A, size_B):
        """(n,) penetration depth [m] (negative: separated); a float for a single pose."""
        p, R, sA, sB, single = self._checked(p_AB, R_AB, size_A, size_B)
        depth = self._depth_of(p, R, sA, sB)
        return float(depth[0]) if single else depth

    @property
    def has_force(self) -> bool:
        """Whether the model answers its own contact force (contact_force)."""
        return self._force_fn is not None

    def contact_force(self, p_AB, R_AB, *, size_A, size_B) -> np.ndarray:
        """(n, 3) rows (F [N] the elastic normal force along the model's normal, 0 where apart; dF/dd
        [N/m] its normal stiffness; area [m^2], 0 if the model gives none) at FORCE_MODULUS; a
        PredictorOutputError for a model without one or a bad answer."""
        if self._force_fn is None:
            raise PredictorOutputError(f"{self.source}: the model answers no force (outputs force_n and stiffness)")
        p, R, sA, sB, _ = self._checked(p_AB, R_AB, size_A, size_B)
        force_n, stiffness, area = self._force_fn(p, R, sA, sB)
        return check_force(self.source, force_n, stiffness, area, len(p))

    def in_domain(self, p_AB, R_AB, *, size_A, size_B):
        """(n,) bool (a bool for a single pose): depth within DOMAIN_DEPTH."""
        d = np.asarray(self.depth(p_AB, R_AB, size_A=size_A, size_B=size_B))
        ok = (d >= DOMAIN_DEPTH[0]) & (d <= DOMAIN_DEPTH[1])
        return bool(ok) if ok.ndim == 0 else ok


def consistency_probe(predictor: ExternalPredictor) -> None:
    """The load-time probe every untrusted model must pass (PredictorOutputError or
    WeightsError naming the model, the check and by how much otherwise): the probe batch
    (probe_poses) answered with finite unit-normal outputs of the right shapes; the same
    batch again, reversed and SINGLE_POSES of its poses one at a time answered the same
    within CONSISTENCY_TOLERANCE; every in-domain point within REACH_MARGIN of both boxes."""
    sizes = np.asarray(predictor.supported_sizes)
    if len(sizes) > MAX_SUPPORTED_SIZES:
        raise WeightsError(f"{predictor.source}: declares {len(sizes)} supported sizes; expected at most "
                           f"{MAX_SUPPORTED_SIZES} (the probe asks every pair of them)")
    p, R, sA, sB = probe_poses(sizes)
    point, normal = predictor.predict(p, R, size_A=sA, size_B=sB)
    asked = {"asked again": (p, R, sA, sB, slice(None))}
    back = slice(None, None, -1)
    asked["asked in reverse order"] = (p[back], R[back], sA[back], sB[back], back)
    for i in np.linspace(0, len(p) - 1, min(SINGLE_POSES, len(p))).astype(int):
        one = slice(int(i), int(i) + 1)
        asked[f"asked alone (pose {int(i)})"] = (p[one], R[one], sA[one], sB[one], one)
    for how, (pp, RR, a, b, rows) in asked.items():
        q, n = predictor.predict(pp, RR, size_A=a, size_B=b)
        off = max(float(np.max(np.abs(np.asarray(q) - point[rows]))), float(np.max(np.abs(np.asarray(n) - normal[rows]))))
        if not off <= CONSISTENCY_TOLERANCE:
            raise WeightsError(f"{predictor.source}: refused by the load-time consistency probe: the answer to the same "
                               f"poses {how} differs from the batch's by {off:.3g}; expected the same answer within "
                               f"{CONSISTENCY_TOLERANCE:g} (a model's answer may depend only on its pose)")
    depth = np.asarray(predictor.depth(p, R, size_A=sA, size_B=sB))
    inside = (depth >= DOMAIN_DEPTH[0]) & (depth <= DOMAIN_DEPTH[1])
    outside_A = np.max(np.abs(point) - 0.5 * sA, axis=1)  # (n,) [m] > 0: beyond A's box by that much
    in_B = np.einsum("nji,nj->ni", R, point - p)  # (n, 3) the point in B's frame [m]
    outside_B = np.max(np.abs(in_B) - 0.5 * sB, axis=1)
    far = np.maximum(outside_A, outside_B) * inside
    if np.any(far > REACH_MARGIN):
        worst = int(np.argmax(far))
        raise WeightsError(f"{predictor.source}: refused by the load-time consistency probe: {int((far > REACH_MARGIN).sum())} "
                           f"of {len(p)} answers put the contact point {far[worst]:.4g} m outside a box (pose {worst}, "
                           f"depth {depth[worst] * 1000:.3g} mm); expected points within {REACH_MARGIN:g} m of both boxes")


def probe_poses(sizes: np.ndarray):
    """A small batch every model must answer when it is loaded: B resting 5 mm deep on A
    for every pair of supported sizes, one of them tilted and offset. Returns (p_AB (n, 3),
    R_AB (n, 3, 3), size_A (n, 3), size_B (n, 3))."""
    sizes = np.asarray(sizes, dtype=float).reshape(-1, 3)
    pairs = [(a, b) for a in sizes for b in sizes]
    n = len(pairs)
    size_A = np.array([a for a, _ in pairs])
    size_B = np.array([b for _, b in pairs])
    p = np.zeros((n, 3))
    p[:, 2] = 0.5 * (size_A[:, 2] + size_B[:, 2]) - 0.005
    R = np.repeat(np.eye(3)[None], n, axis=0)
    c, s = np.cos(0.01), np.sin(0.01)
    R[0] = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    p[0, :2] = (0.3, -0.2)
    # the first pair again: yawed 2 deg and offset, and tilted about y by 0.1 deg (deeper by
    # the tilt's drop at the edge, <= 1.1 cm for 12.2 m boxes: within the trained depths)
    c, s = np.cos(np.radians(2.0)), np.sin(np.radians(2.0))
    yaw = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    c, s = np.cos(np.radians(0.1)), np.sin(np.radians(0.1))
    tilt = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    p = np.vstack([p, [[-0.4, 0.1, p[0, 2]], [0.2, 0.0, p[0, 2]]]])
    R = np.concatenate([R, yaw[None], tilt[None]])
    size_A = np.vstack([size_A, size_A[:1], size_A[:1]])
    size_B = np.vstack([size_B, size_B[:1], size_B[:1]])
    return p, R, size_A, size_B
