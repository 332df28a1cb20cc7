"""The improved predictor is continuous across A's reflection planes by construction
(encodings.frame_blend): within SYMMETRY_BAND of a plane p_k = 0 its answer is blended
with the same pose answered in the neighbouring octant's frame, both frames weighted
1/2 on the plane. Checked on all three inference paths (numpy reference, native core,
ONNX export):
- crossing a plane (p_k = +-1e-9 m) the answer moves by no more than rounding; without
  the blend the shipped network jumps by centimetres there (9.2 mm and 0.38 deg on a centred
  40 ft pair, up to 18 cm on the poses below);
- crossing the band's edge nothing jumps either (the weight falls to 0 with zero slope);
- beyond every band the answer is the plain octant-frame pipeline's, bit for bit on the
  numpy path.
Poses: B resting on A (x and y planes, singly and both at once) and B beside A (the z
plane), all pairs of the shipped sizes, small random tilts and yaws (seeded).
"""

from __future__ import annotations

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.model.encodings import SYMMETRY_BAND, canonicalise, features
from learned_contact.predictors.improved import POINT_STEP
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.geometry.boxes import sat_normal
from testbed.geometry.rotations import rotation_from_rpy

SIZES = np.array([CONTAINER_TYPES[t].size for t in ("1CC", "1AA", "1AAA")])
EPS = 1e-9  # [m] half the step across a plane
# Tolerances across a plane, for a step of 2 EPS = 2e-9 m: the answer's slope is O(1)
# (point [m/m], normal [1/m] well below 10), so a continuous answer moves < 2e-8; rounding
# of float64 sums of terms ~10 m is ~1e-14. The ONNX graph's answers are float32: half an
# ulp of a coordinate below 8 m is 2.4e-7 m (of a unit normal 3e-8), so 1e-6 there.
# The un-blended shipped network jumps by a median of 15-22 mm (up to 82 mm, 0.7 deg) across
# x = 0 or y = 0 on these poses and 95 mm across z = 0 (9.2 mm on the 40 ft centred pair).
TOL = {"numpy": (2e-8, 2e-8), "compiled": (2e-8, 2e-8), "onnx": (1e-6, 1e-6)}


def _poses(n: int, seed: int):
    """(p (n, 3) [m], R (n, 3, 3), size_A, size_B (n, 3)): B on A, small tilt and yaw,
    centred within the band on x and y, 1 mm to 2 cm deep; the second half beside A
    (along +y, yaw within 1e-3 rad) with its centre within the band of z = 0."""
    rng = np.random.default_rng(seed)
    a, b = rng.integers(0, 3, n), rng.integers(0, 3, n)
    sA, sB = SIZES[a], SIZES[b]
    side = np.arange(n) >= n // 2
    yaw = np.where(side, 0.02, 1.0) * rng.uniform(-0.05, 0.05, n)  # beside A: a 12 m side turns little
    R = rotation_from_rpy(np.c_[rng.normal(0.0, 2e-3, (n, 2)), yaw])
    depth = rng.uniform(1e-3, 0.02, n)
    p = np.c_[rng.uniform(-SYMMETRY_BAND, SYMMETRY_BAND, (n, 2)), 0.5 * (sA[:, 2] + sB[:, 2]) - depth]
    p[side, 1] = 0.5 * (sA[side, 1] + sB[side, 1]) - depth[side]
    p[side, 2] = rng.uniform(-SYMMETRY_BAND, SYMMETRY_BAND, side.sum())
    return p, R, sA, sB


@pytest.fixture(scope="module")
def paths(tmp_path_factory):
    out = {"numpy": load_predictor(compiled=False).predict, "compiled": load_predictor().predict}
    try:
        from learned_contact.export.onnx_check import onnx_session, run_onnx
        from learned_contact.export.onnx_export import export_onnx
    except ImportError:  # pragma: no cover - the test extra installs onnx
        return out
    session = onnx_session(export_onnx("improved", tmp_path_factory.mktemp("sym") / "improved.onnx"))

    def onnx_predict(p, R, *, size_A, size_B):
        got = run_onnx(session, p, R, size_A, size_B)
        return got["point_A"].astype(float), got["normal_A"].astype(float)

    out["onnx"] = onnx_predict
    return out


def _step(predict, p, R, sA, sB, k, at):
    """Largest (point [m], normal) change between p_k = at - EPS and at + EPS."""
    lo, hi = p.copy(), p.copy()
    lo[:, k], hi[:, k] = at - EPS, at + EPS
    pl, nl = predict(lo, R, size_A=sA, size_B=sB)
    ph, nh = predict(hi, R, size_A=sA, size_B=sB)
    return np.abs(ph - pl).max(), np.abs(nh - nl).max()


@pytest.mark.parametrize("path", ["numpy", "compiled", "onnx"])
def test_no_jump_across_a_plane_nor_at_the_band_edge(paths, path):
    if path not in paths:
        pytest.skip("onnx is not installed")
    predict = paths[path]
    p, R, sA, sB = _poses(300, 2020)
    tol_p, tol_n = TOL[path]
    if path == "onnx":  # the graph sees float32 inputs: give every path the same ones
        p, R, sA, sB = (np.asarray(x, np.float32).astype(float) for x in (p, R, sA, sB))
    stacked, beside = slice(0, 150), slice(150, 300)
    for k, rows in ((0, stacked), (1, stacked), (2, beside), (0, beside)):
        for at in (0.0, SYMMETRY_BAND, -SYMMETRY_BAND):
            dp, dn = _step(predict, p[rows], R[rows], sA[rows], sB[rows], k, at)
            assert dp <= tol_p and dn <= tol_n, f"{path}: plane {k} at {at} m: point {dp:.3g} m, normal {dn:.3g}"
    # on both planes at once (the 4-frame blend): cross x = 0 with y = 0 exactly
    q = p[stacked].copy()
    q[:, 1] = 0.0
    dp, dn = _step(predict, q, R[stacked], sA[stacked], sB[stacked], 0, 0.0)
    assert dp <= tol_p and dn <= tol_n, f"{path}: x = 0 on y = 0: point {dp:.3g} m, normal {dn:.3g}"


