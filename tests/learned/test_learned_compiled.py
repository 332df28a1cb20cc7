"""The compiled inference path (the native core, learned_contact.compiled) against the numpy
reference.

Both paths run the same pipeline (canonicalisation, geometric estimate, features, MLP,
decoding, reflection); they differ only in the order of a few floating-point sums and in
the networks' tanh, so they must agree to 1e-12 (m for points, unit-vector components for
normals) on thousands of held-out poses: poses drawn from the samplers with seeds the
training never uses, placed at their separating-axis depth, plus the domain edges (depth
at the DOMAIN_DEPTH bounds, separated, exact face-on-face, exact 90-degree yaw, edge-on-edge
crossings, poses on A's symmetry planes). 1e-12 is far above rounding (~1e-15 m) and far
below any error that matters (the predictors' errors are ~1e-4 m and more), so a
disagreement is a bug, not noise. tests/learned/test_native_core.py holds the same on
the accuracy gates' pose sets and on random poses.
"""

import numpy as np
import pytest

from learned_contact import PredictorInputError, load_predictor
from learned_contact.compiled import NATIVE_AVAILABLE
from learned_contact.data.sampling import sample
from learned_contact.interface import DOMAIN_DEPTH
from testbed.geometry.boxes import sat_normal
from testbed.geometry.rotations import rotation_from_rpy

TOL = 1e-12  # [m] / [-]: see the module docstring
pytestmark = pytest.mark.skipif(not NATIVE_AVAILABLE, reason="the native core was not built")
HELD_OUT_SEED = 987  # sampling seeds used by training: 10 * seed + 1, 2; gates: + 5, 6


def _place(p0, direction, R, hA, hB, depth):
    """p_AB = p0 + t * direction with separating-axis depth `depth` (n,) [m] (bisection on t)."""
    lo, hi = np.zeros(len(p0)), np.full(len(p0), 40.0)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        d = sat_normal(p0 + mid[:, None] * direction, R, hA, hB)[1]
        deeper = d > depth
        lo, hi = np.where(deeper, mid, lo), np.where(deeper, hi, mid)
    return p0 + hi[:, None] * direction


def _held_out(n=1500):
    poses = []
    for k, dist in enumerate(("stacking", "general")):
        s = sample(dist, n, HELD_OUT_SEED + k)
        size_A, size_B = s.sizes()
        depth = np.random.default_rng(k).uniform(-0.02, 0.06, n)  # across and beyond DOMAIN_DEPTH
        d = s.direction / np.linalg.norm(s.direction, axis=1, keepdims=True)
        p = _place(s.base, d, s.R_AB, 0.5 * size_A, 0.5 * size_B, depth)
        poses.append((p, s.R_AB, size_A, size_B))
    return [np.concatenate(x) for x in zip(*poses)]


def _rz(yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _edges():
    """Domain-edge poses (n, 3), (n, 3, 3) for two 20 ft boxes and their names."""
    h = 0.5 * np.array([6.058, 2.438, 2.591])
    top = 2 * h[2]
    quarter = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # exact 90 deg yaw
    cases = {
        "face-on-face exact": ([0.0, 0.0, top - 0.01], np.eye(3)),
        "face-on-face offset": ([1.3, -0.4, top - 0.02], np.eye(3)),
        "face-on-face on a symmetry plane": ([0.0, 0.3, top - 0.005], np.eye(3)),
        "face-on-face, upside down": ([0.5, 0.2, -(top - 0.01)], np.diag([1.0, -1.0, -1.0])),
        "90 deg yaw exact": ([0.0, 0.0, top - 0.01], quarter),
        "90 deg yaw, offset": ([2.0, 0.5, top - 0.02], quarter),
        "180 deg yaw": ([0.4, 0.1, top - 0.01], np.diag([-1.0, -1.0, 1.0])),
        "separated 1 m": ([0.0, 0.0, top + 1.0], np.eye(3)),
        "separated, tumbled": ([8.0, 3.0, -2.0], rotation_from_rpy([[0.3, 0.2, 1.0]])[0]),
        "deep": ([0.0, 0.0, 0.3], np.eye(3)),
        "centre inside A": ([0.1, 0.1, 0.0], rotation_from_rpy([[0.5, 0.1, 0.2]])[0]),
        "side by side": ([0.0, 2 * h[1] - 0.01, 0.0], np.eye(3)),
        "end to end": ([2 * h[0] - 0.01, 0.0, 0.0], _rz(np.pi)),
    }
    # edge on edge: A's top edge along x crossed by B's long edge along (0, 1, -1)/sqrt(2),
    # B turned about that edge so that both its faces at the edge lean away from the
    # normal n = (0, 1, 1)/sqrt(2); the edges overlap by dz along n
    n = np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0)
    u = np.array([-1.0, 0.0, 0.0])
    b_x = np.cross(u, n)
    R_edge = np.stack([b_x, (u + n) / np.sqrt(2.0), (n - u) / np.sqrt(2.0)], axis=1)
    for k, dz in enumerate((0.005, 0.02)):
        corner = np.array([1.0, h[1], h[2]]) - dz * n
        cases[f"edge on edge {k}"] = (corner + R_edge @ np.array([0.0, h[1], h[2]]), R_edge)
    # depth exactly at (and a hair around) the DOMAIN_DEPTH bounds, stacked and tilted
    R_tilt = rotation_from_rpy([[0.01, -0.02, 0.7]])[0]
    for bound in DOMAIN_DEPTH:
        for eps in (-1e-7, 0.0, 1e-7):
            for name, R in (("aligned", np.eye(3)), ("tilted", R_tilt)):
                p = _place(np.array([[0.3, -0.2, 0.0]]), np.array([[0.0, 0.0, 1.0]]), R[None], h, h,
                           np.array([bound + eps]))[0]
                cases[f"depth {bound:+.2f}{eps:+.0e} {name}"] = (p, R)
    names = sorted(cases)
    p = np.array([cases[k][0] for k in names], dtype=float)
    R = np.array([cases[k][1] for k in names], dtype=float)
    return names, p, R, 2 * h


