"""Public API of learned_contact: shapes, errors, no torch import."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from learned_contact import PredictorInputError, WeightsError, load_predictor
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.errors import TestbedError

REPO = Path(__file__).resolve().parents[2]
SIZE_1AA = np.array(CONTAINER_TYPES["1AA"].size)
SIZE_1CC = np.array(CONTAINER_TYPES["1CC"].size)


@pytest.fixture(scope="module")
def pred():
    return load_predictor()


def test_import_and_predict_do_not_import_torch():
    code = (
        "import sys, numpy as np\n"
        "import learned_contact\n"
        "assert 'torch' not in sys.modules\n"
        "pred = learned_contact.load_predictor()\n"
        "p = np.array([[0.5, 0.1, 2.58]]); R = np.eye(3)[None]\n"
        "pred.predict(p, R, size_A=(12.192, 2.438, 2.591), size_B=(6.058, 2.438, 2.591))\n"
        "print(json.dumps(sorted(m for m in sys.modules if m == 'torch' or m.startswith('torch.'))))\n"
    )
    # (pydrake does get imported: learned_contact's errors derive from testbed.errors, and
    # importing the testbed package loads pydrake by design.)
    out = subprocess.run([sys.executable, "-c", "import json\n" + code], cwd=REPO, capture_output=True,
                         text=True, check=True)
    assert json.loads(out.stdout.strip()) == []


def test_batched_and_single_shapes(pred):
    p = np.array([[0.3, 0.2, 2.58], [1.0, -0.4, 2.575]])
    R = np.stack([np.eye(3), np.eye(3)])
    point, normal = pred.predict(p, R, size_A=SIZE_1AA, size_B=SIZE_1CC)
    assert point.shape == (2, 3) and normal.shape == (2, 3)
    np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-12)
    p1, n1 = pred.predict(p[1], R[1], size_A=SIZE_1AA, size_B=SIZE_1CC)
    assert p1.shape == (3,) and n1.shape == (3,)
    np.testing.assert_allclose(p1, point[1], atol=1e-12)
    # per-row sizes give the same answer as broadcast ones
    p2, _ = pred.predict(p, R, size_A=np.tile(SIZE_1AA, (2, 1)), size_B=np.tile(SIZE_1CC, (2, 1)))
    np.testing.assert_allclose(p2, point, atol=1e-12)


def test_aligned_stack_answer_is_sensible(pred):
    # a 20 ft box centred on a 40 ft box, 1 cm deep: normal up, point near the top centre
    p = np.array([[0.0, 0.0, 2.591 - 0.01]])
    point, normal = pred.predict(p, np.eye(3)[None], size_A=SIZE_1AA, size_B=SIZE_1CC)
    assert np.degrees(np.arccos(normal[0, 2])) < 1.0
    assert np.linalg.norm(point[0] - [0, 0, 1.2955]) < 0.1


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(p_AB=np.full((1, 3), np.nan)), "finite"),
        (dict(p_AB=np.zeros((1, 2))), "expected p_AB"),
        (dict(R_AB=np.eye(3)[None].repeat(2, 0)), "expected p_AB"),
        (dict(size_A=(3.0, 2.0, 2.0)), "not a supported container size"),
        (dict(size_B=(np.inf, 2.438, 2.591)), "finite"),
    ],
)
def test_bad_inputs_raise_clear_errors(pred, kwargs, match):
    args = dict(p_AB=np.array([[0.0, 0.0, 2.58]]), R_AB=np.eye(3)[None], size_A=SIZE_1AA, size_B=SIZE_1AA)
    args.update(kwargs)
    with pytest.raises(PredictorInputError, match=match) as info:
        pred.predict(args["p_AB"], args["R_AB"], size_A=args["size_A"], size_B=args["size_B"])
    assert isinstance(info.value, TestbedError) and isinstance(info.value, ValueError)


def test_missing_weights_file(tmp_path):
    with pytest.raises(WeightsError, match="not found"):
        load_predictor(tmp_path / "nope.npz")


def test_shipped_files_are_small_and_consistent(pred):
    shipped = REPO / "learned_contact" / "shipped"
    for name in ("weights.npz", "paper_weights.npz", "config.json", "metrics.json", "report.md"):
        assert (shipped / name).is_file(), name
        assert (shipped / name).stat().st_size < 1_000_000, name
    config = json.loads((shipped / "config.json").read_text())
    assert pred.meta["config"] == config
