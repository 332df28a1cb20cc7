"""Every predictor answers the one interface (learned_contact.interface.Predictor), and
is loaded by the kind recorded in its weights file."""

import json

import numpy as np
import pytest

from learned_contact import Predictor, WeightsError, load_predictor
from learned_contact.predictors.loading import SHIPPED
from testbed.bodies.containers import CONTAINER_TYPES

SIZE_20 = np.array(CONTAINER_TYPES["1CC"].size)
SIZE_40 = np.array(CONTAINER_TYPES["1AA"].size)


def _arrays(name):
    with np.load(SHIPPED[name]) as z:
        return {k: z[k] for k in z.files}


@pytest.fixture(scope="module")
def user_file(tmp_path_factory):
    """A user's own weights: the improved network with perturbed weights, saved by save()."""
    pred = load_predictor("improved", compiled=False)
    rng = np.random.default_rng(3)
    mlp = pred.mlp
    weights = tuple(W + 0.01 * rng.normal(size=W.shape) for W in mlp.weights)
    mine = type(pred)(type(mlp)(weights, mlp.biases, mlp.activation, mlp.x_mean, mlp.x_std),
                      pred.supported_sizes, {"owner": "a user"})
    return mine.save(tmp_path_factory.mktemp("user") / "mine.npz")


def _all(user_file):
    return [("improved", load_predictor(compiled=c)) for c in (True, False)] + \
        [("paper", load_predictor("paper", compiled=c)) for c in (True, False)] + \
        [("improved", load_predictor(user_file, compiled=c)) for c in (True, False)]


def test_every_predictor_conforms(user_file):
    p = np.array([[0.3, 0.2, 2.58], [1.0, -0.4, 2.575], [0.0, 0.0, 2.59]])
    R = np.stack([np.eye(3)] * 3)
    for kind, pred in _all(user_file):
        assert isinstance(pred, Predictor), kind
        assert pred.kind == kind
        assert pred.supported_sizes.shape[1] == 3 and len(pred.supported_sizes) >= 1
        point, normal = pred.predict(p, R, size_A=SIZE_40, size_B=SIZE_20)
        assert point.shape == (3, 3) and normal.shape == (3, 3)
        np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-12)
        assert np.all(normal[:, 2] > 0.9), kind  # stacked: the normal points up, out of A into B
        p1, n1 = pred.predict(p[1], R[1], size_A=SIZE_40, size_B=SIZE_20)
        assert p1.shape == (3,) and n1.shape == (3,)
        np.testing.assert_allclose(p1, point[1], atol=1e-12)
        depth = pred.depth(p, R, size_A=SIZE_40, size_B=SIZE_20)
        assert depth.shape == (3,)
        np.testing.assert_allclose(depth, [0.011, 0.016, 0.001], atol=1e-12)  # 2.591 - z, face on face
        assert isinstance(pred.depth(p[0], R[0], size_A=SIZE_40, size_B=SIZE_20), float)
        assert pred.in_domain(p, R, size_A=SIZE_40, size_B=SIZE_20).tolist() == [True] * 3


def test_names_and_paths_load_the_same_predictor():
    for name in ("improved", "paper"):
        a, b = load_predictor(name), load_predictor(SHIPPED[name])
        assert a.kind == b.kind == name
        for Wa, Wb in zip(a.mlp.weights, b.mlp.weights):
            assert np.array_equal(Wa, Wb)
    assert load_predictor().kind == "improved"


def test_user_file_records_its_kind(user_file):
    with np.load(user_file) as z:
        assert str(z["kind"]) == "improved" and int(z["format_version"]) == 1
    assert load_predictor(user_file).meta == {"owner": "a user"}


@pytest.mark.parametrize("name", ["improved", "paper"])
def test_files_without_kind_are_recognised(tmp_path, name):
    """Files written before `kind` existed: the improved one by its supported_sizes, the
    paper one by its 6-input network (and no format_version)."""
    arrays = _arrays(name)
    del arrays["kind"]
    if name == "paper":
        for key in ("format_version", "supported_sizes", "meta"):
            del arrays[key]
    np.savez(tmp_path / "old.npz", **arrays)
    old, new = load_predictor(tmp_path / "old.npz"), load_predictor(name)
    assert old.kind == name
    np.testing.assert_array_equal(old.supported_sizes, new.supported_sizes)
    p, R = np.array([0.2, 0.1, 2.58]), np.eye(3)
    np.testing.assert_array_equal(old.predict(p, R, size_A=SIZE_20, size_B=SIZE_20)[0],
                                  new.predict(p, R, size_A=SIZE_20, size_B=SIZE_20)[0])


