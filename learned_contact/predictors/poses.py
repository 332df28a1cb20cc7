"""The model contract's pose inputs from what a simulator holds: world poses, roll-pitch-yaw
or quaternions.

Every predictor answers B's pose in A's frame: p_AB (n, 3) [m] is B's centre expressed in A
(A's origin at its box's centre, axes along its edges) and R_AB (n, 3, 3) the rotation
matrix whose columns are B's axes expressed in A (a vector v_B in B's frame is R_AB @ v_B in
A's). There is no Euler convention in the contract; where a simulator holds angles, these
helpers state theirs:

- roll-pitch-yaw [rad]: R = Rz(yaw) Ry(pitch) Rx(roll), rotations about the fixed axes x, then
  y, then z (Drake's RollPitchYaw, ROS's RPY, Eigen's AngleAxis product z*y*x);
- quaternions (w, x, y, z), scalar first (Drake, MuJoCo); a quaternion stored scalar last
  (x, y, z, w: SciPy, Eigen's coeffs(), Unity) must be reordered first.

    p_AB, R_AB = relative_pose(p_WA, R_WA, p_WB, R_WB)       # from two world poses
    R = rotation_from_rpy(np.array([[roll, pitch, yaw]]))   # (1, 3, 3)
    R = rotation_from_quaternion(np.array([[w, x, y, z]]))  # (1, 3, 3)

The outputs come back in A too: point_A (n, 3) [m], normal_A (n, 3) unit from A into B; in
the world, p_W = p_WA + R_WA @ point_A and n_W = R_WA @ normal_A (`to_world`).
"""

from __future__ import annotations

import numpy as np

from testbed.geometry.rotations import rotation_from_quaternion, rotation_from_rpy


def relative_pose(p_WA, R_WA, p_WB, R_WB) -> tuple[np.ndarray, np.ndarray]:
    """(p_AB (n, 3) [m], R_AB (n, 3, 3)) from the world poses of A and B: p_WA, p_WB (n, 3)
    [m] the boxes' centres in the world frame W, R_WA, R_WB (n, 3, 3) their orientations;
    p_AB = R_WA^T (p_WB - p_WA), R_AB = R_WA^T R_WB. Single poses ((3,), (3, 3)) are
    answered as (1, 3) and (1, 3, 3)."""
    p_WA, p_WB = (np.asarray(v, dtype=float).reshape(-1, 3) for v in (p_WA, p_WB))
    R_WA, R_WB = (np.asarray(v, dtype=float).reshape(-1, 3, 3) for v in (R_WA, R_WB))
    R_AW = np.swapaxes(R_WA, 1, 2)
    return np.einsum("nij,nj->ni", R_AW, p_WB - p_WA), R_AW @ R_WB


def to_world(p_WA, R_WA, point_A, normal_A) -> tuple[np.ndarray, np.ndarray]:
    """(p_W (n, 3) [m], n_W (n, 3) unit): a predictor's answer in A expressed in the world."""
    p_WA = np.asarray(p_WA, dtype=float).reshape(-1, 3)
    R_WA = np.asarray(R_WA, dtype=float).reshape(-1, 3, 3)
    point_A = np.asarray(point_A, dtype=float).reshape(-1, 3)
    normal_A = np.asarray(normal_A, dtype=float).reshape(-1, 3)
    return p_WA + np.einsum("nij,nj->ni", R_WA, point_A), np.einsum("nij,nj->ni", R_WA, normal_A)


__all__ = ["relative_pose", "rotation_from_quaternion", "rotation_from_rpy", "to_world"]
