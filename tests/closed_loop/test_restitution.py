"""Dissipation in the closed loop judged against the truth: the restitution of a flat drop (a box
landing level on a fixed one; e = the largest upward speed after the impact / the impact speed), the
learned loop (the exact field force with Hunt-Crossley's damping, implicit per pair) against Drake
hydroelastic at the same modulus (1e8 Pa), the truth's own step error beside it (its plant at half the
step), Drake point contact as the simplest alternative.

Measured 2026-12-07 (Drake 1.51.1), e for truth / learned / truth at 0.5 ms / point contact:
  10 t,  0.3 m/s   0.344 / 0.339 / 0.367 / 0.476
  10 t,  2.0 m/s   0.090 / 0.087 / 0.091 / 0.415
  2.2 t, 0.3 m/s   0.364 / 0.324 / 0.375 / 0.423
  2.2 t, 1.0 m/s   0.146 / 0.146 / 0.166 / 0.434
(also 10 t 1.0 m/s: 0.154 / 0.155 / 0.164 / 0.378; 2.2 t 2.0 m/s: 0.095 / 0.084 / 0.093 / 0.341).
Hunt-Crossley's e falls with the impact speed; point contact's does not. Bound: |e - e_truth| <= 0.05,
above the truth's own step error (at most 0.020 here, asserted) and below point contact's distance
(0.06-0.32): the loop without damping (e 0.79 / 0.47: the implicit step's own loss), with half
(0.48 / 0.23) or twice (0.21 / 0.084) the damping, or point contact fail it (10 t at 0.3 / 2.2 t at 1 m/s).
"""

from __future__ import annotations

import pytest

from testbed import variants
from testbed.compare.runs import run_variant, variant
from testbed.scenario import load_scenario

RESTITUTION_ABS = 0.05  # [-]
TRUTH_STEP_ERROR_MAX = 0.025  # [-] the truth at 1 ms against 0.5 ms must stay below the bound's half

DROP = """
name: rebound
duration: 0.4
containers:
- {{name: base, type: 1CC, mass: 20000.0, fixed: true, X_WC: {{translation: [0.0, 0.0, 1.2955]}}}}
- {{name: top, type: 1CC, mass: {mass}, X_WC: {{translation: [0.0, 0.0, 3.8875]}}, V_WC: [0, 0, 0, 0, 0, {v}]}}
effects:
  contact: {{}}
  friction: {{}}
"""


def _restitution(run) -> float:
    """[-] the largest upward speed after the impact over the speed at release (1 mm above the face)."""
    assert not run.error, run.error
    v_z = run.V_WB[:, 0, 5]  # the top box's translational velocity along world z [m/s]
    return max(0.0, float(v_z.max())) / -float(v_z[0])


@pytest.fixture(scope="module", params=[(10000.0, 0.3), (10000.0, 2.0), (2200.0, 0.3), (2200.0, 1.0)],
                ids=lambda p: f"{p[0] / 1000:g}t-{p[1]:g}mps")
def drop(request):
    mass, speed = request.param
    scenario = load_scenario(text=DROP.format(mass=mass, v=-speed))
    e = {kind: _restitution(run_variant(variant(scenario, kind), 0.4, 1)) for kind in ("truth", "learned", "point")}
    half = variants.derive(variant(scenario, "truth"), variants.timing(time_step=5e-4))
    e["truth_half_step"] = _restitution(run_variant(half, 0.4, 1))
    return e


def test_the_truths_own_step_error_lies_below_the_bound(drop):
    assert abs(drop["truth"] - drop["truth_half_step"]) < TRUTH_STEP_ERROR_MAX, drop


def test_the_learned_loop_rebounds_as_the_truth_does(drop):
    assert 0.0 < drop["learned"] < 1.0, drop  # a rebound, and energy lost
    assert abs(drop["learned"] - drop["truth"]) <= RESTITUTION_ABS, drop


def test_point_contact_rebounds_otherwise(drop):
    """The simplest alternative fails the bound: point contact's damping is not the truth's."""
    assert abs(drop["point"] - drop["truth"]) > RESTITUTION_ABS, drop


def test_restitution_falls_with_the_impact_speed():
    """Hunt-Crossley's e = 1 - O(d v): the same box at 0.3 and 2.0 m/s, learned loop only."""
    e = []
    for speed in (0.3, 2.0):
        scenario = load_scenario(text=DROP.format(mass=10000.0, v=-speed))
        e.append(_restitution(run_variant(variant(scenario, "learned"), 0.4, 1)))
    assert e[1] < 0.5 * e[0], e  # measured 0.339 -> 0.087


@pytest.mark.parametrize("dissipation", [0.0, 2.5, 10.0])
def test_the_wrong_damping_fails_the_bound(dissipation):
    """The learned loop with none, half or twice Hunt-Crossley's d (the models' 5 s/m) leaves the bound
    on both drops (measured above); the shipped d is within it (test above)."""
    for mass, speed, truth in ((10000.0, 0.3, 0.344), (2200.0, 1.0, 0.146)):
        text = DROP.format(mass=mass, v=-speed) + f"  learned_dynamics: {{dissipation: {dissipation}}}\n"
        e = _restitution(run_variant(variant(load_scenario(text=text), "learned"), 0.4, 1))
        assert abs(e - truth) > RESTITUTION_ABS, (mass, speed, e)
