"""testbed/scenes/corner_drop.yaml: a loaded 20 ft box dropped corner-first (rolled 6, pitched 4, yawed
3 deg, its lowest corner 0.25 m up) on a 3-high stack of 40 ft boxes. What it does is decided by the
force while a corner and then an edge carry it, by the damping of the rocking after, and by friction:
the learned loop against Drake hydroelastic from the same start, with Drake point contact beside it.

The truth is the scene's own: Drake's continuous-time plant at accuracy 1e-3 (its YAML's `truth:`), since
at 1e8 Pa the discrete plant ends the dropped box 34 mm from it. Measured (2026-12-07, 1e8 Pa), final
position of the dropped box from that truth's: the learned loop 25.5 mm and 0.83 deg (the exact field
force with Hunt-Crossley's torque over the surface; its own step error: 1 / 0.5 / 0.25 ms end within
2.5 mm), Drake point contact 21.1 mm and 0.99 deg. Against the discrete truth: learned 45.7 mm (the
former Winkler foundation 108 mm), point contact 38.2 mm. What is left is friction's model more than the
force: the learned loop without its stick anchor (stick_hw 0, Coulomb as the truth's regularised
friction) ends 17.1 mm away, without torsional friction 64.6 mm; the anchor is what holds the stacks at
rest (the drift gate), so it stays. validate's full suite judges the scene (a pinned known limit:
testbed/gates/closed_loop.py KNOWN_LIMITS)."""

from __future__ import annotations

import numpy as np
import pytest

from testbed.compare.run_candidates import reference_run
from testbed.compare.runs import run_variant, variant
from testbed.scenario import load_scenario

pytestmark = pytest.mark.slow  # the continuous truth: ~80 s of CPU for the 2 s


@pytest.fixture(scope="module")
def runs():
    scenario = load_scenario("corner_drop")
    assert scenario.truth.reference == "continuous"
    out = {kind: run_variant(variant(scenario, kind), 2.0, 20) for kind in ("learned", "point")}
    out["truth"] = reference_run(variant(scenario, "truth"), 2.0, 20)[0]
    return out


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
    """Final position from the truth's: measured 25.5 mm; the pinned band (0.5-2x, as KNOWN_LIMITS)."""
    assert not runs["learned"].error
    learned, point = _final_error(runs, "learned"), _final_error(runs, "point")
    assert 0.0128 < learned < 0.051, learned
    assert learned / point < 1.5, (learned, point)  # the known gap to point contact (below), pinned: 1.21x measured


@pytest.mark.xfail(strict=True, reason="the learned loop ends 25.5 mm from the continuous truth where Drake point "
                   "contact ends 21.1 mm from it (every 20th step recorded)")
def test_the_learned_loop_lands_no_further_from_the_truth_than_point_contact(runs):
    learned, point = _final_error(runs, "learned"), _final_error(runs, "point")
    assert learned <= point, (learned, point)
