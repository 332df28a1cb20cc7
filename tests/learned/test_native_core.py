"""The native core (learned_contact._native, C11: native/src) against the numpy reference.

The compiled predictors (`load_predictor(kind)`, compiled=True) run the C core; the numpy
path (compiled=False) is the oracle. Both compute the same pipeline in the same operation
order wherever a result depends on it; they differ in the order of a few sums (numpy's
matrix products, einsum) and in the networks' tanh (the core's plain-arithmetic tanh is
within a few 1e-15 of np.tanh), so their answers agree to rounding: held here to 1e-12 m
(points) and 1e-12 (normal components) on every held-out pose set the accuracy gates use
(learned_contact.evaluation.gates: the same samplers, seeds and subsets, placed at their
separating-axis depth instead of Drake's, which needs no Drake) and on random poses beyond
them: out of the trained depth range on both sides, separated, deep, on and near A's
symmetry planes, level and edge on edge. Also: the statuses of bad inputs raise the numpy
path's errors; the constants the C core holds equal the Python ones; without the extension
the compiled path falls back to the numpy one and says so once.
"""

import dataclasses
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from learned_contact import PredictorDomainError, PredictorInputError, compiled as native, load_predictor
from learned_contact.data.sampling import sample
from learned_contact.evaluation.gates import N_HELD_OUT, OUTSIDE_RANGES, exactly_level, outside_training
from learned_contact.interface import CLIP_MARGIN, DOMAIN_DEPTH, ROTATION_TOLERANCE, SIZE_TOLERANCE
from learned_contact.model import prior, quadrature
from learned_contact.model.encodings import LENGTH_SCALE, N_FEATURES, PAPER_FRAME, SYMMETRY_BAND
from learned_contact.model.expert import R_SLAB
from learned_contact.model.mlp import NumpyMLP
from learned_contact.predictors.improved import POINT_STEP
from testbed.geometry.boxes import sat_normal
from testbed.geometry.rotations import random_rotations, rotation_from_rpy

REPO = Path(__file__).resolve().parents[2]
TOL = 1e-12  # [m] points, [-] normal components (module docstring)
GATE_SEEDS = (0, 98_765)  # evaluate_gates' default seed (testbed validate) and the gate tests' seed
needs_core = pytest.mark.skipif(not native.NATIVE_AVAILABLE, reason="the native core was not built")


def _place(p0, direction, R, hA, hB, depth):
    """p = p0 + t direction with separating-axis depth `depth` (n,) [m] (bisection on t)."""
    lo, hi = np.zeros(len(p0)), np.full(len(p0), 40.0)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        deeper = sat_normal(p0 + mid[:, None] * direction, R, hA, hB)[1] > depth
        lo, hi = np.where(deeper, mid, lo), np.where(deeper, hi, mid)
    return p0 + hi[:, None] * direction


def _proposals(distribution, n, seed, depth=None, **ranges):
    """(p, R, size_A, size_B) of the sampler's proposals placed at their depth (or `depth`)."""
    s = sample(distribution, n, seed, **ranges)
    sA, sB = s.sizes()
    d = s.direction / np.linalg.norm(s.direction, axis=1, keepdims=True)
    p = _place(s.base, d, s.R_AB, 0.5 * sA, 0.5 * sB, s.depth if depth is None else depth)
    return tuple(np.ascontiguousarray(a, dtype=float) for a in (p, s.R_AB, sA, sB))


def _subset(poses, keep):
    return tuple(np.ascontiguousarray(a[keep]) for a in poses)


