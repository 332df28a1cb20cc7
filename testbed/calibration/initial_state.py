"""Initial states of a toss rollout: the published first-frame protocol, or an optional
estimate from the pre-impact free-flight frames.

"first-frame" (THE metric of Acosta, Yang and Posa): pose and velocities of frame 0 as
recorded (the angular velocity rotated from the body frame to W). Motion-capture noise in
that single frame, and the backward-difference velocity, go straight into the rollout.

"flight-fit" (a separate diagnostic, never the headline figure): before the cube first
comes near the table it flies freely, so its centre follows a parabola under gravity and,
the cube's principal moments being equal, its world angular velocity is constant. Least
squares over those frames give p_WB(0), v_WB(0), R_WB(0) and w_WB_W. It tells how much of the
first-frame error is the first frame's own noise rather than the contact model.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RotationMatrix

from testbed.calibration.data import CUBE_WIDTH, Toss
from testbed.errors import TestbedError
from testbed.physics import GRAVITY

INITIAL_STATES = ("first-frame", "flight-fit")
FLIGHT_CLEARANCE = 0.004  # [m] lowest corner this far above the table counts as free flight (mocap noise ~0.3 mm)
MIN_FLIGHT_FRAMES = 4  # fewer pre-impact frames than this: keep the first frame (a fit of 3 unknowns per axis needs >= 4)


def first_frame(toss: Toss) -> tuple[RotationMatrix, np.ndarray, np.ndarray, np.ndarray]:
    """(R_WB, p_WB (3,) [m], w_WB_W (3,) [rad/s], v_WB_W (3,) [m/s]) of frame 0 as recorded;
    the stored angular velocity is in the body frame B and is rotated by R_WB."""
    R_WB = RotationMatrix(Quaternion(toss.q_WB[0]))
    return R_WB, toss.p_WB[0].copy(), R_WB.matrix() @ toss.w_WB_B[0], toss.v_WB[0].copy()


def flight_frames(toss: Toss, table_height: float) -> int:
    """Number of leading frames whose lowest cube corner is more than FLIGHT_CLEARANCE above
    the table top at z = table_height [m]."""
    half = CUBE_WIDTH / 2
    for k, (q, p) in enumerate(zip(toss.q_WB, toss.p_WB)):
        R = RotationMatrix(Quaternion(q)).matrix()
        lowest = p[2] - half * np.abs(R[2]).sum()  # z of the lowest corner [m]
        if lowest < table_height + FLIGHT_CLEARANCE:
            return k
    return len(toss)


def flight_fit(toss: Toss, table_height: float) -> tuple[RotationMatrix, np.ndarray, np.ndarray, np.ndarray]:
    """Like `first_frame`, but fitted to the pre-impact frames (falls back to the first
    frame when fewer than MIN_FLIGHT_FRAMES of them are recorded)."""
    n = flight_frames(toss, table_height)
    if n < MIN_FLIGHT_FRAMES:
        return first_frame(toss)
    t = toss.t[:n]  # (n,) [s]
    # centre: p(t) = p0 + v0 t - g t^2 / 2 e_z; solve for p0, v0 per axis
    p = toss.p_WB[:n].copy()
    p[:, 2] += 0.5 * GRAVITY * t**2
    A = np.column_stack([np.ones(n), t])  # (n, 2)
    (p0, v0), *_ = np.linalg.lstsq(A, p, rcond=None)
    # orientation: R_k = exp(t_k [w]) exp([a]) R_data(0); the rotation vector of
    # R_k R_data(0)^T is a + t_k w to first order in a (a is mocap noise, a few mrad)
    R_ref = RotationMatrix(Quaternion(toss.q_WB[0]))
    r = np.empty((n, 3))
    for k in range(n):
        aa = RotationMatrix(Quaternion(toss.q_WB[k])).multiply(R_ref.inverse()).ToAngleAxis()
        r[k] = aa.angle() * aa.axis()
    (a, w), *_ = np.linalg.lstsq(A, r, rcond=None)
    angle = float(np.linalg.norm(a))
    R0 = RotationMatrix(AngleAxis(angle, a / angle)).multiply(R_ref) if angle > 0 else R_ref
    return R0, p0, w, v0


def initial_state(toss: Toss, mode: str, table_height: float):
    """(R_WB, p_WB, w_WB_W, v_WB_W) at t = 0 for `mode` (one of INITIAL_STATES)."""
    if mode == "first-frame":
        return first_frame(toss)
    if mode == "flight-fit":
        return flight_fit(toss, table_height)
    raise TestbedError(f"initial state: unknown {mode!r}; expected one of: {', '.join(INITIAL_STATES)}")
