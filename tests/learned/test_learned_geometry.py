"""Fixed-cost geometry, encodings and sampling of learned_contact (no Drake needed)."""

import numpy as np
import pytest

from learned_contact.data.sampling import sample
from learned_contact.errors import DatasetError
from learned_contact.model.encodings import canonicalise, from_spherical, paper_outputs, spherical
from learned_contact.model.prior import contact_type, patch_estimate
from testbed.geometry.boxes import sat_normal
from testbed.geometry.rotations import random_rotations, rotation_from_rpy, rpy_from_rotation

H_A = np.array([6.096, 1.219, 1.2955])  # 1AA half extents [m]
H_B = np.array([3.029, 1.219, 1.2955])  # 1CC


def test_rpy_round_trip():
    rng = np.random.default_rng(0)
    rpy = rng.uniform([-3, -1.5, -3], [3, 1.5, 3], size=(50, 3))
    np.testing.assert_allclose(rpy_from_rotation(rotation_from_rpy(rpy)), rpy, atol=1e-9)
    R = random_rotations(rng, 20)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0)


def test_aligned_offset_stack_patch_is_overlap_centroid():
    # B (20 ft) offset 5 m along x on A (40 ft), 2 cm deep: the overlap is x in [1.967, 6.096]
    p = np.array([[5.0, 0.0, H_A[2] + H_B[2] - 0.02]])
    point, normal, depth, _, _, _ = patch_estimate(p, np.eye(3)[None], H_A[None], H_B[None])
    np.testing.assert_allclose(normal[0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(depth, 0.02, atol=1e-12)
    np.testing.assert_allclose(point[0], [(5.0 - H_B[0] + H_A[0]) / 2, 0.0, H_A[2] - 0.01], atol=1e-9)


def test_canonicalise_and_spherical_round_trip():
    rng = np.random.default_rng(1)
    p = rng.normal(size=(100, 3))
    R = random_rotations(rng, 100)
    S, p_c, R_c = canonicalise(p, R)
    assert np.all(p_c >= 0)
    np.testing.assert_allclose(S * p_c, p)
    # the same box: columns equal up to sign
    np.testing.assert_allclose(np.abs(S[:, :, None] * R_c), np.abs(R), atol=1e-12)
    v = rng.normal(size=(100, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    np.testing.assert_allclose(from_spherical(spherical(v)), v, atol=1e-12)
    # canonical-octant directions are far from the poles and the azimuth seam
    out = paper_outputs(np.abs(v), np.abs(v), np.ones_like(v))
    assert np.all(np.abs(out[:, 1]) <= np.pi / 4 + 1e-9) and np.all(np.abs(out[:, 0]) < np.pi * 0.7)


def test_sampling_is_seeded_and_within_ranges():
    a, b = sample("stacking", 500, 3), sample("stacking", 500, 3)
    np.testing.assert_array_equal(a.R_AB, b.R_AB)
    assert not np.array_equal(a.R_AB, sample("stacking", 500, 4).R_AB)
    tilt = np.degrees(np.arccos(np.clip(a.R_AB[:, 2, 2], -1, 1)))
    assert tilt.max() <= 5.0 * np.sqrt(2) + 1e-9
    assert np.mean(tilt < 0.1) > 0.2  # near-parallel cases are present
    assert np.all((a.depth >= 0) & (a.depth <= 0.03))
    with pytest.raises(DatasetError, match="expected one of"):
        sample("sideways", 10, 0)


def test_resting_sampling_covers_its_ranges_and_keeps_the_others_stream():
    """The resting distribution: log-uniform overlap 5 um-0.5 mm, roll/pitch within
    0.05 deg, yaw within 2 deg, offsets up to 0.4 m, every ordered type pair."""
    from testbed.geometry.rotations import rpy_from_rotation

    r = sample("resting", 4000, 3)
    assert np.all((r.depth >= 5e-6) & (r.depth <= 5e-4))
    # log-uniform: the decade 5-50 um holds half the poses (binomial sd 0.8 %, bound 4 sd)
    assert abs(np.mean(r.depth < 5e-5) - 0.5) < 0.032
    rpy = np.degrees(rpy_from_rotation(r.R_AB))
    assert np.all(np.abs(rpy[:, :2]) <= 0.05 + 1e-9) and np.all(np.abs(rpy[:, 2]) <= 2.0 + 1e-9)
    assert np.all(np.abs(r.base[:, :2]) <= 0.4) and np.all(r.base[:, 2] == 0.0)
    np.testing.assert_array_equal(r.direction, np.tile([0.0, 0.0, 1.0], (4000, 1)))
    assert len(np.unique(3 * r.type_a + r.type_b)) == 9  # all 9 ordered type pairs
    with pytest.raises(DatasetError, match="fixed ranges"):
        sample("resting", 10, 0, max_depth=0.01)


def test_contact_type_tags_simple_cases():
    R0 = np.eye(3)[None]
    face = contact_type(np.array([[0.0, 0.0, H_A[2] + H_B[2] - 0.01]]), R0, H_A, H_B)
    # B's corner down (tilted 30 deg about x and y) into A's top face
    R = rotation_from_rpy(np.array([[np.radians(30), np.radians(35), 0.3]]))
    n, depth, _ = sat_normal(np.array([[0.0, 0.0, 5.0]]), R, H_A, H_B)
    lowest = np.min((R[0] @ (np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * H_B).T)[2])
    p = np.array([[0.0, 0.0, H_A[2] - lowest - 0.01]])
    vertex = contact_type(p, R, H_A, H_B)
    assert face[0] == 3 and vertex[0] == 0


def test_patch_estimate_single_rows_match_batched():
    # the few-pairs path (plain Python clipping) and the vectorised path agree
    rng = np.random.default_rng(2)
    n = 60
    R = random_rotations(rng, n)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    p = u * rng.uniform(2.0, 4.0, size=(n, 1))
    hA, hB = np.tile(H_A, (n, 1)), np.tile(H_B, (n, 1))
    batched = patch_estimate(p, R, hA, hB)
    for i in range(n):
        single = patch_estimate(p[i:i + 1], R[i:i + 1], hA[i:i + 1], hB[i:i + 1])
        for a, b in zip(batched, single):
            np.testing.assert_allclose(a[i:i + 1], b, atol=1e-12)