def gate_pose_sets(seed: int, n: int = N_HELD_OUT) -> dict:
    """{set name: (p, R, size_A, size_B)}: the poses of gates.held_out(seed, n) (same
    distributions, seeds, ranges and subsets), placed by the separating axis."""
    sets = {"stacking": _proposals("stacking", n, 10 * seed + 5), "general": _proposals("general", n, 10 * seed + 6)}
    wide = _proposals("stacking", n, 10 * seed + 7, **OUTSIDE_RANGES)
    depth = sat_normal(wide[0], wide[1], 0.5 * wide[2], 0.5 * wide[3])[1]
    sets["outside"] = _subset(wide, outside_training(SimpleNamespace(R_AB=wide[1], depth=depth)))
    sets["resting"] = _proposals("resting", n, 10 * seed + 8)
    sets["resting_wider"] = _proposals("resting_wider", n, 10 * seed + 9)
    sets["resting_wider_level"] = _subset(sets["resting_wider"], exactly_level(SimpleNamespace(R_AB=sets["resting_wider"][1])))
    return sets


def random_pose_set(n: int = 1200, seed: int = 2024, kind: str = "paper"):
    """(p, R, size_A, size_B) of random poses beyond the gates' sets, a quarter each: any
    rotation placed along a random direction at a depth across and beyond DOMAIN_DEPTH
    (-5 cm to +10 cm); separated by 0.1-5 m; centre deep inside A; stacks on and near A's
    symmetry planes (p_x, p_y exactly 0, or within the blending band), level or yawed."""
    rng = np.random.default_rng(seed)
    sizes = load_predictor(kind, compiled=False).supported_sizes  # paper: 20 / 40 ft; improved: every ISO type
    sA, sB = sizes[rng.integers(0, len(sizes), n)], sizes[rng.integers(0, len(sizes), n)]
    R = random_rotations(rng, n)
    q = n // 4
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    depth = rng.uniform(-0.05, 0.10, n)
    depth[q:2 * q] = -rng.uniform(0.1, 5.0, q)  # separated
    p = _place(np.zeros((n, 3)), d, R, 0.5 * sA, 0.5 * sB, depth)
    p[2 * q:3 * q] = rng.uniform(-0.5, 0.5, (q, 3)) * sA[2 * q:3 * q]  # centre inside A
    rows = np.arange(3 * q, n)
    yaw = np.where(rng.random(len(rows)) < 0.5, 0.0, rng.uniform(-np.pi, np.pi, len(rows)))
    tilt = np.where(rng.random(len(rows)) < 0.5, 0.0, 1.0) * rng.uniform(-0.05, 0.05, (2, len(rows)))
    R[rows] = rotation_from_rpy(np.c_[tilt.T, yaw])
    xy = rng.choice([0.0, 1.0], (len(rows), 2)) * rng.uniform(-2.0, 2.0, (len(rows), 2)) * SYMMETRY_BAND
    base = np.c_[xy, np.zeros(len(rows))]
    up = np.tile([0.0, 0.0, 1.0], (len(rows), 1))
    p[rows] = _place(base, up, R[rows], 0.5 * sA[rows], 0.5 * sB[rows], rng.uniform(-0.02, 0.06, len(rows)))
    return tuple(np.ascontiguousarray(a, dtype=float) for a in (p, R, sA, sB))


def _variants() -> dict:
    """{name: numpy reference predictor}: the shipped ones, and the improved one with the
    expert's support layout (11 bounds), without an expert, and with tanh / relu networks
    (their answers mean nothing; they exercise the core's other branches)."""
    improved, paper = load_predictor("improved", compiled=False), load_predictor("paper", compiled=False)
    d = improved.expert_domain
    support = np.array([*d[:6], 0.9, 1.0, 0.45, 0.5, d[-1]]) if len(d) == 9 else d
    act = lambda mlp, a: dataclasses.replace(mlp, activation=a)  # noqa: E731
    return {"improved": improved, "paper": paper,
            "improved, support gate": dataclasses.replace(improved, expert_domain=support),
            "improved, no expert": dataclasses.replace(improved, expert=None, expert_domain=None),
            "improved, tanh": dataclasses.replace(improved, mlp=act(improved.mlp, "tanh"), expert=act(improved.expert, "tanh")),
            "paper, relu": dataclasses.replace(paper, mlp=act(paper.mlp, "relu"))}


