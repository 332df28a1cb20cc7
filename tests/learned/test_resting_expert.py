"""The resting expert (learned_contact.model.expert): its gate opens on every resting
pose, shuts beyond the margin it was trained on, hands over continuously, and changes
nothing where it is shut; the file format carries it or refuses it clearly."""

import dataclasses

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.data.sampling import RESTING_RANGES
from learned_contact.errors import WeightsError
from learned_contact.export.onnx_check import probe_poses
from learned_contact.model.encodings import frame_blend, reflect
from learned_contact.model.expert import R_SLAB, gate, slab_ratio, weights
from learned_contact.training.config import default_domain
from testbed.geometry.boxes import sat_normal
from testbed.geometry.rotations import rotation_from_rpy

SIZE_20FT = np.array([6.058, 2.438, 2.591])
TOP = SIZE_20FT[2]  # B's centre height on A when just touching [m]


@pytest.fixture(scope="module")
def shipped():
    return load_predictor(compiled=False)


def _shifted_expert(pred, offset: float = 0.1):
    """`pred` with its expert's point outputs shifted by `offset` (bias of the last layer): an
    expert whose correction differs from the main network's by centimetres. Since the labels are
    the exact centre of pressure the shipped expert's own correction is micrometres (the prior is
    exact on resting stacks), so the blend's tests give it one that a switch would reveal."""
    mlp = pred.expert
    b = list(mlp.biases)
    b[-1] = b[-1].copy()
    b[-1][:3] += offset
    return dataclasses.replace(pred, expert=dataclasses.replace(mlp, biases=tuple(b)))


def _gate(p, R, sA, sB, domain=None):
    """(n,) the gate of poses in A's frame, in their own octant frame."""
    sigma = np.where(p >= 0.0, 1.0, -1.0)
    p_c, R_c = reflect(sigma, p, R)
    return gate(p_c, R_c, sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1], default_domain() if domain is None else domain)


def _stack(depth=2e-4, roll_deg=0.0, pitch_deg=0.0, yaw_deg=0.0, x=0.1, y=0.05):
    """A 20 ft box B resting on a 20 ft box A: (p (1, 3), R (1, 3, 3), size (1, 3)); depth
    is the separating-axis overlap [m] (exact: B's lowest corner sits `depth` into A)."""
    R = rotation_from_rpy(np.radians([[roll_deg, pitch_deg, yaw_deg]]))
    p = np.array([[x, y, TOP]])
    lift = sat_normal(p, R, 0.5 * SIZE_20FT[None], 0.5 * SIZE_20FT[None])[1]  # overlap at TOP
    return p - np.array([[0.0, 0.0, depth - lift[0]]]), R, SIZE_20FT[None]


def test_the_shipped_predictor_carries_the_expert_and_its_domain(shipped):
    assert shipped.expert is not None
    np.testing.assert_array_equal(shipped.expert_domain, default_domain())
    assert shipped.meta["config"]["expert"]["n_resting"] > 0


def test_the_gate_is_open_on_every_resting_pose():
    """g = 1 on all of sampling's "resting" distribution (the held-out resting set's
    poses), so the resting gates measure the expert alone."""
    p, R, sA, sB = probe_poses(3000, 31, "resting")
    np.testing.assert_array_equal(_gate(p, R, sA, sB), 1.0)


def test_the_gate_ramps_inside_the_wide_training_ranges_and_is_the_same_in_every_frame():
    """On "resting_wide" poses (the expert's margin) the gate is open, ramping and shut in
    the proportions its bounds give, none of them beyond that distribution's own ranges
    with g > 0; every octant frame of a pose gets the same g (the predictor blends frames
    near A's planes). Expected fractions: open = depth 0.89 (log-uniform 5 um-1 mm below
    0.55 mm) x tilt 0.40 (the disc of 0.0714 deg in the +-0.1 deg square) x yaw 0.67 x
    offsets 0.64 = 0.15; shut = tilt beyond the 0.1 deg disc, 1 - pi / 4 = 0.21 (measured
    0.17 and 0.21 on 3 000 poses; bands of about +-4 standard errors)."""
    p, R, sA, sB = probe_poses(3000, 32, "resting_wide")
    g = _gate(p, R, sA, sB)
    assert 0.12 < np.mean(g == 1.0) < 0.19 and 0.18 < np.mean(g == 0.0) < 0.25
    depth = sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1]
    (_, d_max), tilt, yaw, offset = RESTING_RANGES["resting_wide"]
    assert np.all(depth[g > 0] <= d_max) and np.all(np.abs(p[g > 0, :2]) <= offset)
    near = frame_blend(p)
    assert len(near) > 1  # some poses lie within the band of a plane
    for sigma, _ in near:
        p_c, R_c = reflect(sigma, p, R)
        np.testing.assert_array_equal(gate(p_c, R_c, depth, default_domain()), g)


