"""ONNX export of the shipped predictors (learned_contact.export.onnx_export), the PyTorch
export helper and `testbed export-onnx`: the exported files, run with onnxruntime on
the CPU, agree with the predictors' numpy reference paths on held-out poses (the improved
one's compiled path is held to its numpy path in tests/learned/test_learned_compiled.py) and
follow the contract (names, shapes, dynamic batch axis, metadata)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

onnx = pytest.importorskip("onnx")
pytest.importorskip("onnxruntime")

from learned_contact import WeightsError, load_predictor  # noqa: E402
from learned_contact.evaluation.gates import OUTSIDE_RANGES  # noqa: E402
from learned_contact.export.onnx_check import onnx_session, probe_poses, run_onnx  # noqa: E402
from learned_contact.export.onnx_export import export_onnx, export_torch_model  # noqa: E402

KINDS = ("paper", "improved")
SEED = 31337  # held-out: the gates use 10 * seed + 5..7 for small seeds, training + 1, + 2
# Largest allowed difference to the reference predictor (`_reference`) given the same
# (float32-rounded) poses:
# - improved: the graph computes in float64 and casts its answers to float32, so only that
#   rounding remains: half a float32 ulp of a coordinate below 8 m is 2.4e-7 m (measured
#   2.4e-7 m with the face-on-face quadrature), of a unit normal 3e-8 rad (measured 2.4e-6 deg);
#   bounds 4x that.
# - paper: float32 throughout (onnxruntime has no float64 Atan/Asin): ~1e-7 relative rounding of
#   6 inputs of up to 6 m and of the angles, through two tanh layers (20, 18) and the spherical
#   decoding, lands ~1e-6 rad on the output angles, times up to 6.1 m of reach: measured
#   9.6e-6 m and 3.5e-5 deg on 800 poses; bounds 5x that.
TOLERANCE = {"improved": {"point": 1e-6, "normal_deg": 1e-5}, "paper": {"point": 5e-5, "normal_deg": 2e-4}}
DEPTH_TOLERANCE = 1e-7  # [m] float32 rounding of a depth below 0.1 m is < 4e-9 m; computed in float64


def _reference(kind):
    """The predictor an export is held to: its numpy reference path (the compiled paths agree
    with it to rounding: tests/learned/test_learned_compiled.py)."""
    return load_predictor(kind, compiled=False)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("onnx")
    return {kind: export_onnx(kind, out / f"{kind}.onnx") for kind in KINDS}


def _pose_sets():
    """The gates' held-out sets (general, stacking, outside the training distribution) plus
    poses out of the answered domain: 8 cm deep and separated (p_AB pushed out by 2 %)."""
    sets = {"general": probe_poses(300, SEED, "general"), "stacking": probe_poses(300, SEED, "stacking"),
            "outside": probe_poses(300, SEED + 1, "stacking", **OUTSIDE_RANGES),
            "deep": probe_poses(300, SEED + 2, "general", max_depth=0.08)}
    p, R, a, b = probe_poses(200, SEED + 3, "general")
    sets["separated"] = (1.02 * p, R, a, b)
    return sets


def _angle_deg(a, b):
    """(n,) angle between rows [deg], from atan2(|a x b|, a . b) (exact near 0)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1)))


@pytest.mark.parametrize("kind", KINDS)
def test_export_agrees_with_compiled_predictor(exported, kind):
    pred = _reference(kind)
    session = onnx_session(exported[kind])
    clipped = 0
    for name, poses in _pose_sets().items():
        p, R, a, b = [np.asarray(x, dtype=np.float32).astype(float) for x in poses]  # both see the same poses
        got = run_onnx(session, p, R, a, b)
        point, normal = pred.predict(p, R, size_A=a, size_B=b)
        depth = pred.depth(p, R, size_A=a, size_B=b)
        assert got["point_A"].dtype == np.float32 and got["point_A"].shape == (len(p), 3)
        assert np.all(np.isfinite(got["point_A"])) and np.all(np.isfinite(got["normal_A"]))
        point_diff = np.abs(got["point_A"] - point).max()
        angle = _angle_deg(got["normal_A"], normal).max()
        assert point_diff <= TOLERANCE[kind]["point"], f"{kind} {name}: point differs by {point_diff:.3g} m"
        assert angle <= TOLERANCE[kind]["normal_deg"], f"{kind} {name}: normal differs by {angle:.3g} deg"
        assert np.abs(np.linalg.norm(got["normal_A"], axis=1) - 1.0).max() < 1e-6
        assert np.abs(got["depth"] - depth).max() <= DEPTH_TOLERANCE, name
        outside = (depth < -0.01) | (depth > 0.05)
        clipped += int(outside.sum())
    assert clipped > 200  # the deep and separated sets exercise outside="clip" in the graph