@pytest.fixture(scope="module")
def pose_sets() -> dict:
    sets = {f"{name} (seed {seed})": poses for seed in GATE_SEEDS for name, poses in gate_pose_sets(seed).items()}
    sets["random"] = random_pose_set()
    sets["random, every ISO size"] = random_pose_set(seed=2025, kind="improved")  # half heights: unequal fields
    return sets


def _worst(fast, ref, poses):
    """(worst |point difference| [m], worst |normal difference|, worst |depth difference| [m])."""
    p, R, sA, sB = poses
    pc, nc = fast.predict(p, R, size_A=sA, size_B=sB)
    pr, nr = ref.predict(p, R, size_A=sA, size_B=sB)
    dc, dr = fast.depth(p, R, size_A=sA, size_B=sB), ref.depth(p, R, size_A=sA, size_B=sB)
    return float(np.abs(pc - pr).max()), float(np.abs(nc - nr).max()), float(np.abs(dc - dr).max())


@needs_core
@pytest.mark.parametrize("kind", ["improved", "paper"])
def test_the_core_answers_as_the_numpy_reference_on_every_gate_set(kind, pose_sets):
    ref = load_predictor(kind, compiled=False)
    fast = ref.with_compiled(True)
    assert fast.compiled and not ref.compiled
    worst = {name: _worst(fast, ref, poses) for name, poses in pose_sets.items()
             if kind == "improved" or "every ISO size" not in name}  # the paper's MLP answers its 3 sizes
    bad = {name: w for name, w in worst.items() if max(w) > TOL}
    assert not bad, f"worst (point [m], normal, depth [m]) above {TOL:g}: {bad}"
    counts = {name: len(poses[0]) for name, poses in pose_sets.items()}
    assert min(counts.values()) >= 150 and counts["random"] >= 1000, counts  # the sets are there


@needs_core
def test_the_sets_reach_every_part_of_the_pipeline(pose_sets):
    """The poses cover what the agreement must hold on: both sides of DOMAIN_DEPTH,
    separated pairs, A's symmetry bands, face-on-face and learned answers."""
    p, R, sA, sB = (np.concatenate(a) for a in zip(*pose_sets.values()))
    n, depth, axis = sat_normal(p, R, 0.5 * sA, 0.5 * sB)
    assert np.mean(depth < DOMAIN_DEPTH[0]) > 0.05 and np.mean(depth > DOMAIN_DEPTH[1]) > 0.03
    assert np.mean(np.any(np.abs(p) < SYMMETRY_BAND, axis=1)) > 0.1 and np.any(p[:, :2] == 0.0)
    assert np.mean(axis >= 6) > 0.01  # edge-on-edge contacts
    _, _, weight, tilt = quadrature.face_on_face(p, R, 0.5 * sA, 0.5 * sB, n)
    on_face = (weight > 0) & (tilt < quadrature.NORMAL_TILT[0]) & (depth >= DOMAIN_DEPTH[0])
    assert 0.2 < np.mean(on_face) < 0.8  # the quadrature alone, and the networks, both answer many


@needs_core
@pytest.mark.parametrize("name", ["improved, support gate", "improved, no expert", "improved, tanh", "paper, relu"])
def test_the_core_answers_as_the_numpy_reference_for_other_networks_and_gates(name, pose_sets):
    ref = _variants()[name]
    fast = ref.with_compiled(True)
    for set_name in ("resting (seed 0)", "resting_wider (seed 0)", "stacking (seed 0)", "general (seed 0)", "random"):
        worst = _worst(fast, ref, pose_sets[set_name])
        assert max(worst) <= TOL, (set_name, worst)


@needs_core
@pytest.mark.parametrize("kind", ["improved", "paper"])
def test_one_pose_per_call_is_the_batch_answer_bit_for_bit(kind, pose_sets):
    fast = load_predictor(kind)
    p, R, sA, sB = (a[::40] for a in pose_sets["random"])
    point, normal = fast.predict(p, R, size_A=sA, size_B=sB)
    depth = fast.depth(p, R, size_A=sA, size_B=sB)
    for i in range(len(p)):
        for args in ((p[i], R[i]), (p[i].tolist(), R[i].tolist())):  # the fast path and the converting one
            one = fast.predict(*args, size_A=sA[i], size_B=sB[i])
            np.testing.assert_array_equal(one[0], point[i])
            np.testing.assert_array_equal(one[1], normal[i])
        assert fast.depth(p[i], R[i], size_A=sA[i], size_B=sB[i]) == depth[i]