@pytest.mark.parametrize("quantity, inside, outside", [
    ("depth", 5.4e-4, 1.0001e-3),  # [m]: inner bound 0.55 mm, outer 1 mm
    ("roll_deg", 0.0705, 0.1001),  # B's tilt: inner 1.01 x sqrt(2) x 0.05 deg, outer 0.1 deg
    ("pitch_deg", 0.0705, 0.1001),
    ("yaw_deg", 2.01, 3.001),
    ("x", 0.4, 0.5001),  # [m]
    ("y", -0.4, -0.5001),
])
def test_the_gate_holds_its_bounds_on_each_quantity(quantity, inside, outside):
    """One quantity at a time from a centred resting stack: g = 1 up to the inner bound,
    0 beyond the outer one, each other quantity inside."""
    assert _gate(*_stack(**{quantity: inside}), SIZE_20FT[None])[0] == 1.0
    assert _gate(*_stack(**{quantity: outside}), SIZE_20FT[None])[0] == 0.0


def test_where_the_gate_is_shut_the_answer_is_the_main_networks_bit_for_bit(shipped):
    """The expert must not leak into other regimes: on stacking, general and outside
    probe poses and on an overhang (B's centre 3.1 m off A's, the overhang scenes) every
    pose with g = 0 is answered exactly as by the same predictor without an expert."""
    plain = dataclasses.replace(shipped, expert=None, expert_domain=None)
    poses = [probe_poses(1500, 41, "stacking"), probe_poses(1500, 42, "general"),
             probe_poses(800, 43, "stacking", max_depth=0.05, max_tilt_deg=10.0)]
    p, R, sA = _stack(depth=3e-5, x=3.1, y=0.0)
    poses.append((p, R, sA, sA))
    for p, R, sA, sB in poses:
        shut = _gate(p, R, sA, sB) == 0.0
        assert shut.mean() > 0.95
        a, b = shipped.predict(p, R, size_A=sA, size_B=sB), plain.predict(p, R, size_A=sA, size_B=sB)
        np.testing.assert_array_equal(a[0][shut], b[0][shut])
        np.testing.assert_array_equal(a[1][shut], b[1][shut])


def _learned(pred, p, R, *, size_A, size_B):
    """The learned pipeline's answer (ContactPredictor._learned, numpy): what the expert
    and the slab scale shape. The predictor answers with the face-on-face quadrature where
    two faces meet, which covers every pose the expert's gate opens on, so these
    tests look at the pipeline beneath it (it answers beyond the quadrature's tilt bands)."""
    pred = pred.with_compiled(False)
    size_A = np.broadcast_to(size_A, p.shape)
    size_B = np.broadcast_to(size_B, p.shape)
    sat_n, depth, _ = sat_normal(p, R, 0.5 * size_A, 0.5 * size_B)
    return pred._learned(p, R, 0.5 * size_A, 0.5 * size_B, sat_n, depth)


@pytest.mark.parametrize("quantity, bounds", [("depth", (5.5e-4, 1e-3)), ("x", (0.4, 0.5)),
                                              ("yaw_deg", (2.02, 3.0))])