def test_the_unblended_network_does_jump():
    """What the blend removes: the octant-frame pipeline alone (predictor's steps without
    frame_blend) jumps by centimetres crossing y = 0 on these poses (median 15 mm, up to
    66 mm; 9.2 mm on a centred 40 ft pair); if this ever stops, the blend is no longer needed."""
    pred = load_predictor(compiled=False)
    p, R, sA, sB = _poses(150, 2020)
    lo, hi = p.copy(), p.copy()
    lo[:, 1], hi[:, 1] = -EPS, EPS
    jumps = np.abs(_plain(pred, hi, R, sA, sB)[0] - _plain(pred, lo, R, sA, sB)[0]).max(axis=1)
    assert np.median(jumps) > 5e-3 and jumps.max() > 3e-2


def _plain(pred, p, R, sA, sB):
    """The octant-frame pipeline without the blend (the predictor before the resting expert)."""
    S, p_c, R_c = canonicalise(p, R)
    x, pe, ne = features(p_c, R_c, 0.5 * sA, 0.5 * sB)
    y = pred.mlp(x)
    normal = S * (ne + y[:, 3:6])
    return S * (pe + POINT_STEP * y[:, :3]), normal / np.linalg.norm(normal, axis=1, keepdims=True)


def test_beyond_the_bands_the_answer_is_unchanged():
    """Where every |p_k| >= SYMMETRY_BAND the blend gives the own frame weight exactly 1:
    the numpy path's learned pipeline (ContactPredictor._learned, which answers where the
    face-on-face quadrature does not) returns the plain pipeline's answer bit for bit."""
    pred = load_predictor(compiled=False)
    p, R, sA, sB = _poses(200, 7)
    out = lambda v: np.where(v >= 0.0, 1.0, -1.0) * (SYMMETRY_BAND + 10.0 * np.abs(v))  # noqa: E731
    p[:100, :2] = out(p[:100, :2])  # on A: off the x and y bands
    p[100:, 0], p[100:, 2] = out(p[100:, 0]), out(p[100:, 2])  # beside A: off the x and z bands
    assert np.all(load_predictor().in_domain(p, R, size_A=sA, size_B=sB))  # no clipping in play
    sat_n, depth, _ = sat_normal(p, R, 0.5 * sA, 0.5 * sB)
    point, normal = pred._learned(p, R, 0.5 * sA, 0.5 * sB, sat_n, depth)
    ref_point, ref_normal = _plain(pred, p, R, sA, sB)
    np.testing.assert_array_equal(point, ref_point)
    np.testing.assert_array_equal(normal, ref_normal)


def test_the_band_is_the_same_on_every_path():
    """The native core holds its own copy of the band (native/src/cc_internal.h)."""
    from learned_contact import compiled

    if not compiled.NATIVE_AVAILABLE:
        pytest.skip("the native core was not built")
    assert compiled.constants()["SYMMETRY_BAND"] == SYMMETRY_BAND


def test_mirror_training_rows_are_the_same_poses_in_the_neighbouring_frames():
    """TrainConfig.mirror: every labelled pose within the band of a plane is added once per
    neighbouring frame the predictor blends in; each added row describes the same physical
    pose (its geometric estimate, mapped back to A's frame, is the own frame's to rounding)
    with its label reflected into that frame."""
    import dataclasses

    from learned_contact.data.labels import make_dataset
    from learned_contact.model.encodings import frame_blend
    from learned_contact.training.datasets import improved_inputs

    ds = make_dataset("stacking", 60, 20_201, progress=False)
    p = ds.p_AB.copy()
    p[:30, 1] = np.linspace(-0.9, 0.9, 30) * SYMMETRY_BAND  # half of them inside the y band
    ds = dataclasses.replace(ds, p_AB=p)
    x0, pe0, _, pc0, _ = improved_inputs(ds)
    x, pe, ne, pc, nc, depth = improved_inputs(ds, mirror=True, with_depth=True)
    extra = [(sigma, np.flatnonzero(coef > 0.0)) for sigma, coef in frame_blend(p)[1:]]
    assert len(x) == len(ds) + sum(len(rows) for _, rows in extra) and len(x) > len(ds) + 25
    np.testing.assert_array_equal(x[:len(ds)], x0)
    np.testing.assert_array_equal(depth[:len(ds)], ds.depth)
    S = np.where(p >= 0.0, 1.0, -1.0)
    at = len(ds)
    for sigma, rows in extra:
        block = slice(at, at + len(rows))
        np.testing.assert_allclose(sigma[rows] * pe[block], S[rows] * pe0[rows], rtol=0, atol=1e-9)
        np.testing.assert_allclose(sigma[rows] * pc[block], ds.cop[rows], rtol=0, atol=1e-12)
        np.testing.assert_allclose(sigma[rows] * nc[block], ds.normal[rows], rtol=0, atol=1e-12)
        at += len(rows)