@needs_core
@pytest.mark.parametrize("name", ["improved", "paper", "improved, tanh", "paper, relu"])
def test_the_networks_vector_and_plain_forms_give_the_same_bits(name, pose_sets):
    """The core runs its networks on AVX vectors where the CPU has them and in plain C
    elsewhere (native/src/mlp.c); both must give the same bits (on a CPU without AVX this
    compares the plain form with itself)."""
    fast = _variants()[name].with_compiled(True)
    p, R, sA, sB = pose_sets["random"]
    vector = fast.predict(p, R, size_A=sA, size_B=sB)
    native._native.set_vector_path(False)
    try:
        plain = fast.predict(p, R, size_A=sA, size_B=sB)
    finally:
        native._native.set_vector_path(True)
    np.testing.assert_array_equal(vector[0], plain[0])
    np.testing.assert_array_equal(vector[1], plain[1])


@needs_core
def test_the_networks_tanh_is_numpys_to_rounding():
    x = np.concatenate([np.linspace(-25.0, 25.0, 200_001), [0.0, -0.0, 1e-300, -1e-300, 19.99, 20.0, 20.01, 700.0, -700.0]])
    out = np.empty_like(x)
    native._native.tanh(x, out)
    assert np.abs(out - np.tanh(x)).max() < 1e-14
    assert np.all(np.abs(out) <= 1.0) and np.all(np.sign(out) * np.sign(x) >= 0.0)  # no sign flips (0 near 0)


# ------------------------------------------------------------------ statuses and errors
def _bad_inputs():
    """{status: (p, R, size_A, size_B, the row the core names)} for two 20 ft poses."""
    size = np.array([6.058, 2.438, 2.591])
    p, R = np.array([[0.0, 0.0, 2.58], [0.3, 0.1, 2.57], [0.0, 0.2, 2.58]]), np.stack([np.eye(3)] * 3)
    sizes = np.stack([size] * 3)
    nan_p = p.copy()
    nan_p[1, 2] = np.nan
    nan_R = R.copy()
    nan_R[2, 0, 1] = np.inf
    mirror, scaled = R.copy(), R.copy()
    mirror[1] = np.diag([1.0, 1.0, -1.0])
    scaled[2] = (1.0 + 10 * ROTATION_TOLERANCE) * np.eye(3)
    off_A, off_B = sizes.copy(), sizes.copy()
    off_A[:] = [6.0, 2.4, 2.6]
    # widths off ISO's: outside the improved predictor's size range too (its lengths and heights span)
    off_B[1], off_B[2] = [6.058, 2.438 + 2 * SIZE_TOLERANCE, 2.591], [6.058, 2.5, 2.591]  # row 2 lies farther
    inf_A, nan_B = sizes.copy(), sizes.copy()
    inf_A[1, 0], nan_B[2, 1] = np.inf, np.nan
    return [(1, (nan_p, R, size, size), 1), (1, (p, nan_R, size, size), 2), (6, (p, mirror, size, size), 1),
            (6, (p, scaled, size, size), 2), (2, (p, R, off_A, size), 0), (2, (p, R, off_A[0], size), 0),
            (3, (p, R, size, off_B), 2), (4, (p, R, inf_A, size), 1), (5, (p, R, size, nan_B), 2),
            (4, (p, R, inf_A, off_B), 1)]


def _error(fn, *args, **kwargs):
    """The message of the PredictorInputError that fn(*args, **kwargs) raises."""
    with pytest.raises(PredictorInputError) as info:
        fn(*args, **kwargs)
    return str(info.value)