def test_the_hand_over_is_continuous(shipped, quantity, bounds):
    # a tilted stack (r = 30 to 60, beyond R_SLAB), so that the expert's correction is whole inside
    """Across the ramp of one quantity the answer moves by the answers' own slope: a step
    of 1e-9 (in that quantity's unit) moves the point by < 1e-6 m and the normal by
    < 1e-6, at both bounds and mid-ramp. A hard switch would jump by the two networks'
    difference there, which is asserted to be over 1 mm (so this test can fail)."""
    shipped = _shifted_expert(shipped)  # the blend's mechanism, with networks a switch would reveal
    plain = dataclasses.replace(shipped, expert=None, expert_domain=None)
    expert_only = dataclasses.replace(shipped, expert_domain=np.array([1.0, 2.0, 1.0, 2.0, 1.0, 2.0, 10.0, 20.0, 1e-12]))
    lo, hi = bounds
    for q in (lo, 0.5 * (lo + hi), hi):
        a = _learned(shipped, *_stack(roll_deg=0.01, **{quantity: q})[:2], size_A=SIZE_20FT, size_B=SIZE_20FT)
        b = _learned(shipped, *_stack(roll_deg=0.01, **{quantity: q + 1e-9})[:2], size_A=SIZE_20FT, size_B=SIZE_20FT)
        assert np.abs(a[0] - b[0]).max() < 1e-6 and np.abs(a[1] - b[1]).max() < 1e-6
    mid = _stack(roll_deg=0.01, **{quantity: 0.5 * (lo + hi)})[:2]
    gap = np.linalg.norm(_learned(plain, *mid, size_A=SIZE_20FT, size_B=SIZE_20FT)[0]
                         - _learned(expert_only, *mid, size_A=SIZE_20FT, size_B=SIZE_20FT)[0])
    assert gap > 1e-3


