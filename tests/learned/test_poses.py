"""learned_contact.predictors.poses states the contract's rotation convention: checked against Drake's own
RollPitchYaw, Quaternion and RigidTransform (the conventions a user's simulator is compared to)."""

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix

from learned_contact.predictors.poses import relative_pose, rotation_from_quaternion, rotation_from_rpy, to_world


def test_roll_pitch_yaw_is_drakes():
    rng = np.random.default_rng(5)
    rpy = rng.uniform(-1.5, 1.5, (20, 3))
    mine = rotation_from_rpy(rpy)
    for row, R in zip(rpy, mine):
        np.testing.assert_allclose(R, RollPitchYaw(*row).ToRotationMatrix().matrix(), atol=1e-14)


def test_quaternions_are_scalar_first_as_drakes():
    rng = np.random.default_rng(6)
    q = rng.normal(size=(20, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    for row, R in zip(q, rotation_from_quaternion(q)):
        np.testing.assert_allclose(R, RotationMatrix(Quaternion(*row)).matrix(), atol=1e-14)


def test_relative_pose_is_X_AW_X_WB_and_back():
    rng = np.random.default_rng(7)
    X_WA = RigidTransform(RollPitchYaw(*rng.uniform(-1, 1, 3)), rng.uniform(-5, 5, 3))
    X_WB = RigidTransform(RollPitchYaw(*rng.uniform(-1, 1, 3)), rng.uniform(-5, 5, 3))
    p_AB, R_AB = relative_pose(X_WA.translation(), X_WA.rotation().matrix(), X_WB.translation(), X_WB.rotation().matrix())
    X_AB = X_WA.inverse() @ X_WB
    np.testing.assert_allclose(p_AB[0], X_AB.translation(), atol=1e-12)
    np.testing.assert_allclose(R_AB[0], X_AB.rotation().matrix(), atol=1e-12)
    point_A, normal_A = np.array([[0.1, 0.2, 1.3]]), np.array([[0.0, 0.0, 1.0]])
    p_W, n_W = to_world(X_WA.translation(), X_WA.rotation().matrix(), point_A, normal_A)
    np.testing.assert_allclose(p_W[0], X_WA @ point_A[0], atol=1e-12)
    np.testing.assert_allclose(n_W[0], X_WA.rotation().matrix() @ normal_A[0], atol=1e-12)
