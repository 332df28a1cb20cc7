"""Exact where the geometry is exact (issue 30): where B's face is parallel to A's (a level
face on a face: the overlap is a slab of one depth) the improved predictor answers its
geometric estimate, the centre of the overlap rectangle with A's face normal, on all three
paths (numpy, numba, ONNX), at any yaw and offset, and hands over to the learned answer
continuously as the tilt grows (learned_contact.model.expert: the slab scale)."""

from __future__ import annotations

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.compiled import kernels
from learned_contact.data.labels import make_dataset
from learned_contact.evaluation.gates import GeometricPrior
from learned_contact.evaluation.metrics import point_normal_errors
from learned_contact.export.onnx_export import export_onnx, probe_poses
from learned_contact.model.encodings import features, reflect
from learned_contact.model.expert import R_SLAB, slab_axes, slab_ratio
from learned_contact.sources import load_predictor as load_source
from testbed.geometry.boxes import sat_normal
from testbed.geometry.rotations import rotation_from_rpy

SIZE_20FT, SIZE_40FT = np.array([6.058, 2.438, 2.591]), np.array([12.192, 2.438, 2.591])


@pytest.fixture(scope="module")
def paths():
    """{path name: predictor}: the shipped improved predictor on numpy and numba."""
    return {"numpy": load_predictor(compiled=False), "compiled": load_predictor()}


def _onnx(tmp_path_factory):
    """The shipped improved predictor exported to ONNX and loaded back (skips without onnx)."""
    pytest.importorskip("onnx")
    pytest.importorskip("onnxruntime")
    path = tmp_path_factory.mktemp("onnx") / "improved.onnx"
    export_onnx("improved", path)
    return load_source(str(path))


def _level_poses(n: int, seed: int):
    """n exactly level poses (roll = pitch = 0) of sampling's "resting_wider" ranges, placed
    by the separating-axis depth (no Drake): (p (n, 3), R (n, 3, 3), size_A, size_B)."""
    p, R, sA, sB = probe_poses(4 * n, seed, "resting_wider")
    level = np.flatnonzero((R[:, 0, 2] == 0.0) & (R[:, 1, 2] == 0.0))[:n]
    return p[level], R[level], sA[level], sB[level]


def test_the_compiled_slab_constant_is_the_experts():
    assert kernels.R_SLAB == R_SLAB


def test_level_face_on_face_is_answered_by_the_prior_at_any_yaw_offset_and_face(paths):
    """Level resting poses of the wider set, the same rotated to any yaw (30, 90, 137 deg:
    beyond any expert's gate), and boxes beside A (B's x along A's y, level in A's z,
    touching A's +-y face): numpy and compiled answer the prior's point and normal to
    rounding (1e-12 m: within 2 cm of A's planes the octant frames' answers, each the
    prior's, are summed with blend weights); the main network alone moves the level resting points by
    centimetres (so this test fails without the construction)."""
    prior = GeometricPrior()
    p, R, sA, sB = _level_poses(300, 71)
    poses = [(p, R, sA, sB)]
    for yaw in (30.0, 90.0, 137.0):
        Rz = rotation_from_rpy(np.radians([[0.0, 0.0, yaw]]))
        poses.append((p, np.broadcast_to(Rz, R.shape).copy(), sA, sB))
    # beside A: B rotated 90 deg about z, its centre out along A's +-y, overlapping by 0.2 mm
    Rb = rotation_from_rpy(np.radians([[0.0, 0.0, 90.0]]))[0]
    n = 50
    rng = np.random.default_rng(72)
    side = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    reach = 0.5 * (SIZE_20FT[1] + SIZE_20FT[0])  # A's half width + B's half length along A's y
    pb = np.c_[rng.uniform(-2.0, 2.0, n), side * (reach - 2e-4), rng.uniform(-0.3, 0.3, n)]
    poses.append((pb, np.broadcast_to(Rb, (n, 3, 3)).copy(), np.tile(SIZE_40FT, (n, 1)), np.tile(SIZE_20FT, (n, 1))))
    for p, R, sA, sB in poses:
        want = prior.predict(p, R, size_A=sA, size_B=sB)
        for name, pred in paths.items():
            got = pred.predict(p, R, size_A=sA, size_B=sB)
            np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-12, err_msg=name)
            np.testing.assert_allclose(got[1], want[1], rtol=0, atol=1e-15, err_msg=name)
    p, R, sA, sB = poses[0]
    sigma = np.where(p >= 0.0, 1.0, -1.0)
    p_c, R_c = reflect(sigma, p, R)
    x, _, _ = features(p_c, R_c, 0.5 * sA, 0.5 * sB)
    moved = 0.5 * np.linalg.norm(paths["numpy"].mlp(x)[:, :3], axis=1)  # [m] what the network's correction alone would do
    assert np.median(moved) > 0.01