def test_compiled_equals_numpy_where_the_expert_answers():
    """The native core's gate and expert against the numpy reference on resting and
    resting_wide poses (ramps included) and on near-level ones (the slab ratio's ramp), to
    the tolerance the compiled tests hold (1e-9)."""
    fast, ref = load_predictor(), load_predictor(compiled=False)
    for k, dist in enumerate(("resting", "resting_wide", "resting_level")):
        p, R, sA, sB = probe_poses(2000, 51 + k, dist)
        a, b = fast.predict(p, R, size_A=sA, size_B=sB), ref.predict(p, R, size_A=sA, size_B=sB)
        np.testing.assert_allclose(a[0], b[0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(a[1], b[1], rtol=0, atol=1e-9)


def test_a_saved_expert_loads_back_with_the_same_answers(shipped, tmp_path):
    path = shipped.save(tmp_path / "w.npz")
    with np.load(path) as z:
        assert int(z["format_version"]) == 2 and "expert/W0" in z.files
    back = load_predictor(path, compiled=False)
    p, R, sA, sB = probe_poses(300, 61, "resting_wide")
    np.testing.assert_array_equal(back.predict(p, R, size_A=sA, size_B=sB)[0], shipped.predict(p, R, size_A=sA, size_B=sB)[0])
    plain = dataclasses.replace(shipped, expert=None, expert_domain=None).save(tmp_path / "plain.npz")
    with np.load(plain) as z:
        assert int(z["format_version"]) == 1 and not any(k.startswith("expert/") for k in z.files)


def test_the_paper_kind_refuses_an_expert(tmp_path):
    paper = load_predictor("paper")
    path = paper.save(tmp_path / "p.npz")
    with np.load(path) as z:
        arrays = dict(z)
    shipped = load_predictor()
    arrays.update(shipped.expert.to_arrays("expert/"), **{"expert/domain": default_domain(),
                                                          "format_version": np.array(2)})
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(WeightsError, match=r"field 'expert/\*' is present in a 'paper' file"):
        load_predictor(tmp_path / "bad.npz")


def test_on_a_level_stack_the_answer_is_the_priors_and_the_correction_returns_smoothly():
    """Where the prior is exact (a level stack: the overlap is a slab) the correction
    vanishes by construction: at r = 0 the learned pipeline answers its geometric prior bit for
    bit (measured against Drake on 214 poses with r < 0.001: prior 0.023 mm median, the
    expert's uncorrected answer 0.56 mm); the weight grows smoothly with r and is whole
    from R_SLAB on. A predictor without the construction fails the first assertion."""
    from learned_contact.evaluation.gates import GeometricPrior

    shipped = _shifted_expert(load_predictor())  # an expert whose correction is centimetres (see there)
    p, R, s = _stack(depth=1e-4)
    point, normal = _learned(shipped, p, R, size_A=s, size_B=s)
    prior_point, prior_normal = GeometricPrior().predict(p, R, size_A=s, size_B=s)
    np.testing.assert_array_equal(point, prior_point)
    np.testing.assert_allclose(normal, prior_normal, rtol=0, atol=1e-15)
    # without the construction (r_slab 1e-12: whole from r = 1e-12 on) a stack level to 1e-9 deg gets
    # the expert's own correction, which moves the point off the prior's
    without = dataclasses.replace(shipped, expert_domain=np.r_[shipped.expert_domain[:8], 1e-12])
    p, R, _ = _stack(depth=1e-4, roll_deg=1e-9)
    near_prior = GeometricPrior().predict(p, R, size_A=s, size_B=s)[0]
    assert np.linalg.norm(_learned(without, p, R, size_A=s, size_B=s)[0] - near_prior) > 1e-5
    assert np.linalg.norm(_learned(shipped, p, R, size_A=s, size_B=s)[0] - near_prior) < 1e-9
    # the weight along r: 0 at 0, smooth, 1 from R_SLAB
    h = 0.5 * s
    ratios, answers = [], []
    for roll in np.linspace(0.0, 2e-6, 41):  # [deg]; r = 2 tan(roll) h_y / depth, up to ~0.04
        p, R, _ = _stack(depth=1e-4, roll_deg=roll)
        sigma = np.where(p >= 0.0, 1.0, -1.0)
        p_c, R_c = reflect(sigma, p, R)
        ratios.append(slab_ratio(R_c, h, h, np.array([1e-4]))[0])
        answers.append(weights(p_c, R_c, h, h, np.array([1e-4]), default_domain())[1][0])
    ratios, answers = np.array(ratios), np.array(answers)
    assert answers[0] == 0.0 and np.all(answers[ratios >= R_SLAB] == 1.0) and np.all(np.diff(answers) >= 0.0)
    assert np.max(np.abs(np.diff(answers))) < 0.1  # no jump between neighbouring tilts (steps of r ~ 1e-3)


def test_near_level_stacks_are_answered_at_nanometres():
    """Held-out "resting_level" poses (tilt log-uniform 1e-9 to 1e-3 rad, the regime of a
    stack settled under a centred load; sampling seed 10 * 0 + 9, not a training seed),
    labelled with the exact centre of pressure: the shipped predictor (the face-on-face closed
    form answers them all) is within 1 um at the median (measured 0.3 nm) and no worse than the
    geometric prior (0.8 um; exact only where the tilt across the patch is a fraction of the
    overlap), on the whole set and on its most level third (slab ratio < R_SLAB, 142 poses;
    0.15 nm against 0.17 um). The earlier "2 mm, where the prior is 7.7 mm" measured Drake's
    one-point rule, which lies 7.7 mm (median) from the exact answer on these poses."""
    from learned_contact.data.labels import make_dataset
    from learned_contact.evaluation.gates import GeometricPrior
    from learned_contact.evaluation.metrics import point_normal_errors

    ds = make_dataset("resting_level", 400, 9, progress=False, use_cache=False)
    mine = point_normal_errors(*load_predictor().predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B), ds)[0]
    prior = point_normal_errors(*GeometricPrior().predict(ds.p_AB, ds.R_AB, size_A=ds.size_A, size_B=ds.size_B), ds)[0]
    assert np.median(mine) <= 1e-6 and np.median(mine) <= np.median(prior)
    assert np.median(np.linalg.norm(ds.cop - ds.cop_one_point, axis=1)) > 1e-3  # the poses discriminate the rules
    sigma = np.where(ds.p_AB >= 0.0, 1.0, -1.0)
    _, R_c = reflect(sigma, ds.p_AB, ds.R_AB)
    level = slab_ratio(R_c, 0.5 * ds.size_A, 0.5 * ds.size_B, ds.depth) < R_SLAB
    assert level.sum() > 50
    assert np.median(mine[level]) <= np.median(prior[level])


# ---------------------------------------------------------------------------------------------
# The per-axis gate on the edge of support (format_version 3: expert.DOMAIN_FIELDS)

SIZE_40FT = np.array([12.192, 2.438, 2.591])


@pytest.fixture(scope="module")
def support_paths():
    """{path: the shipped networks with the support layout's gate (training.support_domain)}."""
    from learned_contact.training.config import support_domain

    ref = dataclasses.replace(load_predictor(compiled=False), expert_domain=support_domain())
    return {"numpy": ref, "compiled": ref.with_compiled(True)}


def _support_gate(p, R, sA, sB):
    from learned_contact.training.config import support_domain

    sigma = np.where(p >= 0.0, 1.0, -1.0)
    p_c, R_c = reflect(sigma, p, R)
    return gate(p_c, R_c, sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1], support_domain(), 0.5 * sA, 0.5 * sB)