def _face_on_face_poses(n, seed, max_tilt_deg):
    """B on A's top face at a separating-axis depth of 5 um - 0.5 mm (log-uniform), B's centre
    offset up to 3 m x 0.6 m, yaw within 6 deg; resting (max_tilt_deg None: roll and pitch within
    0.05 deg) or tilted by up to max_tilt_deg about a random horizontal axis. Sizes from the
    shipped improved predictor's supported_sizes. (p, R, size_A, size_B) float64."""
    from scipy.spatial.transform import Rotation

    from testbed.geometry.boxes import sat_normal

    sizes = load_predictor("improved", compiled=False).supported_sizes
    rng = np.random.default_rng(seed)
    a, b = sizes[rng.integers(0, len(sizes), n)], sizes[rng.integers(0, len(sizes), n)]
    yaw = Rotation.from_euler("z", np.radians(rng.uniform(-6.0, 6.0, (n, 1))))
    if max_tilt_deg is None:
        tilt = Rotation.from_euler("xy", np.radians(rng.uniform(-0.05, 0.05, (n, 2))))
    else:
        axis = np.c_[rng.normal(size=(n, 2)), np.zeros(n)]
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        tilt = Rotation.from_rotvec(axis * np.radians(rng.uniform(0.0, max_tilt_deg, (n, 1))))
    R = (tilt * yaw).as_matrix()
    xy = np.c_[rng.uniform(-3.0, 3.0, n), rng.uniform(-0.6, 0.6, n)]
    depth = np.exp(rng.uniform(np.log(5e-6), np.log(5e-4), n))
    lo, hi = np.zeros(n), np.full(n, 30.0)  # B's height: lo overlapping deeper than depth, hi not
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        deep = sat_normal(np.c_[xy, mid], R, 0.5 * a, 0.5 * b)[1] > depth
        lo, hi = np.where(deep, mid, lo), np.where(deep, hi, mid)
    return np.c_[xy, hi], R, a, b


def test_improved_export_reproduces_the_face_on_face_quadrature(exported):
    """Where two faces meet the improved predictor answers with the exact face-on-face centre
    of pressure (learned_contact.model.quadrature: Drake's linear pressure integrated exactly
    over its contact surface), handed over to the learned pipeline as the faces tilt (point
    from 20 to 30 deg, normal from 2 to 4 deg): the graph reproduces it to the export's
    tolerances on resting stacks, on stacks tilted by up to 40 deg (both hand-over ramps
    crossed) and on random poses. Measured with the one-point rule it replaced (2,000
    resting, 2,000 tilted, 5,000 random poses): 2.4e-7 m, 2.4e-6 deg; with the exact integral
    (these 400, 600 and 1,000 poses): 2.4e-7 m, 2.4e-6 deg, the answers' float32 rounding (the
    one-point answer it replaced lies 24 mm (median) and 0.55 m (worst) from the exact one on
    the resting stacks, 0.08 mm and 0.42 m on the tilted ones: far outside these bounds)."""
    from scipy.spatial.transform import Rotation

    from learned_contact.model.quadrature import NORMAL_TILT, POINT_TILT, face_on_face, hand_over
    from testbed.geometry.boxes import sat_normal

    pred = _reference("improved")
    session = onnx_session(exported["improved"])
    rng = np.random.default_rng(SEED + 10)
    sizes = pred.supported_sizes
    sets = {"resting": _face_on_face_poses(400, SEED + 11, None), "tilted": _face_on_face_poses(600, SEED + 12, 40.0),
            "random": (rng.uniform(-8.0, 8.0, (1000, 3)), Rotation.random(1000, random_state=SEED + 13).as_matrix(),
                       sizes[rng.integers(0, len(sizes), 1000)], sizes[rng.integers(0, len(sizes), 1000)])}
    ramps = {"point": 0, "normal": 0}
    for name, poses in sets.items():
        p, R, a, b = [np.asarray(x, dtype=np.float32).astype(float) for x in poses]
        got = run_onnx(session, p, R, a, b)
        point, normal = pred.predict(p, R, size_A=a, size_B=b)
        point_diff = np.abs(got["point_A"] - point).max()
        angle = _angle_deg(got["normal_A"], normal).max()
        assert point_diff <= TOLERANCE["improved"]["point"], f"{name}: point differs by {point_diff:.3g} m"
        assert angle <= TOLERANCE["improved"]["normal_deg"], f"{name}: normal differs by {angle:.3g} deg"
        # the comparison is not vacuous: the quadrature answers, fully and on its hand-over ramps
        n_AB, depth, _ = sat_normal(p, R, 0.5 * a, 0.5 * b)
        weight, tilt = face_on_face(p, R, 0.5 * a, 0.5 * b, n_AB)[2:]
        meet = (weight > 0.0) & (depth >= -0.01) & (depth <= 0.05)
        if name == "resting":
            assert meet.sum() >= len(p) // 2 and np.all(hand_over(tilt[meet], NORMAL_TILT) == 1.0)
        for key, band in (("point", POINT_TILT), ("normal", NORMAL_TILT)):
            f = hand_over(tilt, band)
            ramps[key] += int((meet & (f > 0.0) & (f < 1.0)).sum())
    assert ramps["point"] >= 50 and ramps["normal"] >= 20, ramps