def test_on_level_resting_poses_every_path_is_within_0_01_mm_of_drake(paths, tmp_path_factory):
    """Issue 30's target: on exactly level poses of the wider resting set (yaw within 6 deg,
    offsets within 3 m along A's length and 0.6 m across, 20 ft on 40 ft and 40 ft on 20 ft
    included; sampling seed 3003, not used in training), labelled by Drake, the point error
    is <= 0.01 mm at the median and the p95 on numpy, compiled and ONNX (measured on seeds
    3001 and 3002, 1000 poses each: 0.0002 mm median, 0.004-0.005 mm p95 on all three; the
    shipped predictor before: 31-33 mm median, 123-140 mm p95)."""
    ds = make_dataset("resting_wider", 300, 3003, progress=False, use_cache=False)
    level = (ds.R_AB[:, 0, 2] == 0.0) & (ds.R_AB[:, 1, 2] == 0.0)
    assert level.sum() > 100
    ds = ds.subset(np.flatnonzero(level))
    models = dict(paths, onnx=_onnx(tmp_path_factory))
    for name, pred in models.items():
        e_point, e_normal = point_normal_errors(*pred.predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B)[:2],
                                                ds)
        assert np.median(e_point) <= 1e-5 and np.percentile(e_point, 95) <= 1e-5, name
        assert np.percentile(e_normal, 95) <= 0.01, name


def test_the_slab_ratio_is_zero_exactly_where_b_is_parallel_and_names_the_faces_that_meet():
    """r = 0 on level poses (any yaw) and on a box beside A; r > 0 as soon as B tilts by
    1e-9 deg; slab_axes names A's z and B's z on a stack and A's y and B's x beside A."""
    p, R, sA, sB = _level_poses(50, 73)
    sigma = np.where(p >= 0.0, 1.0, -1.0)
    p_c, R_c = reflect(sigma, p, R)
    _, _, _, overlap = features(p_c, R_c, 0.5 * sA, 0.5 * sB, with_overlap=True)
    depth = sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1]
    k, j = slab_axes(R_c, overlap)
    assert np.all(k == 2) and np.all(j == 2)
    np.testing.assert_array_equal(slab_ratio(R_c, 0.5 * sA, 0.5 * sB, depth, (k, j)), 0.0)
    R_t = rotation_from_rpy(np.radians([[1e-9, 0.0, 0.0]]))[0] @ R_c[0]
    assert slab_ratio(R_t[None], 0.5 * sA[:1], 0.5 * sB[:1], depth[:1], (k[:1], j[:1]))[0] > 0.0
    Rb = rotation_from_rpy(np.radians([[0.0, 0.0, 90.0]]))
    pb = np.array([[0.5, 0.5 * (SIZE_40FT[1] + SIZE_20FT[0]) - 2e-4, 0.1]])
    p_c, R_c = reflect(np.ones((1, 3)), pb, Rb)
    _, _, _, overlap = features(p_c, R_c, 0.5 * SIZE_40FT[None], 0.5 * SIZE_20FT[None], with_overlap=True)
    k, j = slab_axes(R_c, overlap)
    assert (k[0], j[0]) == (1, 0)


# inside the expert's gate (its correction there is small: measured 0.04 mm), and where the main
# network answers (B's centre 2 m off A's)
@pytest.mark.parametrize("x, min_gap", [(0.1, 1e-5), (2.0, 1e-4)])
def test_the_hand_over_from_exact_to_learned_is_continuous(paths, x, min_gap):
    """A 20 ft box on a 40 ft one, 0.1 mm deep, rolled from 0 to the tilt where r reaches
    2 R_SLAB in 400 steps: the answer starts at the prior's and leaves it by the
    networks' correction (more than min_gap [m] here, so a switch would show as one step
    of about that size), and no step moves it by more than 10 % of the largest
    correction on the path (smoothstep in r, then the correction's own slope with the
    tilt), on numpy and compiled alike."""
    depth, h_y = 1e-4, 0.5 * SIZE_20FT[1]
    roll_end = np.degrees(np.arctan(2.0 * R_SLAB * depth / (2.0 * h_y)))
    rolls = np.linspace(0.0, roll_end, 401)
    R = rotation_from_rpy(np.radians(np.c_[rolls, np.zeros_like(rolls), np.full_like(rolls, 1.0)]))
    p = np.tile([x, 0.05, 0.5 * (SIZE_40FT[2] + SIZE_20FT[2])], (len(rolls), 1))
    sA, sB = np.tile(SIZE_40FT, (len(rolls), 1)), np.tile(SIZE_20FT, (len(rolls), 1))
    p[:, 2] -= depth - sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1]  # every pose 0.1 mm deep
    prior = GeometricPrior().predict(p, R, size_A=sA, size_B=sB)[0]
    for name, pred in paths.items():
        point = pred.predict(p, R, size_A=sA, size_B=sB)[0]
        np.testing.assert_allclose(point[0], prior[0], rtol=0, atol=1e-12)
        correction = np.linalg.norm(point - prior, axis=1)
        assert correction.max() > min_gap, name
        steps = np.linalg.norm(np.diff(point - prior, axis=0), axis=1)
        assert steps.max() < 0.1 * correction.max(), name
