"""Simple alternatives to the shipped predictor, for the closed-loop gates' test.

Each is a `module:attribute` predictor (this module is importable as
`closed_loop_alternatives` when tests/ is on sys.path): a factory with no arguments whose
object answers predict(p_AB, R_AB, *, size_A, size_B) -> (point_A (n, 3) [m] in A's frame,
unit normal_A (n, 3) from A into B). A is the pair's lower body index; in the overhang
scenes (testbed/scenes/overhang_*.yaml) that is the welded base, at the world origin
without rotation, and the overhang lies along A's +x.

- bias_5cm, bias_30cm: the shipped improved predictor with every point moved 5 cm / 30 cm
  along A's +x (toward the overhang); bias_away_30cm: 30 cm along A's -x (away from it);
- normal_1deg: the improved predictor with every normal tilted 1 deg about A's y, its
  top toward A's +x (toward the overhang);
- prior: the improved predictor's geometric estimate alone (learned_contact.evaluation.gates.GeometricPrior);
- drake_point: Drake point contact's answer (ComputePointPairPenetration: the midpoint of
  the two witness points, its normal), the geometric prior's answer where Drake finds none;
- drake_hydroelastic: not an alternative but the reference, Drake hydroelastic's own static
  answer at the pose (the centre of pressure and pressure-weighted normal of the contact
  surface: what the shipped predictor was trained on), the prior's answer where there is none.
"""

from __future__ import annotations

import numpy as np
from bench_models import GeometricModel

from testbed.validation.sensitivity import Biased, TiltedNormal


class Prior(GeometricModel):
    """learned_contact.evaluation.gates.GeometricPrior: the improved predictor's network correction zeroed."""

    name = "geometric prior alone"


class DrakePoint:
    """Drake point contact's point and normal at each pose (one two-box plant per type pair,
    testbed.contact.pair_plant.ContainerPair); the geometric prior's answer where Drake reports no
    penetrating pair."""

    name = "Drake point contact's answer"
    modulus = None  # the SDF's; the point query does not read it

    def __init__(self):
        from testbed.bodies.containers import CONTAINER_TYPES

        self._types = {tuple(np.round(t.size, 3)): code for code, t in CONTAINER_TYPES.items()}
        self._pairs = {}
        self._prior = Prior()

    def _pair(self, size_A, size_B):
        key = (self._types[tuple(np.round(size_A, 3))], self._types[tuple(np.round(size_B, 3))])
        if key not in self._pairs:
            from testbed.contact.pair_plant import ContainerPair

            self._pairs[key] = ContainerPair(*key, modulus=self.modulus)
        return self._pairs[key]

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        p_AB, R_AB = np.asarray(p_AB, float), np.asarray(R_AB, float)
        size_A = np.broadcast_to(np.asarray(size_A, float), p_AB.shape)
        size_B = np.broadcast_to(np.asarray(size_B, float), p_AB.shape)
        point, normal = (np.array(x, dtype=float) for x in
                         self._prior.predict(p_AB, R_AB, size_A=size_A, size_B=size_B))
        for i in range(len(p_AB)):
            pair = self._pair(size_A[i], size_B[i])
            answer = self._answer(pair, pair.set_pose(p_AB[i], R_AB[i]))
            if answer is not None:
                point[i], normal[i] = answer
        return point, normal

    @staticmethod
    def _answer(pair, query):
        """(point, normal) in A's frame (A sits at the world origin), or None."""
        found = query.ComputePointPairPenetration()
        if not found:
            return None
        pp = found[0]
        flip = -1.0 if pp.id_A == pair.gid_a else 1.0  # nhat_BA_W: out of Drake's B into Drake's A
        return 0.5 * (pp.p_WCa + pp.p_WCb), flip * pp.nhat_BA_W


class DrakeHydroelastic(DrakePoint):
    """Drake hydroelastic's static answer at each pose: the contact surface's centre of pressure
    and pressure-weighted normal (testbed.contact.surfaces.static_pressure), as the training
    labels take them (learned_contact/data/labels.py); the geometric prior's answer where there is
    no surface. The centre of pressure does not depend on the modulus (pressure scales with it)."""

    name = "Drake hydroelastic's static answer"

    @staticmethod
    def _answer(pair, query):
        from pydrake.geometry import HydroelasticContactRepresentation

        from testbed.contact.surfaces import static_pressure, surface_face_arrays

        surfaces = query.ComputeContactSurfaces(HydroelasticContactRepresentation.kPolygon)
        if not surfaces:
            return None
        sp = static_pressure(surface_face_arrays(surfaces[0]))
        if not np.all(np.isfinite(sp.cop)):
            return None
        flip = 1.0 if surfaces[0].id_M() == pair.gid_b else -1.0  # face normals point out of N into M
        return sp.cop, flip * sp.normal


def bias_5cm():
    return Biased(0.05)


def bias_30cm():
    return Biased(0.30)


def bias_away_30cm():
    return Biased(-0.30)


def normal_1deg():
    return TiltedNormal(1.0)


def prior():
    return Prior()


def drake_point():
    return DrakePoint()


def drake_hydroelastic():
    return DrakeHydroelastic()


def __getattr__(name: str):
    """Factories for any bias or tilt (the bisection of the smallest one that flips a verdict):
    `bias_mm_25` moves every point 25 mm toward the overhang (A's +x), `bias_mm_m25` 25 mm away
    from it; `tilt_mdeg_500` tilts every normal 0.5 deg (millidegrees) toward it."""
    for prefix, make, scale in (("bias_mm_", Biased, 1e-3), ("tilt_mdeg_", TiltedNormal, 1e-3)):
        if name.startswith(prefix):
            tail = name[len(prefix):]
            sign = -1.0 if tail.startswith("m") else 1.0
            if tail.lstrip("m").isdigit():
                value = sign * int(tail.lstrip("m")) * scale
                return lambda: make(value)
    raise AttributeError(name)


# name in the report -> `module:attribute` predictor
ALTERNATIVES = {"bias 5 cm": "closed_loop_alternatives:bias_5cm", "bias 30 cm": "closed_loop_alternatives:bias_30cm",
                "bias -30 cm": "closed_loop_alternatives:bias_away_30cm",
                "normal 1 deg": "closed_loop_alternatives:normal_1deg", "prior": "closed_loop_alternatives:prior",
                "drake point": "closed_loop_alternatives:drake_point"}
# the reference every closed-loop gate must pass: Drake hydroelastic's own static answer
REFERENCE = {"drake hydroelastic": "closed_loop_alternatives:drake_hydroelastic"}