def test_improved_export_clips_outside_the_domain(exported):
    """The graph reproduces outside='clip': the numpy path without the clip would place
    some of these points further than CLIP_MARGIN outside A; the graph never does."""
    from learned_contact.interface import CLIP_MARGIN

    p, R, a, b = probe_poses(200, SEED + 4, "general")
    got = run_onnx(onnx_session(exported["improved"]), 1.2 * p, R, a, b)  # separated by ~0.1-1 m
    assert np.all(np.abs(got["point_A"]) <= 0.5 * a + CLIP_MARGIN + 1e-6)
    assert np.all(got["depth"] < -0.01)


@pytest.mark.parametrize("kind", KINDS)
def test_contract_names_shapes_dynamic_axis_metadata(exported, kind):
    model = onnx.load(exported[kind])
    expected_in = {"p_AB": [3], "R_AB": [3, 3], "size_A": [3], "size_B": [3]}
    assert [i.name for i in model.graph.input] == list(expected_in)
    for value in model.graph.input:
        t = value.type.tensor_type
        assert t.elem_type == onnx.TensorProto.FLOAT
        assert t.shape.dim[0].dim_param == "n" and not t.shape.dim[0].HasField("dim_value")
        assert [d.dim_value for d in t.shape.dim[1:]] == expected_in[value.name]
    outputs = {o.name: o.type.tensor_type for o in model.graph.output}
    assert list(outputs) == ["point_A", "normal_A", "depth"]
    for name, rest in (("point_A", [3]), ("normal_A", [3]), ("depth", [])):
        assert outputs[name].elem_type == onnx.TensorProto.FLOAT
        assert outputs[name].shape.dim[0].dim_param == "n"
        assert [d.dim_value for d in outputs[name].shape.dim[1:]] == rest
    meta = {p.key: p.value for p in model.metadata_props}
    assert meta["name"] == kind
    np.testing.assert_array_equal(np.array(json.loads(meta["supported_sizes"])), load_predictor(kind).supported_sizes)
    assert {o.domain for o in model.opset_import} == {""} and model.opset_import[0].version == 17
    session = onnx_session(exported[kind])
    p, R, a, b = probe_poses(7, SEED + 5)
    for n in (1, 7):  # the batch axis really is dynamic
        got = run_onnx(session, p[:n], R[:n], a[:n], b[:n])
        assert got["point_A"].shape == (n, 3) and got["normal_A"].shape == (n, 3) and got["depth"].shape == (n,)


