"""The learned contact step's cost with the exact field force against the former foundation, as
ratios timed side by side (testbed/bench/step_cost.py): each state's ratio meets the force issue's
1.5x or stays inside its pinned band (worse fails, and so does better: re-pin or drop the pin)."""

from __future__ import annotations

import numpy as np
import pytest

from testbed.bench import step_cost

pytestmark = pytest.mark.timing  # CPU-time ratios: serially, alone on the machine (tests/tiers.py)


@pytest.fixture(scope="module")
def measured() -> dict:
    """{state: median ratio of 3 measurements}."""
    pytest.importorskip("learned_contact._native")
    runs = [step_cost.ratios() for _ in range(3)]
    return {name: float(np.median([r[name][0] for r in runs])) for name in runs[0]}


@pytest.mark.parametrize("name", list(step_cost.STATES))
def test_the_step_cost_is_met_or_within_its_pin(measured, name):
    assert step_cost.verdict(name, measured[name]) in ("met", "known limit"), (name, measured[name])


def test_the_verdicts_read_the_pins():
    name = "yard block (72 resting pairs)"
    assert step_cost.verdict(name, 3.0) == "known limit"
    assert step_cost.verdict(name, 7.0) == "worse than pinned"
    assert step_cost.verdict(name, 1.4) == "better than pinned"
    assert step_cost.verdict("unpinned", 1.4) == "met" and step_cost.verdict("unpinned", 1.6) == "NOT met"
