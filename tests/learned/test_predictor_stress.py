"""The learned predictor under stress: outside its training range it answers within
a documented bound or refuses clearly; near the paper's discontinuities it is continuous;
non-finite input is rejected."""

import numpy as np
import pytest

from learned_contact import PredictorDomainError, PredictorInputError, load_predictor
from learned_contact.predictors.improved import CLIP_MARGIN, DOMAIN_DEPTH
from testbed.bodies.containers import CONTAINER_TYPES

SIZE = np.array(CONTAINER_TYPES["1CC"].size)
SIZE_40 = np.array(CONTAINER_TYPES["1AA"].size)


def _R(roll=0.0, pitch=0.0, yaw=0.0):
    from pydrake.math import RollPitchYaw

    return RollPitchYaw(roll, pitch, yaw).ToRotationMatrix().matrix()


@pytest.fixture(scope="module")
def pred():
    return load_predictor()


OUT_OF_RANGE = {
    "separated 10 m above": ([0.0, 0.0, 12.6], _R()),
    "separated 0.5 m beside": ([0.0, 2.95, 0.0], _R(0.2, 0.1, 0.3)),
    "far away, tumbled": ([30.0, 5.0, -4.0], _R(0.3, 0.2, 1.0)),
    "deep: 2.4 m of 2.6 m": ([0.0, 0.0, 0.2], _R()),
    "centre inside A": ([0.1, 0.1, 0.0], _R(0.5, 0.1, 0.2)),
}


@pytest.mark.parametrize("case", sorted(OUT_OF_RANGE))
def test_out_of_range_poses_get_bounded_answers_or_a_clear_refusal(pred, case):
    p, R = OUT_OF_RANGE[case]
    p, R = np.array([p]), np.array([R])
    assert not pred.in_domain(p, R, size_A=SIZE, size_B=SIZE)[0]
    point, normal = pred.predict(p, R, size_A=SIZE, size_B=SIZE)
    assert np.all(np.isfinite(point)) and np.all(np.isfinite(normal))
    assert np.linalg.norm(normal[0]) == pytest.approx(1.0, abs=1e-9)
    assert np.all(np.abs(point[0]) <= 0.5 * SIZE + CLIP_MARGIN + 1e-12)  # the documented bound
    with pytest.raises(PredictorDomainError, match="outside the trained range"):
        pred.predict(p, R, size_A=SIZE, size_B=SIZE, outside="raise")


def test_in_range_answers_do_not_depend_on_the_policy(pred):
    p = np.array([[0.3, 0.1, 2.58], [1.0, -0.2, 2.575]])
    R = np.array([_R(0.002, -0.003, 0.3), _R(0.0, 0.002, -1.0)])
    assert np.all(pred.in_domain(p, R, size_A=SIZE, size_B=SIZE))
    a = pred.predict(p, R, size_A=SIZE, size_B=SIZE)
    b = pred.predict(p, R, size_A=SIZE, size_B=SIZE, outside="raise")
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert DOMAIN_DEPTH[0] < 0 < 0.03 < DOMAIN_DEPTH[1]


@pytest.mark.parametrize("size", [[6.0, 2.4, 2.6], [2.0, 2.0, 2.0], [12.192, 2.438, 9.0]])
def test_sizes_it_was_not_trained_on_are_refused(pred, size):
    with pytest.raises(PredictorInputError, match="not a supported container size"):
        pred.predict(np.array([[0.0, 0.0, 2.58]]), np.array([_R()]), size_A=size, size_B=SIZE)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_input_is_rejected(pred, bad):
    p = np.array([[0.0, 0.0, 2.58]])
    with pytest.raises(PredictorInputError, match="finite"):
        pred.predict(np.where(True, bad, p), np.array([_R()]), size_A=SIZE, size_B=SIZE)
    R = np.array([_R()])
    R[0, 1, 2] = bad
    with pytest.raises(PredictorInputError, match="finite"):
        pred.predict(p, R, size_A=SIZE, size_B=SIZE)


@pytest.mark.parametrize("axis", ["roll", "pitch", "yaw"])
@pytest.mark.parametrize("p_AB", [[0.5, 0.3, 2.58], [-1.2, 0.4, 2.57], [0.0, 0.0, 2.585]])
def test_continuous_across_euler_sign_changes(pred, axis, p_AB):
    """The paper's discontinuities: a sign change of an Euler angle switches the contact
    vertex in its encoding (a jump of metres). Across +-1e-6 rad the answer may move by what
    the physics moves it plus 1 mm, and by 0.01 deg: a tilt theta of a shallow face-on-face
    contact shifts the pressure-weighted centre by L^2 theta / (12 d) (the depth varies
    linearly across the face: L the face's extent along the lever, d the mean overlap), 0.51 mm
    at 1e-6 rad for a 20 ft box 6 mm deep, which the predictor (exact on level faces) follows."""
    eps = 1e-6
    angles = {"roll": (eps, 0, 0), "pitch": (0, eps, 0), "yaw": (0, 0, eps)}[axis]
    R = np.array([_R(*angles), _R(*(-np.array(angles)))])
    p = np.array([p_AB, p_AB])
    point, normal = pred.predict(p, R, size_A=SIZE, size_B=SIZE)
    lever = {"roll": SIZE[1], "pitch": SIZE[0], "yaw": 0.0}[axis]  # [m] the face's extent the tilt acts along
    depth = SIZE[2] - p_AB[2]  # [m] B rests on A: overlap of the two half heights
    physical = 2 * lever**2 * eps / (12 * depth)  # [m] the centre of pressure's move from -eps to +eps
    assert np.linalg.norm(point[0] - point[1]) < 1e-3 + physical
    assert np.degrees(np.arccos(np.clip(normal[0] @ normal[1], -1, 1))) < 0.01


def test_continuous_across_the_octant_reflection(pred):
    """The predictor reflects poses into A's positive octant: crossing x = 0 or y = 0
    (a 40 ft box centred on a 40 ft box, offsets +-1e-6 m) the answer may jump by no
    more than the predictor's typical error (the gates' medians: 1 cm, 0.1 deg), or
    a simulator using it would see the force direction flicker on the planes. (Without
    the octant-plane blend, encodings.frame_blend, the shipped network jumped 9.2 mm and
    0.38 deg crossing y = 0; tests/learned/test_octant_symmetry.py checks the blend to rounding.)"""
    base = np.array([0.0, 0.0, 2.58])
    for k in (0, 1):
        p = np.array([base, base])
        p[0, k], p[1, k] = 1e-6, -1e-6
        point, normal = pred.predict(p, np.array([_R(), _R()]), size_A=SIZE_40, size_B=SIZE_40)
        assert np.linalg.norm(point[0] - point[1]) < 1e-2
        assert normal[0] @ normal[1] > np.cos(np.radians(0.1))