@needs_core
@pytest.mark.parametrize("kind", ["improved", "paper"])
@pytest.mark.parametrize("case", range(10))
def test_every_status_raises_the_numpy_paths_error(kind, case):
    status, (p, R, sA, sB), row = _bad_inputs()[case]
    ref = load_predictor(kind, compiled=False)
    fast = ref.with_compiled(True)
    rows = lambda s: np.ascontiguousarray(np.broadcast_to(s, (len(p), 3)) if np.ndim(s) == 2 else np.reshape(s, (1, 3)))  # noqa: E731
    args = (np.ascontiguousarray(p), np.ascontiguousarray(R), rows(sA), rows(sB))
    assert native.native_predict(fast._native, *args)[3:] == (status, row)
    assert native.native_depth(fast._native, *args)[1:] == (status, row)
    assert native.STATUS_NAMES[status]
    for method in ("predict", "depth"):
        expected = _error(getattr(ref, method), p, R, size_A=sA, size_B=sB)
        assert _error(getattr(fast, method), p, R, size_A=sA, size_B=sB) == expected
        assert _error(getattr(fast, method), p.tolist(), R.tolist(), size_A=np.asarray(sA).tolist(),
                      size_B=np.asarray(sB).tolist()) == expected


@needs_core
def test_shapes_and_domain_are_refused_as_on_the_numpy_path():
    ref = load_predictor(compiled=False)
    fast = ref.with_compiled(True)
    size = [6.058, 2.438, 2.591]
    cases = [(np.zeros((2, 3)), np.stack([np.eye(3)] * 3), size, size), (np.zeros(3), np.eye(3), np.ones((2, 3)), size),
             (np.zeros((2, 2)), np.stack([np.eye(3)] * 2), size, size), (np.zeros(3), np.eye(3)[:2], size, size)]
    for p, R, sA, sB in cases:
        assert _error(fast.predict, p, R, size_A=sA, size_B=sB) == _error(ref.predict, p, R, size_A=sA, size_B=sB)
    p, R = np.array([[0.0, 0.0, 2.5], [0.0, 0.0, 2.58]]), np.stack([np.eye(3)] * 2)  # 9 cm deep, then in the domain
    for path in (fast, ref):
        with pytest.raises(PredictorDomainError) as info:
            path.predict(p, R, size_A=size, size_B=size, outside="raise")
        assert "1 of 2 poses" in str(info.value)
    np.testing.assert_array_equal(fast.predict(p[1], R[1], size_A=size, size_B=size, outside="raise")[0],
                                  fast.predict(p[1], R[1], size_A=size, size_B=size)[0])
    with pytest.raises(PredictorInputError, match="outside="):
        fast.predict(p, R, size_A=size, size_B=size, outside="wrap")


@needs_core
def test_a_model_the_core_cannot_answer_is_refused_at_construction():
    improved = load_predictor(compiled=False)
    spec = native.mlp_spec(improved.mlp)
    with pytest.raises(ValueError, match="kind"):
        native._native.Model(3, improved.supported_sizes, spec)
    with pytest.raises(ValueError, match="widths"):
        native._native.Model(native.KIND_CODES["paper"], improved.supported_sizes, spec)  # 91 inputs, not 6
    with pytest.raises(TypeError, match="float64"):
        native._native.Model(1, improved.supported_sizes.astype(np.float32), spec)
    with pytest.raises(ValueError, match="domain"):
        native._native.Model(1, improved.supported_sizes, spec, spec, np.zeros(5))
    with pytest.raises(TypeError, match="Model"):
        native._native.predict(None, np.zeros((1, 3)), np.eye(3)[None], np.ones(3), np.ones(3), np.empty((1, 3)),
                               np.empty((1, 3)), None)