def _pair(size_A, size_B, x=0.0, y=0.0, depth=2e-4, roll_deg=0.01, yaw_deg=0.0):
    """B (size_B) resting on A (size_A) with its centre at (x, y) [m] in A, `depth` [m] deep."""
    R = rotation_from_rpy(np.radians([[roll_deg, 0.0, yaw_deg]]))
    p = np.array([[x, y, 0.5 * (size_A[2] + size_B[2])]])
    lift = sat_normal(p, R, 0.5 * size_A[None], 0.5 * size_B[None])[1]
    return p - np.array([[0.0, 0.0, depth - lift[0]]]), R, size_A[None], size_B[None]


@pytest.mark.parametrize("pose, expected", [
    (dict(x=0.9 * 3.029), 1.0),  # 20 ft on 20 ft, B's centre 0.9 of the way to A's edge
    (dict(x=1.0001 * 3.029), 0.0),  # beyond the edge of support (overhang_tip: 3.129 m)
    (dict(x=3.129), 0.0),
    (dict(y=0.45 * 1.219), 1.0),
    (dict(y=0.5001 * 1.219), 0.0),
    (dict(x=2.7, y=0.7), 0.0),  # open along x does not open across: y = 0.7 m is 0.57 of the edge
    (dict(yaw_deg=5.0), 1.0),
    (dict(yaw_deg=6.001), 0.0),
])
def test_the_support_gate_holds_its_bounds_per_axis(pose, expected):
    """Offsets are fractions of the edge of support max(h_A,i, h_B,i) with separate bounds
    along A's x (0.9 -> 1.0) and y (0.45 -> 0.5); yaw 5 -> 6 deg."""
    assert _support_gate(*_pair(SIZE_20FT, SIZE_20FT, **pose))[0] == expected


def test_the_support_gate_opens_on_bridges_and_end_stacks_and_shuts_beside():
    """A 20 ft box at either end of a 40 ft one and a 40 ft box across two 20 ft ones (bridge:
    3.048 m off each support's centre) sit at half the edge of support, either way round; a box
    beside A along x or y (side contact, B's z level) is beyond it."""
    for sA, sB, x in ((SIZE_40FT, SIZE_20FT, 3.067), (SIZE_20FT, SIZE_40FT, 3.067), (SIZE_20FT, SIZE_40FT, 3.048),
                      (SIZE_40FT, SIZE_20FT, -3.048)):
        assert _support_gate(*_pair(sA, sB, x=x))[0] == 1.0
    R = np.eye(3)[None]
    for p in ([[0.5 * (6.058 + 6.058) - 1e-4, 0.0, 0.0]], [[0.0, 2.438 - 1e-4, 0.0]]):
        assert _support_gate(np.array(p), R, SIZE_20FT[None], SIZE_20FT[None])[0] == 0.0


def test_the_support_gate_is_the_same_in_every_frame_and_trained_where_it_opens():
    """On "resting_support" poses (the distribution the support layout's outer bounds come
    from) the gate is open on a share, ramping on a share and shut only beyond the tilt disc;
    every octant frame of a pose gets the same g."""
    p, R, sA, sB = probe_poses(3000, 33, "resting_support")
    g = _support_gate(p, R, sA, sB)
    assert np.mean(g == 1.0) > 0.2 and np.mean((g > 0.0) & (g < 1.0)) > 0.3
    depth = sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1]
    from learned_contact.training.config import support_domain

    for sigma, _ in frame_blend(p):
        p_c, R_c = reflect(sigma, p, R)
        np.testing.assert_array_equal(gate(p_c, R_c, depth, support_domain(), 0.5 * sA, 0.5 * sB), g)


