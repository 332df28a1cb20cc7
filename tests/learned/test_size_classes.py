"""Every ISO container and any box in the stated range: the shipped predictor answers them, refuses
what it was not made for, and holds the 20 / 40 ft gates' bounds on sizes it was not fitted on
(testbed/bench/size_classes.py), with the force the loop applies equal to Drake's."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.errors import PredictorInputError, WeightsError
from learned_contact.predictors.improved import ANSWERED_SIZE_RANGE
from testbed.bench.size_classes import CLASSES, KNOWN_LIMITS, measure
from testbed.bodies.containers import CONTAINER_TYPES, FITTED_TYPES, container_type, generic_code

STACK = (np.array([0.3, -0.1, 2.6]), np.eye(3))  # B about 2.6 m above A's centre, level [m]


@pytest.mark.parametrize("compiled", [True, False])
def test_every_iso_type_and_any_box_in_range_is_answered(compiled):
    pred = load_predictor("improved", compiled=compiled)
    for code, ctype in CONTAINER_TYPES.items():
        p = np.array([0.3, -0.1, 0.5 * ctype.size[2] + 0.5 * 2.591 - 1e-4])  # a 1CC resting on it, 0.1 mm deep
        point, normal = pred.predict(p, np.eye(3), size_A=ctype.size, size_B=CONTAINER_TYPES["1CC"].size)
        # (the slivers along B's edges, off centre on a larger face, tilt Drake's normal by up to 2e-5)
        assert normal == pytest.approx([0.0, 0.0, 1.0], abs=1e-4), code
        assert point[2] == pytest.approx(0.5 * ctype.size[2], abs=1e-4), code  # on A's top face
    lo, hi = ANSWERED_SIZE_RANGE
    for size in (lo, hi, 0.5 * (lo + hi)):
        point, normal = pred.predict(p, np.eye(3), size_A=size, size_B=size)
        assert np.all(np.isfinite(point)) and np.linalg.norm(normal) == pytest.approx(1.0)


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("size, words", [((6.058, 2.5, 2.591), "x 2.438 x"), ((14.5, 2.438, 2.591), "2.9-13.8"),
                                         ((6.058, 2.438, 0.9), "1.2-3")])
def test_a_box_outside_the_range_is_refused_naming_the_range(compiled, size, words):
    """Other widths are refused: the network never saw one (its width inputs have no spread), and a
    2.5 m wide box was measured metres off on general poses."""
    pred = load_predictor("improved", compiled=compiled)
    with pytest.raises(PredictorInputError, match="outside the supported size range") as info:
        pred.predict(*STACK, size_A=size, size_B=CONTAINER_TYPES["1CC"].size)
    assert words in str(info.value)


def test_the_paper_model_keeps_its_own_three_sizes():
    """The paper's MLP takes no size input: it answers the sizes it was fitted on, nothing else."""
    paper = load_predictor("paper")
    assert paper.size_range is None and len(paper.supported_sizes) == len(FITTED_TYPES)
    with pytest.raises(PredictorInputError):
        paper.predict(*STACK, size_A=CONTAINER_TYPES["1EEE"].size, size_B=CONTAINER_TYPES["1AA"].size)


def test_the_size_range_travels_with_the_weights_file(tmp_path):
    pred = load_predictor("improved")
    narrow = dataclasses.replace(pred, size_range=np.array([[5.0, 2.438, 2.0], [7.0, 2.438, 2.7]]))
    path = narrow.save(tmp_path / "narrow.npz")
    back = load_predictor(str(path))
    np.testing.assert_array_equal(back.size_range, narrow.size_range)
    inside, outside = (6.5, 2.438, 2.5), (9.0, 2.438, 2.5)
    back.predict(*STACK, size_A=inside, size_B=inside)
    with pytest.raises(PredictorInputError):
        back.predict(*STACK, size_A=outside, size_B=inside)
    arrays = dict(np.load(path))
    np.savez(tmp_path / "bad.npz", **dict(arrays, size_range=arrays["size_range"][::-1]))
    with pytest.raises(WeightsError, match="size_range"):
        load_predictor(str(tmp_path / "bad.npz"))


def test_a_generic_code_is_a_box_of_that_size():
    box = container_type(generic_code((7.5, 2.438, 2.7)))
    assert box.size == (7.5, 2.438, 2.7) and box.code == "box:7.5,2.438,2.7"
    with pytest.raises(Exception, match="container type"):
        container_type("box:7.5,2.438")


# once: Drake's static labels are the same bits under both releases CI runs (learned_contact/data/labels.py:
# 1.51.1 and 1.58.0 on 3,000 poses), so suite 2 would repeat suite 1's figures; ~3 min of one worker
@pytest.mark.slow
@pytest.mark.once
@pytest.mark.parametrize("size_class", CLASSES[1:], ids=[c.name for c in CLASSES[1:]])
def test_sizes_not_fitted_on_hold_the_fitted_sizes_bounds(size_class):
    """On held-out poses labelled by Drake for the class's sizes (the gates' seed 0 and 400 proposals
    per set), every point and normal gate of the 20 / 40 ft pairs holds at its own bound (twice it for
    generic boxes), the 'vs prior' gates included (so the closed form and the network still earn their
    place there), except the pins of KNOWN_LIMITS, which hold only within their band; the 45 ft pairs
    have none. The closed loop's force is Drake's to 1e-6 (measured 2e-10 to 5e-10 at the p95; the
    fitted sizes: 3.8e-10). Before the fields' shares were integrated, a half height on a full-height
    box was 55 um off at the resting p95 (bound 1 um)."""
    row = measure(size_class)
    failed = [(g["name"], g["value"], g["bound"]) for g in row["gates"] if not g["passed"]]
    assert not failed, failed
    assert {g["name"].split(" (")[0] for g in row["gates"] if g["pinned"]} == set(KNOWN_LIMITS.get(size_class.name, {}))
    if "45 ft" in size_class.name:
        assert not any(g["pinned"] for g in row["gates"])
    assert len(row["gates"]) >= 14
    assert max(v["force_rel_p95"] for v in row["force"].values()) < 1e-6
    assert all(v["zero_answers"] == 0 for v in row["force"].values())