@pytest.fixture(scope="module")
def held_out():
    return _held_out()


@pytest.mark.parametrize("kind", ["improved", "paper"])
def test_compiled_equals_numpy_on_held_out_poses(kind, held_out):
    p, R, sA, sB = held_out
    assert len(p) >= 3000
    d = sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1]
    assert np.mean(d < DOMAIN_DEPTH[0]) > 0.05 and np.mean(d > DOMAIN_DEPTH[1]) > 0.05  # edges are in the set
    fast, ref = load_predictor(kind), load_predictor(kind, compiled=False)
    assert fast.compiled and not ref.compiled
    pc, nc = fast.predict(p, R, size_A=sA, size_B=sB)
    pr, nr = ref.predict(p, R, size_A=sA, size_B=sB)
    np.testing.assert_allclose(pc, pr, rtol=0, atol=TOL)
    np.testing.assert_allclose(nc, nr, rtol=0, atol=TOL)
    np.testing.assert_allclose(fast.depth(p, R, size_A=sA, size_B=sB), d, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fast.in_domain(p, R, size_A=sA, size_B=sB),
                                  ref.in_domain(p, R, size_A=sA, size_B=sB))


@pytest.mark.parametrize("kind", ["improved", "paper"])
def test_compiled_equals_numpy_at_the_domain_edges(kind):
    names, p, R, size = _edges()
    fast, ref = load_predictor(kind), load_predictor(kind, compiled=False)
    pc, nc = fast.predict(p, R, size_A=size, size_B=size)
    pr, nr = ref.predict(p, R, size_A=size, size_B=size)
    for i, name in enumerate(names):
        assert np.abs(pc[i] - pr[i]).max() <= TOL, name
        assert np.abs(nc[i] - nr[i]).max() <= TOL, name
        # one pose per call takes the same path
        p1, n1 = fast.predict(p[i], R[i], size_A=size, size_B=size)
        assert np.abs(p1 - pr[i]).max() <= TOL and np.abs(n1 - nr[i]).max() <= TOL, name
    np.testing.assert_allclose(fast.depth(p, R, size_A=size, size_B=size),
                               ref.depth(p, R, size_A=size, size_B=size), rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", ["improved", "paper"])
def test_compiled_refuses_what_numpy_refuses(kind):
    fast = load_predictor(kind)
    size = [6.058, 2.438, 2.591]
    p, R = np.array([[0.0, 0.0, 2.58], [0.0, 0.0, 2.58]]), np.stack([np.eye(3)] * 2)
    bad = p.copy()
    bad[1, 2] = np.nan
    with pytest.raises(PredictorInputError, match="finite"):
        fast.predict(bad, R, size_A=size, size_B=size)
    with pytest.raises(PredictorInputError, match="size_B .* not a supported container size"):
        fast.predict(p, R, size_A=size, size_B=np.array([size, [6.0, 2.4, 2.6]]))
    with pytest.raises(PredictorInputError, match="size_A must be finite"):
        fast.depth(p, R, size_A=[np.inf, 2.438, 2.591], size_B=size)


def test_compiled_features_equal_numpy_features(held_out):
    from learned_contact.compiled import features as native_features
    from learned_contact.model.encodings import canonicalise, features

    p, R, sA, sB = (np.ascontiguousarray(a[:500]) for a in held_out)
    X, PE, NE = native_features(p, R, sA, sB)
    _, p_c, R_c = canonicalise(p, R)
    x, pe, ne = features(p_c, R_c, 0.5 * sA, 0.5 * sB)
    np.testing.assert_allclose(X, x, rtol=0, atol=TOL)
    np.testing.assert_allclose(PE, pe, rtol=0, atol=TOL)
    np.testing.assert_allclose(NE, ne, rtol=0, atol=TOL)