@needs_core
def test_copies_and_pickles_rebuild_the_native_model():
    import copy
    import pickle

    fast = load_predictor()
    p, R, size = np.array([0.2, 0.1, 2.5905]), rotation_from_rpy([[0.001, 0.0, 0.3]])[0], [6.058, 2.438, 2.591]
    for other in (copy.deepcopy(fast), pickle.loads(pickle.dumps(fast))):
        assert other.compiled and other._native is not fast._native
        np.testing.assert_array_equal(other.predict(p, R, size_A=size, size_B=size)[0],
                                      fast.predict(p, R, size_A=size, size_B=size)[0])


# ------------------------------------------------------------------ constants
@needs_core
def test_the_constants_the_core_holds_are_pythons():
    c = native.constants()
    assert (c["DOMAIN_DEPTH_LO"], c["DOMAIN_DEPTH_HI"]) == DOMAIN_DEPTH
    assert c["SIZE_TOLERANCE"] == SIZE_TOLERANCE and c["ROTATION_TOLERANCE"] == ROTATION_TOLERANCE
    assert c["CLIP_MARGIN"] == CLIP_MARGIN and c["POINT_STEP"] == POINT_STEP
    assert c["SYMMETRY_BAND"] == SYMMETRY_BAND and c["R_SLAB"] == R_SLAB and c["LENGTH_SCALE"] == LENGTH_SCALE
    assert (c["POINT_TILT_0"], c["POINT_TILT_1"]) == tuple(quadrature.POINT_TILT)
    assert (c["NORMAL_TILT_0"], c["NORMAL_TILT_1"]) == tuple(quadrature.NORMAL_TILT)
    assert c["N_FEATURES"] == N_FEATURES and c["MAX_VERTS"] == prior._MAX_VERTS
    assert c["QUAD_VERTS"] == quadrature._MAX_VERTS
    assert c["PAPER_FRAME"] == tuple(PAPER_FRAME.ravel().tolist())
    assert {a: c[a.upper()] for a in native.ACTIVATION_CODES} == native.ACTIVATION_CODES
    assert (c["KIND_IMPROVED"], c["KIND_PAPER"]) == (native.KIND_CODES["improved"], native.KIND_CODES["paper"])
    assert c["MAX_LAYERS"] >= 3 and c["MAX_WIDTH"] >= 64


@needs_core
def test_the_edge_bias_is_the_separating_axis_references():
    """testbed.geometry.boxes.sat_normal prefers a face axis over an edge axis within a bias
    it holds as a literal; the core's EDGE_BIAS must be it: an edge axis less than the bias
    below the faces loses, one more than the bias below wins (on the reference)."""
    bias, eps = native.constants()["EDGE_BIAS"], 1e-9
    axes = np.zeros((2, 15, 3))
    axes[:, :, 2] = 1.0
    overlap = np.ones((2, 15))
    overlap[0, 7], overlap[1, 7] = 1.0 - bias + eps, 1.0 - bias - eps
    _, _, k = sat_normal(np.zeros((2, 3)), None, None, None, (overlap, axes))
    assert k.tolist() == [0, 7]


