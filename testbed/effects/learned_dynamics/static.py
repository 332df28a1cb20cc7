"""The closed loop's static contact answer for a batch of poses: the force and normal stiffness the
force law applies (the native core's cc_static_contact, native/src/step_field.c), one function for
the bench, the tests, the docs and both hosts.

The answer is the hydroelastic model's own: the exact integral of the two compliant boxes' pressure
fields over their equal-pressure surface, at any pose (corners, edges, any yaw), not a fitted law;
testbed/geometry/box_pressure.py is its independent numpy reference, and both agree with Drake's
contact surface (tests/learned/test_static_contact.py: force within 1e-9 relative). The moduli:
both boxes at `modulus` (the law's KAPPA_MODULUS by default, the learned scenes' modulus).

Frames: A's frame (origin at A's centre, axes along its edges). p_AB (n, 3) [m], R_AB (n, 3, 3),
size_A, size_B (3,) or (n, 3) full extents [m].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.effects.learned_dynamics.force_law import KAPPA_MODULUS
from testbed.effects.learned_dynamics.step import require_native
from testbed.errors import TestbedError

PREDICTORS = ("improved", "paper")  # both are driven by the testbed's law: its force is theirs


@dataclass(frozen=True)
class StaticContact:
    """force (n, 3) [N] on B in A's frame; moment (n, 3) [N m] about A's origin in A's frame; cop
    (n, 3) [m] (NaN without a surface); area (n,) [m^2]; stiffness (n,) [N/m] dF/dd along the
    force; dforce_ddepth (n, 3, 3) [N/m] J with d(force) = J u dd for B moved by -u dd."""

    force: np.ndarray
    moment: np.ndarray
    cop: np.ndarray
    area: np.ndarray
    stiffness: np.ndarray
    dforce_ddepth: np.ndarray


def static_answer(p_AB, R_AB, size_A, size_B, *, modulus: float = KAPPA_MODULUS) -> StaticContact:
    """The whole static answer at each pose (module docstring)."""
    p = np.ascontiguousarray(np.atleast_2d(p_AB), dtype=float)
    n = p.shape[0]
    R = np.ascontiguousarray(np.reshape(R_AB, (n, 3, 3)), dtype=float)
    hA = np.ascontiguousarray(np.broadcast_to(0.5 * np.asarray(size_A, dtype=float), (n, 3)))
    hB = np.ascontiguousarray(np.broadcast_to(0.5 * np.asarray(size_B, dtype=float), (n, 3)))
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(R)) and np.all(hA > 0) and np.all(hB > 0) and modulus > 0):
        raise TestbedError("static_contact: expected finite poses, sizes > 0 [m] and a modulus > 0 [Pa]")
    out = np.zeros((n, 26))
    require_native().static_contact(p, R, hA, hB, float(modulus), float(modulus), out)
    has = out[:, 13] > 0
    cop = np.where(has[:, None], out[:, 6:9], np.nan)
    return StaticContact(out[:, 0:3], out[:, 3:6], cop, out[:, 13], out[:, 23], out[:, 14:23].reshape(n, 3, 3))


def static_contact(p_AB, R_AB, size_A, size_B, *, modulus: float = KAPPA_MODULUS,
                   predictor: str = "improved") -> tuple[np.ndarray, np.ndarray]:
    """(force_A (n, 3) [N] on B in A's frame, stiffness (n,) [N/m]) the closed loop applies at each
    static pose, for a predictor the testbed's law drives (PREDICTORS: the law's force does not
    depend on which; a user's model that supplies its own force is judged on that instead)."""
    if predictor not in PREDICTORS:
        raise TestbedError(f"static_contact: predictor {predictor!r}; expected one of: {', '.join(PREDICTORS)}")
    answer = static_answer(p_AB, R_AB, size_A, size_B, modulus=modulus)
    return answer.force, answer.stiffness