@pytest.mark.parametrize("kind", KINDS)
def test_float64_batch_converted_to_float32(exported, kind):
    """A float64 batch, converted to float32 by run_onnx, gives exactly the float32 batch's
    answer; against the reference predictor on the unrounded float64 poses the answers
    differ only by what rounding the inputs to float32 (~1e-7 relative) moves the predictor:
    the improved one's geometric prior amplifies it on shallow contacts (a 1e-7 m change of a
    0.3 mm depth moves its depth-weighted patch; measured up to 1.1 mm, p99 0.3 mm, 0.065 deg
    on held-out poses before the face-on-face quadrature, 0.24 mm and 0.027 deg with it, on
    4 x 300 stacking poses), the paper's smooth pipeline does not (measured 9e-6 m)."""
    session = onnx_session(exported[kind])
    p, R, a, b = probe_poses(300, SEED + 6, "stacking")
    got64 = run_onnx(session, p, R, a, b)
    feed = {k: np.asarray(v, dtype=np.float32) for k, v in zip(("p_AB", "R_AB", "size_A", "size_B"), (p, R, a, b))}
    got32 = dict(zip(["point_A", "normal_A", "depth"], session.run(["point_A", "normal_A", "depth"], feed)))
    for name, value in got32.items():
        np.testing.assert_array_equal(got64[name], value)
    point, normal = _reference(kind).predict(p, R, size_A=a, size_B=b)
    bound = {"improved": (3e-3, 0.2), "paper": (5e-5, 2e-4)}[kind]
    assert np.abs(got64["point_A"] - point).max() <= bound[0]
    assert _angle_deg(got64["normal_A"], normal).max() <= bound[1]


def test_bad_name_or_path_raises_one_line_and_writes_nothing(tmp_path):
    out = tmp_path / "x.onnx"
    with pytest.raises(WeightsError, match="nosuch.npz") as info:
        export_onnx(tmp_path / "nosuch.npz", out)
    assert "\n" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_export_from_weights_file(exported, tmp_path):
    """A weights .npz (as load_predictor accepts) exports like its name; the metadata name
    defaults to the file's stem."""
    weights = load_predictor("paper", compiled=False).save(tmp_path / "my_paper.npz")
    path = export_onnx(weights, tmp_path / "from_file.onnx")
    assert {p.key: p.value for p in onnx.load(path).metadata_props}["name"] == "my_paper"
    p, R, a, b = probe_poses(50, SEED + 8)
    by_file, by_name = run_onnx(onnx_session(path), p, R, a, b), run_onnx(onnx_session(exported["paper"]), p, R, a, b)
    for name, value in by_name.items():
        np.testing.assert_array_equal(by_file[name], value)


def test_export_leaves_no_temporary_file(exported):
    folder = exported["paper"].parent
    assert sorted(p.name for p in folder.iterdir()) == ["improved.onnx", "paper.onnx"]


@pytest.mark.torch
def test_torch_model_export_matches_torch(tmp_path):
    torch = pytest.importorskip("torch")

    class Tiny(torch.nn.Module):
        """A toy predictor: fixed (seeded) weights over the pose and sizes."""

        def __init__(self):
            super().__init__()
            torch.manual_seed(7)
            self.net = torch.nn.Sequential(torch.nn.Linear(18, 16), torch.nn.SiLU(), torch.nn.Linear(16, 6))

        def forward(self, p_AB, R_AB, size_A, size_B):
            y = self.net(torch.cat([p_AB, R_AB.reshape(-1, 9), size_A, size_B], dim=1))
            point = 0.5 * size_A * torch.tanh(p_AB + 0.1 * y[:, :3])
            return point, torch.nn.functional.normalize(p_AB + y[:, 3:], dim=1)

    module = Tiny()
    sizes = [[6.058, 2.438, 2.591], [12.192, 2.438, 2.591]]
    path = export_torch_model(module, tmp_path / "tiny.onnx", supported_sizes=sizes, name="tiny")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tiny.onnx"]
    model = onnx.load(path)
    assert [i.name for i in model.graph.input] == ["p_AB", "R_AB", "size_A", "size_B"]
    assert [o.name for o in model.graph.output] == ["point_A", "normal_A"]
    assert all(v.type.tensor_type.shape.dim[0].dim_param == "n" for v in [*model.graph.input, *model.graph.output])
    meta = {p.key: p.value for p in model.metadata_props}
    assert meta["name"] == "tiny" and json.loads(meta["supported_sizes"]) == sizes
    p, R, a, b = probe_poses(50, SEED + 7)
    got = run_onnx(onnx_session(path), p, R, a, b)
    with torch.no_grad():
        point, normal = module(*[torch.tensor(v, dtype=torch.float32) for v in (p, R, a, b)])
    # the same float32 operations in both runtimes; kernels may sum in another order: a few ulps
    np.testing.assert_allclose(got["point_A"], point.numpy(), rtol=0, atol=2e-6)
    np.testing.assert_allclose(got["normal_A"], normal.numpy(), rtol=0, atol=1e-6)