def _broken(tmp_path, name, **changes):
    arrays = _arrays(name)
    for key, value in changes.items():
        if value is None:
            del arrays[key]
        else:
            arrays[key] = value
    path = tmp_path / "broken.npz"
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize("changes, match", [
    (dict(kind=np.array("transformer")), r"field 'kind' is 'transformer'; expected one of \['improved', 'paper'\]"),
    (dict(format_version=np.array(7)), r"field 'format_version' is 7; expected 1 or 2"),
    (dict(**{"mlp/W1": np.zeros((5, 64))}), r"field 'mlp/W1' has shape \(5, 64\)"),
    (dict(**{"mlp/b2": None}), r"field 'mlp/b2' is missing"),
    (dict(**{"mlp/activation": np.array("gelu")}), r"field 'mlp/activation' is 'gelu'"),
    (dict(supported_sizes=np.zeros((2, 2))), r"field 'supported_sizes' has shape \(2, 2\)"),
    (dict(meta=np.array("{not json")), r"field 'meta' is not JSON"),
    (dict(kind=np.array("paper")), r"field 'mlp/W0' has shape \(91, \d+\) \(bias \(\d+,\)\); expected \(6, m\)"),
    # the resting expert (format_version 2, learned_contact.model.expert)
    (dict(format_version=np.array(1)), r"field 'format_version' is 1 but the file carries a resting expert"),
    (dict(**{f"expert/{k}": None for k in ("W0", "W1", "W2", "b0", "b1", "b2", "x_mean", "x_std", "activation", "domain")}),
     r"field 'expert/W0' is missing \(format_version 2 carries a resting expert\)"),
    (dict(**{"expert/domain": None}), r"field 'expert/domain' is missing"),
    (dict(**{"expert/domain": np.zeros(8)}), r"field 'expert/domain' has shape \(8,\), expected \(9,\)"),
    (dict(**{"expert/domain": np.array([1e-3, 5e-4, 0, 1, 0, 1, 0, 1.0, 0.01])}),
     r"depth_in \[m\] = 0.001 .* expected 0 <= in < out"),
    (dict(**{"expert/domain": np.array([5e-4, 1e-3, 0, 1, 0, 1, 0, 1.0, 0.0])}), r"r_slab = 0.0: expected > 0"),
    (dict(**{"expert/domain": np.array([np.nan] * 9)}), r"field 'expert/domain' holds NaN or inf"),
    (dict(**{"expert/W1": np.zeros((5, 64))}), r"field 'expert/W1' has shape \(5, 64\)"),
    (dict(**{"expert/x_std": np.full(91, np.inf)}), r"field 'expert/\*' holds NaN or inf"),
])
def test_bad_files_raise_weights_errors_naming_file_and_field(tmp_path, changes, match):
    path = _broken(tmp_path, "improved", **changes)
    with pytest.raises(WeightsError, match=match) as info:
        load_predictor(path)
    assert str(path) in str(info.value)


def test_corrupt_and_missing_files(tmp_path):
    bad = tmp_path / "corrupt.npz"
    bad.write_bytes(b"not a zip file at all")
    with pytest.raises(WeightsError, match="cannot read weights file .*corrupt.npz"):
        load_predictor(bad)
    with pytest.raises(WeightsError, match="not found"):
        load_predictor(tmp_path / "absent.npz")
    with pytest.raises(WeightsError, match="not found"):
        load_predictor(tmp_path / "absent" / "weights")  # a path: the file is not found


def test_shipped_meta_is_json():
    for name in ("improved", "paper"):
        json.dumps(load_predictor(name).meta)


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("R, what", [
    (np.eye(3) * 2.0, "scaled"),
    (np.diag([1.0, 1.0, -1.0]), "a reflection (det -1)"),
    (np.array([[1.0, 1e-3, 0], [0, 1, 0], [0, 0, 1]]), "sheared by 1e-3"),
])
def test_a_matrix_that_is_not_a_rotation_is_refused(compiled, R, what):
    """Every predictor, both paths: R_AB must be orthonormal with det +1 (ROTATION_TOLERANCE)."""
    from learned_contact.errors import PredictorInputError

    size = [6.058, 2.438, 2.591]
    for name in ("improved", "paper"):
        pred = load_predictor(name, compiled=compiled)
        with pytest.raises(PredictorInputError, match=r"R_AB\[1\] is not a rotation matrix"):
            pred.predict(np.array([[0, 0, 2.59]] * 2), np.stack([np.eye(3), R]), size_A=size, size_B=size)


def test_every_array_layout_gets_the_fast_paths_answer():
    """The native core's fast path reads numpy arrays in place (float64, native byte order,
    C-contiguous); every other layout of the same values (byte-swapped, strided, Fortran order,
    float32 sizes, lists) goes through the converting path and must get the same bits. A fast
    path that read a swapped or strided array as if contiguous answers garbage here."""
    pred = load_predictor("improved")
    size = np.array([6.058, 2.438, 2.591])
    rng = np.random.default_rng(5)
    p = np.column_stack([rng.uniform(-0.3, 0.3, 4), rng.uniform(-0.3, 0.3, 4), np.full(4, 2.57)])
    R = np.stack([np.eye(3)] * 4)
    R[1:, :2, :2] = [[np.cos(0.05), -np.sin(0.05)], [np.sin(0.05), np.cos(0.05)]]
    point, normal = pred.predict(p, R, size_A=size, size_B=size)
    layouts = {
        "byte-swapped": (p.astype(">f8"), R.astype(">f8"), size.astype(">f8")),
        "strided": (np.repeat(p, 2, axis=0)[::2], np.repeat(R, 2, axis=0)[::2], np.repeat(size, 2)[::2]),
        "Fortran order": (np.asfortranarray(p), np.asfortranarray(R), size),
        "lists": (p.tolist(), R.tolist(), size.tolist()),
    }
    for what, (p_, R_, s_) in layouts.items():
        got = pred.predict(p_, R_, size_A=s_, size_B=s_)
        assert np.array_equal(got[0], point) and np.array_equal(got[1], normal), what
        single = pred.predict(p_[1], R_[1], size_A=s_, size_B=s_)
        assert np.array_equal(single[0], point[1]) and np.array_equal(single[1], normal[1]), what