# ------------------------------------------------------------------ without the extension
def test_without_the_extension_the_compiled_path_is_the_numpy_one_and_says_so_once():
    code = (
        "import sys\n"
        "sys.modules['learned_contact._native'] = None  # as if the extension was not built\n"
        "import numpy as np\n"
        "from learned_contact import load_predictor\n"
        "from learned_contact.compiled import NATIVE_AVAILABLE\n"
        "p, R, s = np.array([0.3, 0.1, 2.585]), np.eye(3), [6.058, 2.438, 2.591]\n"
        "for kind in ('improved', 'paper', 'improved'):\n"
        "    pred = load_predictor(kind)\n"
        "    ref = load_predictor(kind, compiled=False)\n"
        "    assert not pred.compiled\n"
        "    assert np.array_equal(pred.predict(p, R, size_A=s, size_B=s)[0], ref.predict(p, R, size_A=s, size_B=s)[0])\n"
        "print(NATIVE_AVAILABLE)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.split() == ["False"]
    assert done.stderr.count(native.NOT_BUILT) == 1 and native.NOT_BUILT in done.stderr.splitlines()


def test_the_fallback_line_says_what_to_do():
    assert native.NOT_BUILT == ("native core not built: using the numpy reference path (install a C compiler and run "
                                "pip install -e . again)")


@needs_core
def test_a_network_of_other_widths_is_answered_too():
    """A user's network of other hidden widths (not multiples of the core's vector blocks)."""
    rng = np.random.default_rng(3)
    ref = load_predictor("paper", compiled=False)
    dims = [6, 37, 5, 4]
    mlp = NumpyMLP(weights=tuple(rng.normal(size=(a, b)) / np.sqrt(a) for a, b in zip(dims[:-1], dims[1:])),
                   biases=tuple(rng.normal(size=b) for b in dims[1:]), activation="silu",
                   x_mean=ref.mlp.x_mean, x_std=ref.mlp.x_std)
    user = dataclasses.replace(ref, mlp=mlp)
    p, R, sA, sB = random_pose_set(200, seed=7)
    worst = _worst(user.with_compiled(True), user, (p, R, sA, sB))
    assert max(worst) <= TOL, worst


@needs_core
def test_box_depth_is_the_separating_axis_depth_of_any_boxes():
    """learned_contact.compiled.box_depth (a user model's depth when it gives none) equals the
    numpy separating-axis depth to rounding on random poses of sizes no predictor declares,
    separated, touching and deep, one size row broadcast or one per pose."""
    from learned_contact.compiled import box_depth
    from testbed.geometry.boxes import sat_normal
    from testbed.geometry.rotations import random_rotations

    rng = np.random.default_rng(37)
    n = 500
    sA, sB = rng.uniform(0.3, 14.0, (n, 3)), rng.uniform(0.3, 14.0, (n, 3))
    p = rng.uniform(-1.0, 1.0, (n, 3)) * (0.5 * sA + 0.5 * sB)
    R = random_rotations(rng, n)
    ref = sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1]
    assert np.ptp(np.sign(ref)) == 2  # both separated and overlapping poses
    np.testing.assert_allclose(box_depth(p, R, sA, sB), ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(box_depth(p, R, sA[:1], sB[:1]), sat_normal(p, R, 0.5 * sA[:1], 0.5 * sB[:1])[1], rtol=0, atol=1e-12)


@needs_core
def test_the_native_check_accepts_exactly_what_check_numpy_accepts():
    """native_check (a user model's fast input checks) says 0 exactly where
    interface.check_numpy raises nothing, on clean batches and on batches with one defect of
    each kind the reference refuses (a NaN, a reflection, a skewed matrix, an unsupported or
    non-finite size); each defect placed at a random row."""
    from learned_contact.compiled import native_check
    from learned_contact.errors import PredictorInputError
    from learned_contact.interface import check_numpy
    from testbed.geometry.rotations import random_rotations

    rng = np.random.default_rng(3737)
    supported = np.array([[6.058, 2.438, 2.591], [12.192, 2.438, 2.591]])
    defects = [None, ("p", np.nan), ("R", "reflect"), ("R", "skew"), ("sA", 0.1), ("sB", np.inf), ("sA", 9e-4)]
    for trial in range(70):
        n = int(rng.integers(1, 6))
        p, R = rng.normal(size=(n, 3)), random_rotations(rng, n)
        sA, sB = supported[rng.integers(0, 2, n)].copy(), supported[rng.integers(0, 2, n)].copy()
        kind = defects[trial % len(defects)]
        row = int(rng.integers(0, n))
        if kind is not None:
            what, value = kind
            if what == "p":
                p[row, 1] = value
            elif value == "reflect":
                R[row, :, 2] *= -1.0
            elif value == "skew":
                R[row, 0, 1] += 1e-5
            else:
                (sA if what == "sA" else sB)[row, 0] += value  # 9e-4: within SIZE_TOLERANCE, accepted
        try:
            check_numpy(p, R, sA, sB, supported)
            refused = False
        except PredictorInputError:
            refused = True
        assert (native_check(supported, p, R, sA, sB) != 0) == refused, (trial, kind)
