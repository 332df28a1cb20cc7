"""Drake labels: orientation conventions, depth control, caching."""

import numpy as np
import pytest

from learned_contact.data import labels
from learned_contact.data.sampling import sample

H = {"1AA": np.array([6.096, 1.219, 1.2955]), "1CC": np.array([3.029, 1.219, 1.2955])}


def _label(type_a, type_b, R, p_base, direction, depth):
    row = labels.label_one(type_a, type_b, R, np.asarray(p_base, float), np.asarray(direction, float), depth)
    return {k: row[s] for k, s in labels.LABEL_FIELDS.items()}


@pytest.mark.parametrize("order", [("1AA", "1CC"), ("1CC", "1AA")])
def test_stack_label_orientation_and_centre_of_pressure(order):
    # B above A, offset along x so that the overlap is one end of the lower box
    a, b = order
    lab = _label(a, b, np.eye(3), [2.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.01)
    np.testing.assert_allclose(lab["depth"], 0.01, atol=1e-5)
    assert lab["normal"][2] > np.cos(np.radians(0.5))  # A -> B is up
    assert lab["pp_normal"][2] > np.cos(np.radians(0.5))
    lo = max(-H[a][0], 2.0 - H[b][0])
    hi = min(H[a][0], 2.0 + H[b][0])
    assert lo < lab["cop"][0] < hi  # inside the overlap
    assert abs(lab["cop"][2] - H[a][2]) < 0.02  # on A's top face, within the overlap depth


def test_label_from_below_points_down():
    # B under A: the normal from A towards B points down in A's frame
    lab = _label("1AA", "1AA", np.eye(3), [0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.005)
    assert lab["normal"][2] < -0.999 and lab["cop"][2] < 0


def test_make_dataset_is_cached_and_seeded(tmp_path, monkeypatch):
    monkeypatch.setenv("TESTBED_CACHE", str(tmp_path))
    a = labels.make_dataset("general", 40, 11, workers=1, progress=False)
    files = list((tmp_path / "learned_contact").glob("labels-*.npy"))
    assert len(files) == 1
    b = labels.make_dataset("general", 40, 11, workers=1, progress=False)
    np.testing.assert_array_equal(a.cop, b.cop)
    assert len(a) + a.n_dropped == 40
    assert np.all((a.depth > -1e-4) & (a.depth < 0.03 + 1e-4))  # Drake's depth, target range
    np.testing.assert_allclose(np.linalg.norm(a.normal, axis=1), 1.0, atol=1e-9)


def test_parallel_labels_equal_serial():
    props = sample("stacking", 30, 5)
    serial = labels.label_proposals(props, workers=1, progress=False)
    parallel = labels.label_proposals(props, workers=2, progress=False, chunk=10)
    np.testing.assert_array_equal(serial, parallel)