def test_torch_missing_names_the_pin(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "torch", None)  # `import torch` raises ImportError
    with pytest.raises(WeightsError, match=r"pip install torch==2\.13\.0"):
        export_torch_model(object(), tmp_path / "m.onnx", supported_sizes=[[1, 1, 1]], name="m")


def test_import_learned_contact_imports_neither_torch_nor_onnx():
    code = ("import sys, learned_contact, learned_contact.export.onnx_export; "
            "print(sorted(m for m in ('torch', 'onnx', 'onnxruntime') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_cli_export_onnx(tmp_path, capsys):
    from testbed.cli import main

    out = tmp_path / "sub" / "paper.onnx"
    assert main(["export-onnx", "paper", "--out", str(out), "--name", "paper-export", "--probe", "50"]) == 0
    printed = capsys.readouterr().out
    assert str(out) in printed and "max |point| diff" in printed
    assert {p.key: p.value for p in onnx.load(out).metadata_props}["name"] == "paper-export"
    assert main(["export-onnx", "nosuch", "--out", str(tmp_path / "n.onnx")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nosuch" in err
    assert not (tmp_path / "n.onnx").exists()


@pytest.mark.parametrize("kind", KINDS)
def test_round_trip_through_the_bench_loader(exported, kind):
    """export -> learned_contact.load_predictor(.onnx) -> the same answers as the reference
    predictor on float32-exact poses (the loader's checks, normalisation and clip change
    nothing), and the same depth; the tolerances are the export test's (TOLERANCE)."""
    onnx_pred = load_predictor(exported[kind])
    assert onnx_pred.kind == "onnx" and onnx_pred.name == kind
    reference = _reference(kind)
    p, R, a, b = (np.asarray(v, dtype=np.float32).astype(float) for v in probe_poses(300, SEED + 8, "stacking"))
    point, normal = onnx_pred.predict(p, R, size_A=a, size_B=b)
    want_point, want_normal = reference.predict(p, R, size_A=a, size_B=b)
    assert np.abs(point - want_point).max() <= TOLERANCE[kind]["point"]
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", normal, want_normal), -1, 1))).max()
    assert angle <= TOLERANCE[kind]["normal_deg"] + 1e-6  # + arccos's own resolution near 1
    np.testing.assert_allclose(onnx_pred.depth(p, R, size_A=a, size_B=b), reference.depth(p, R, size_A=a, size_B=b),
                               atol=DEPTH_TOLERANCE)


@pytest.mark.torch
def test_torch_model_exported_then_benched(tmp_path):
    """The README's path for a user's model: a torch module -> export_torch_model -> the
    bench's loader answers like the module (and checks it like any model)."""
    torch = pytest.importorskip("torch")

    class Centre(torch.nn.Module):
        def forward(self, p_AB, R_AB, size_A, size_B):
            return 0.5 * p_AB, torch.nn.functional.normalize(p_AB, dim=1)

    sizes = load_predictor("improved").supported_sizes.tolist()
    path = export_torch_model(Centre(), tmp_path / "centre.onnx", supported_sizes=sizes, name="centre")
    pred = load_predictor(str(path))
    assert (pred.kind, pred.name) == ("onnx", "centre")
    p, R, a, b = probe_poses(20, SEED + 9)
    point, normal = pred.predict(p, R, size_A=a, size_B=b)
    inside = np.asarray(pred.in_domain(p, R, size_A=a, size_B=b))
    assert inside.sum() >= 10  # the held-out poses are in contact: the comparison is not vacuous
    np.testing.assert_allclose(point[inside], 0.5 * p[inside], atol=1e-6)
    np.testing.assert_allclose(normal, p / np.linalg.norm(p, axis=1, keepdims=True), atol=1e-6)
