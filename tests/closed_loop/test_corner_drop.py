"""testbed/scenes/corner_drop.yaml: a loaded 20 ft box dropped corner-first (rolled 6, pitched 4, yawed
3 deg, its lowest corner 0.25 m up) on a 3-high stack of 40 ft boxes. What it does is decided by the
force while a corner and then an edge carry it, and by the damping of the rocking after: the learned
loop against Drake hydroelastic from the same start, with Drake point contact beside it.

Measured (2026-12-07, 1e8 Pa, the twins' modulus), final position of the dropped box from the discrete
truth's: the learned loop 45.7 mm (the exact field force with Hunt-Crossley's torque over the surface,
grid 0), 108 mm with the Winkler foundation damped at the point only (grid 4), 229 mm with the exact
force damped at the point only; Drake point contact 38.2 mm here (60 mm in `testbed compare`'s run). The truth ladder's own spread (discrete
plant against the continuous one, `testbed study truth`): 34 mm, and against that continuous truth the
learned loop ends 25 mm away, point contact 21 mm. Not yet within the closed-loop gates' 20 mm, so the
scene stays out of validate's set (testbed/gates/closed_loop.py EXCLUDED says why)."""

from __future__ import annotations

import numpy as np
import pytest

from testbed.compare.runs import run_variant, variant
from testbed.scenario import load_scenario


@pytest.fixture(scope="module")
def runs():
    scenario = load_scenario("corner_drop")
    return {kind: run_variant(variant(scenario, kind), 2.0, 20) for kind in ("truth", "learned", "point")}


def _final_error(runs, kind) -> float:
    i = list(runs["truth"].names).index("dropped")
    return float(np.linalg.norm(runs[kind].p_WB[-1, i] - runs["truth"].p_WB[-1, i]))


def test_the_drop_lands_on_the_stack(runs):
    """Physical check, every run: the dropped box ends on the stack's top face (its centre over the top
    box's face, its bottom within 5 cm of the face: the truth's penetration peaks at 50 mm at 1e8 Pa)."""
    i = list(runs["truth"].names).index("dropped")
    for kind, run in runs.items():
        assert not run.error, kind
        p = run.p_WB[-1, i]
        assert abs(p[0]) < 6.096 and abs(p[1]) < 1.219, (kind, p)
        assert abs(p[2] - (7.773 + 1.2955)) < 0.05, (kind, p)


def test_the_learned_loop_lands_where_the_truth_does_within_its_known_gap(runs):
    """Final position from the truth's: measured 45.7 mm; 60 mm fails the foundation's 108 mm and the
    exact force damped at the point only (229 mm)."""
    assert not runs["learned"].error
    learned, point = _final_error(runs, "learned"), _final_error(runs, "point")
    assert learned < 0.06
    assert learned / point < 1.5, (learned, point)  # the known gap to point contact (below), pinned: 1.2x measured


@pytest.mark.xfail(strict=True, reason="the learned loop ends 45.7 mm from the discrete truth where Drake point "
                   "contact ends 38.2 mm from it (every 20th step recorded; against the continuous truth 25 and 21 mm)")
def test_the_learned_loop_lands_no_further_from_the_truth_than_point_contact(runs):
    learned, point = _final_error(runs, "learned"), _final_error(runs, "point")
    assert learned <= point, (learned, point)
