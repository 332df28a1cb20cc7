"""Rotations in numpy, batched: quaternions (w, x, y, z) and matrices, roll-pitch-yaw,
uniform random rotations, the angle between two orientations. Shapes: (..., 4) quaternions,
(..., 3, 3) matrices; angles in radians unless a name says deg.
"""

from __future__ import annotations

import numpy as np


def quaternion_from_rotation(R) -> np.ndarray:
    """(..., 3, 3) rotation matrices -> (..., 4) unit quaternions (w, x, y, z), w >= 0 (the
    sign RotationMatrix.ToQuaternion returns); Shepperd's method, vectorised: one call
    for a whole run's rows instead of a binding call per body per step."""
    R = np.asarray(R, dtype=float)
    trace = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2]
    cand = np.stack([trace, R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]], axis=-1)
    k = np.argmax(cand, axis=-1)  # the largest of 4w^2 - 1, 4x^2 - 1, ... (well conditioned)
    s = 2.0 * np.sqrt(np.maximum(1.0 + 2.0 * np.take_along_axis(cand, k[..., None], -1)[..., 0] - trace, 1e-300))
    d21, d02, d10 = R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]
    s01, s02, s12 = R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1]
    options = np.stack([np.stack([0.25 * s, d21 / s, d02 / s, d10 / s], -1),
                        np.stack([d21 / s, 0.25 * s, s01 / s, s02 / s], -1),
                        np.stack([d02 / s, s01 / s, 0.25 * s, s12 / s], -1),
                        np.stack([d10 / s, s02 / s, s12 / s, 0.25 * s], -1)], -2)  # (..., 4 cases, 4)
    q = np.take_along_axis(options, k[..., None, None], -2)[..., 0, :]
    q = q * np.where(q[..., :1] < 0.0, -1.0, 1.0)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def rotation_from_quaternion(q) -> np.ndarray:
    """(..., 4) unit quaternions (w, x, y, z) -> (..., 3, 3) rotation matrices."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - w * z)
    R[..., 0, 2] = 2 * (x * z + w * y)
    R[..., 1, 0] = 2 * (x * y + w * z)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - w * x)
    R[..., 2, 0] = 2 * (x * z - w * y)
    R[..., 2, 1] = 2 * (y * z + w * x)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def rotation_from_rpy(rpy) -> np.ndarray:
    """(n, 3, 3) rotation matrices from (n, 3) roll-pitch-yaw [rad] (R = Rz(y) Ry(p) Rx(r))."""
    rpy = np.atleast_2d(np.asarray(rpy, dtype=float))
    r, p, y = rpy[:, 0], rpy[:, 1], rpy[:, 2]
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    R = np.empty((len(rpy), 3, 3))
    R[:, 0, 0] = cy * cp
    R[:, 0, 1] = cy * sp * sr - sy * cr
    R[:, 0, 2] = cy * sp * cr + sy * sr
    R[:, 1, 0] = sy * cp
    R[:, 1, 1] = sy * sp * sr + cy * cr
    R[:, 1, 2] = sy * sp * cr - cy * sr
    R[:, 2, 0] = -sp
    R[:, 2, 1] = cp * sr
    R[:, 2, 2] = cp * cr
    return R


def rpy_from_rotation(R) -> np.ndarray:
    """(n, 3) roll-pitch-yaw [rad] of (n, 3, 3) rotations (inverse of rotation_from_rpy)."""
    R = np.asarray(R, dtype=float)
    pitch = np.arcsin(np.clip(-R[:, 2, 0], -1.0, 1.0))
    roll = np.arctan2(R[:, 2, 1], R[:, 2, 2])
    yaw = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    return np.stack([roll, pitch, yaw], axis=1)


def random_rotations(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 3, 3) rotations uniform on SO(3) (from uniform unit quaternions)."""
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return rotation_from_quaternion(q)


def angle_between(a, b) -> np.ndarray:
    """(...,) angle [rad] between vectors a and b (..., 3), from atan2(|a x b|, a . b).

    Well conditioned at every angle: a last-bit change of a or b moves it by about one ulp
    of 1 (2.2e-16 rad) whatever the angle, where arccos(a . b) near a dot product of 1 turns
    the same change into about eps / angle (a millionfold more at 1e-5 deg; docs/testing.md,
    "Numerics pinned to what is stable")."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


def angle_between_quaternions_deg(q1, q2) -> np.ndarray:
    """(...,) angle [deg] of the rotation taking unit quaternions q1 to q2 (..., 4) (w, x, y, z),
    sign-free (q and -q are the same orientation): 2 atan2(|v|, |w|) of q1* q2, well conditioned
    at small angles as angle_between is."""
    q1, q2 = np.asarray(q1, dtype=float), np.asarray(q2, dtype=float)
    w = np.abs(np.sum(q1 * q2, axis=-1))  # the scalar part of q1* q2 (its sign dropped)
    v = q1[..., :1] * q2[..., 1:] - q2[..., :1] * q1[..., 1:] - np.cross(q1[..., 1:], q2[..., 1:])
    return np.degrees(2.0 * np.arctan2(np.linalg.norm(v, axis=-1), w))