def test_compiled_equals_numpy_with_the_support_gate(support_paths):
    """The native core's support layout against the numpy reference (1e-9), ramps included:
    resting_support (overhangs to the edge of support, 20 ft/40 ft pairs), resting_wider."""
    for k, dist in enumerate(("resting_support", "resting_wider", "resting")):
        p, R, sA, sB = probe_poses(1500, 71 + k, dist)
        a = support_paths["compiled"].predict(p, R, size_A=sA, size_B=sB)
        b = support_paths["numpy"].predict(p, R, size_A=sA, size_B=sB)
        np.testing.assert_allclose(a[0], b[0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(a[1], b[1], rtol=0, atol=1e-9)


def test_the_support_hand_over_is_continuous(support_paths):
    """Across the x ramp (0.9 -> 1.0 of the edge of support: 2.726-3.029 m on a 20 ft pair) a
    step of 1e-9 m moves the answer by < 1e-6, at both bounds and mid-ramp."""
    pred = support_paths["numpy"]
    for x in (0.9 * 3.029, 0.95 * 3.029, 3.029):
        a = pred.predict(*_pair(SIZE_20FT, SIZE_20FT, x=x)[:2], size_A=SIZE_20FT, size_B=SIZE_20FT)
        b = pred.predict(*_pair(SIZE_20FT, SIZE_20FT, x=x + 1e-9)[:2], size_A=SIZE_20FT, size_B=SIZE_20FT)
        assert np.abs(a[0] - b[0]).max() < 1e-6 and np.abs(a[1] - b[1]).max() < 1e-6


def test_the_support_layout_saves_as_version_3_and_both_versions_load(support_paths, shipped, tmp_path):
    """A support-layout expert saves as format_version 3 with 11 bounds and loads back with the
    same answers on both paths; a version-2 file (9 bounds in metres: the issue-20 layout) loads
    as before; a file whose bounds do not match its version is refused naming the field."""
    path = support_paths["numpy"].save(tmp_path / "v3.npz")
    with np.load(path) as z:
        assert int(z["format_version"]) == 3 and z["expert/domain"].shape == (11,)
        arrays = dict(z)
    p, R, sA, sB = probe_poses(300, 81, "resting_support")
    for compiled in (False, True):
        back = load_predictor(path, compiled=compiled)
        np.testing.assert_allclose(back.predict(p, R, size_A=sA, size_B=sB)[0],
                                   support_paths["numpy"].predict(p, R, size_A=sA, size_B=sB)[0], rtol=0, atol=1e-9)
    v2 = shipped.save(tmp_path / "v2.npz")
    with np.load(v2) as z:
        assert int(z["format_version"]) == 2 and z["expert/domain"].shape == (9,)
    np.testing.assert_array_equal(load_predictor(v2).expert_domain, shipped.expert_domain)
    np.savez(tmp_path / "short.npz", **{**arrays, "expert/domain": shipped.expert_domain})
    with pytest.raises(WeightsError, match=r"field 'expert/domain' has shape \(9,\), expected \(11,\)"):
        load_predictor(tmp_path / "short.npz")
    np.savez(tmp_path / "long.npz", **{**arrays, "format_version": np.array(2)})
    with pytest.raises(WeightsError, match=r"field 'expert/domain' has shape \(11,\), expected \(9,\)"):
        load_predictor(tmp_path / "long.npz")
    bad = arrays["expert/domain"].copy()
    bad[[8, 9]] = bad[[9, 8]]
    np.savez(tmp_path / "swapped.npz", **{**arrays, "expert/domain": bad})
    with pytest.raises(WeightsError, match="support_y_in"):
        load_predictor(tmp_path / "swapped.npz")


def test_the_onnx_export_holds_the_support_gate(support_paths, tmp_path):
    """The ONNX graph of a support-layout expert agrees with the compiled path to the export's
    tolerances (1e-6 m, 1e-5 deg) where the gate opens, ramps and shuts."""
    pytest.importorskip("onnx")
    pytest.importorskip("onnxruntime")
    from learned_contact.export.onnx_check import onnx_session, run_onnx
    from learned_contact.export.onnx_export import export_onnx

    onnx_path = export_onnx(support_paths["numpy"].save(tmp_path / "v3.npz"), tmp_path / "v3.onnx")
    session = onnx_session(onnx_path)
    for k, dist in enumerate(("resting_support", "resting_wider")):
        p, R, sA, sB = [np.asarray(a, dtype=np.float32).astype(float) for a in probe_poses(400, 91 + k, dist)]
        got = run_onnx(session, p, R, sA, sB)
        point, normal = support_paths["compiled"].predict(p, R, size_A=sA, size_B=sB)
        assert np.abs(got["point_A"] - point).max() <= 1e-6
        angle = np.degrees(np.arctan2(np.linalg.norm(np.cross(got["normal_A"].astype(float), normal), axis=1),
                                      np.sum(got["normal_A"] * normal, axis=1)))
        assert angle.max() <= 1e-5
