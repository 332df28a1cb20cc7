"""Any model on the bench (learned_contact.sources): ONNX files and Python objects load
behind the Predictor interface, every broken file is one WeightsError line, and bad
answers at run time are refused with a count."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("onnxruntime", reason="pip install onnxruntime==1.30.0")

import bench_models as bm  # noqa: E402

from learned_contact import (  # noqa: E402
    PredictorOutputError,
    WeightsError,
    load_predictor,
    sources,  # noqa: E402
)
from learned_contact.evaluation.gates import GeometricPrior  # noqa: E402
from learned_contact.interface import CLIP_MARGIN  # noqa: E402
from testbed.bodies.containers import CONTAINER_TYPES  # noqa: E402

SIZE_20 = np.array([6.058, 2.438, 2.591])
TESTS = Path(__file__).resolve().parents[1]


def _poses(n=64, seed=3):
    """B resting on A (20 ft on 20 ft), tilted up to 0.02 rad, offset up to 1 m, 0 to 2 cm deep."""
    from testbed.geometry.rotations import rotation_from_rpy

    rng = np.random.default_rng(seed)
    R = rotation_from_rpy(np.column_stack([rng.uniform(-0.02, 0.02, (n, 2)), rng.uniform(-0.1, 0.1, n)]))
    p = np.column_stack([rng.uniform(-1, 1, (n, 2)), SIZE_20[2] - rng.uniform(0, 0.02, n)])
    return p, R


def test_catalogue_names_each_source():
    assert [sources.source_of(s).key for s in (None, "improved", "paper", "m.npz", "m.onnx", "pkg.mod:make")] == \
        ["shipped", "shipped", "shipped", "weights", "onnx", "python"]
    assert [sources.label(s) for s in (None, "paper", "/x/my_model.onnx", "pkg.mod:Maker.build")] == \
        ["improved", "paper", "my_model", "Maker_build"]


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_onnx_model_answers_its_own_maths(tmp_path, dtype):
    """The centre-line model's answers through the bench equal its numpy maths (to float32
    precision, 1e-6 m on metre-sized inputs), inputs converted to the declared type."""
    pred = load_predictor(bm.centre_line_onnx(tmp_path / "m.onnx", dtype=dtype))
    assert (pred.kind, pred.name) == ("onnx", "centre_line")
    p, R = _poses()
    point, normal = pred.predict(p, R, size_A=SIZE_20, size_B=SIZE_20)
    want_point, want_normal = bm.centre_line_numpy(p)
    tol = 1e-6 if dtype == "float32" else 1e-12
    np.testing.assert_allclose(point, want_point, atol=tol)
    np.testing.assert_allclose(normal, want_normal, atol=tol)
    np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-12)  # normalised by the bench
    # the single-pose form, as the Predictor interface promises
    one_point, one_normal = pred.predict(p[0], R[0], size_A=SIZE_20, size_B=SIZE_20)
    assert one_point.shape == (3,) and np.allclose(one_point, point[0])


def test_onnx_depth_output_is_used_and_sat_depth_otherwise(tmp_path):
    from testbed.geometry.boxes import sat_normal

    p, R = _poses(8)
    with_depth = load_predictor(bm.centre_line_onnx(tmp_path / "d.onnx", depth=True))
    np.testing.assert_allclose(with_depth.depth(p, R, size_A=SIZE_20, size_B=SIZE_20), 0.001, atol=1e-7)
    without = load_predictor(bm.centre_line_onnx(tmp_path / "n.onnx"))
    np.testing.assert_allclose(without.depth(p, R, size_A=SIZE_20, size_B=SIZE_20),
                               sat_normal(p, R, SIZE_20 / 2, SIZE_20 / 2)[1], atol=1e-12)


def test_onnx_supported_sizes_come_from_metadata(tmp_path):
    pred = load_predictor(bm.centre_line_onnx(tmp_path / "m.onnx", sizes=[list(SIZE_20)]))
    assert pred.supported_sizes.shape == (1, 3)
    with pytest.raises(Exception, match="not a supported container size"):
        pred.predict(np.array([0, 0, 2.7]), np.eye(3), size_A=SIZE_20, size_B=[12.192, 2.438, 2.591])
    # a model that declares none is asked for every type the testbed simulates
    assert load_predictor(bm.centre_line_onnx(tmp_path / "all.onnx", sizes=None)).supported_sizes.shape == (
        len(CONTAINER_TYPES), 3)


def test_outside_the_domain_the_point_is_clipped(tmp_path):
    """A pose 0.5 m apart (outside DOMAIN_DEPTH; the centre line's point is 1.55 m up, above A's
    top face + CLIP_MARGIN = 1.35 m): clip bounds the point to A's box grown by
    CLIP_MARGIN as for the shipped predictors; outside='raise' refuses it."""
    from learned_contact import PredictorDomainError

    pred = load_predictor(bm.centre_line_onnx(tmp_path / "m.onnx"))
    far = np.array([[0.0, 0.0, SIZE_20[2] + 0.5]])  # B 0.5 m above resting on A
    point, _ = pred.predict(far, np.eye(3)[None], size_A=SIZE_20, size_B=SIZE_20)
    assert point[0, 2] <= SIZE_20[2] / 2 + CLIP_MARGIN + 1e-12 and 0.5 * far[0, 2] > SIZE_20[2] / 2 + CLIP_MARGIN
    with pytest.raises(PredictorDomainError):
        pred.predict(far, np.eye(3)[None], size_A=SIZE_20, size_B=SIZE_20, outside="raise")


BAD_ONNX = {
    "static batch": ({"static_batch": 4}, "static batch axis of 4"),
    "misnamed input": ({"input_names": ("p", "R_AB", "size_A", "size_B")}, "missing \\['p_AB'\\]"),
    "NaN outputs": ({"nan": True}, "hold NaN or inf"),
    "normals off unit": ({"normal_scale": 1.01}, "not unit length"),
    "bad metadata": ({"metadata": {"supported_sizes": "[[1, 2]]"}}, "metadata 'supported_sizes'"),
}


@pytest.mark.parametrize("case", sorted(BAD_ONNX))
def test_broken_onnx_files_are_one_line_naming_the_file(tmp_path, case):
    kwargs, match = BAD_ONNX[case]
    path = bm.centre_line_onnx(tmp_path / "bad.onnx", **kwargs)
    with pytest.raises(WeightsError, match=match) as info:
        load_predictor(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize("what", ["garbage", "empty", "directory", "device", "missing", "oversized"])
def test_unreadable_model_files(tmp_path, monkeypatch, what):
    from learned_contact.predictors import onnx_model

    path = tmp_path / "m.onnx"
    if what == "garbage":
        path.write_bytes(b"\x00not a protobuf" * 100)
    elif what == "empty":
        path.write_bytes(b"")
    elif what == "directory":
        path.mkdir()
    elif what == "device":
        path = Path("/dev/zero")
    elif what == "oversized":
        bm.centre_line_onnx(path)
        monkeypatch.setattr(onnx_model, "MAX_MODEL_BYTES", 100)
    with pytest.raises(WeightsError) as info:
        if what == "device":  # a device given as an ONNX model: refused before it is read
            onnx_model.load_onnx(path)
        else:
            load_predictor(str(path))
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_python_object_predictor_gets_depth_and_sizes_filled_in():
    pred = load_predictor("bench_models:GeometricModel")
    assert (pred.kind, pred.name) == ("python", "geometric") and pred.supported_sizes.shape == (len(CONTAINER_TYPES), 3)
    p, R = _poses()
    point, normal = pred.predict(p, R, size_A=SIZE_20, size_B=SIZE_20)
    want = GeometricPrior().predict(p, R, size_A=SIZE_20, size_B=SIZE_20)
    np.testing.assert_allclose(point, want[0], atol=1e-12)
    np.testing.assert_allclose(normal, want[1], atol=1e-12)
    np.testing.assert_allclose(pred.depth(p, R, size_A=SIZE_20, size_B=SIZE_20),
                               load_predictor().depth(p, R, size_A=SIZE_20, size_B=SIZE_20), atol=1e-9)


@pytest.mark.parametrize("spec, match", [
    ("bench_models:NaNModel", rf"{len(CONTAINER_TYPES) ** 2 + 2} of {len(CONTAINER_TYPES) ** 2 + 2} answers hold NaN"),
    ("bench_models:not_a_model", "without predict"),
    ("bench_models:Missing", "no attribute 'Missing'"),
    ("no_such_module_xyz:make", "cannot import module"),
])
def test_broken_python_models(spec, match):
    with pytest.raises(WeightsError, match=match) as info:
        load_predictor(spec)
    assert spec in str(info.value)


def test_run_time_nan_is_refused_with_a_count():
    pred = load_predictor("bench_models:LateNaNModel")  # passes the load-time probe
    p, R = _poses(10)
    p[[2, 5, 7], 2] = 3.5  # three poses the model answers with NaN
    with pytest.raises(PredictorOutputError, match="3 of 10 answers hold NaN"):
        pred.predict(p, R, size_A=SIZE_20, size_B=SIZE_20)


def test_cli_names_the_bad_model_and_exits_2(tmp_path):
    path = bm.centre_line_onnx(tmp_path / "bad.onnx", static_batch=2)
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "testbed.cli", "compare", "two_stack", "--predictor", str(path),
                           "--duration", "0.01", "--out", str(out), "--no-replay"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and "static batch axis" in lines[0]
    assert not out.exists()


@pytest.mark.parametrize("suffix", [".npz", ".onnx"])
def test_a_fifo_model_file_is_refused_without_blocking(tmp_path, suffix):
    """A named pipe given as a model would block the reader forever: refused from stat()."""
    import os
    import time

    path = tmp_path / f"pipe{suffix}"
    os.mkfifo(path)
    t0 = time.perf_counter()
    with pytest.raises(WeightsError, match="FIFO") as info:
        load_predictor(str(path))
    assert time.perf_counter() - t0 < 2.0 and str(path) in str(info.value)


def test_a_weights_zip_bomb_is_refused_from_the_zip_directory(tmp_path, monkeypatch):
    """Arrays that unpack beyond the limit are refused before numpy reads any (the limit is
    lowered here so that a 1 MB array stands in for a bomb)."""
    from learned_contact.predictors import loading

    path = tmp_path / "bomb.npz"
    np.savez_compressed(path, big=np.zeros(2**17))  # 1 MiB of zeros, ~1 kB on disk
    monkeypatch.setattr(loading, "MAX_WEIGHTS_BYTES", 64 * 1024)
    with pytest.raises(WeightsError, match="unpack to") as info:
        load_predictor(str(path))
    assert str(path) in str(info.value)
