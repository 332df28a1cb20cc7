"""MuJoCo's matched contact against Drake's discrete contact, run side by side: the one-step
map of the contact mode, the scene's contact overrides, and the scenes where they part
(testbed/engines/mujoco/model.py, module docstring)."""

import math

import numpy as np
import pytest

from testbed.physics import GRAVITY
from testbed.scenario import load_scenario

pytest.importorskip("mujoco")

from testbed.engines.mujoco.model import build_model  # noqa: E402
from testbed.engines.mujoco.run import simulate_mujoco  # noqa: E402


def _drake_steps(scenario, duration):
    """(n + 1, m, 3) [m] Drake's p_WB at every step of `duration` [s] (recorders dropped)."""
    from testbed.compare.runs import run_variant
    from testbed.engines.comparison import engine_variant

    return run_variant(engine_variant(scenario, "truth"), duration, 1).p_WB


def _step_map_roots(z):
    """The two eigenvalues of the one-step map of a settling coordinate z (k,), by an AR(2)
    least-squares fit of z[n+1] - z_end on the two previous deviations."""
    e = z[1:40] - z[-1]
    (a1, a2), *_ = np.linalg.lstsq(np.column_stack([e[1:-1], e[:-2]]), e[2:], rcond=None)
    return np.roots([1.0, -a1, -a2])


@pytest.mark.parametrize("overrides, floored", [
    ([], False),  # shipped: 1e9 Pa, 'auto' = similar (Hunt-Crossley)
    (["effects.contact.approximation=sap"], False),  # 1e9 Pa, SAP (tau = 2 ms)
    (["effects.contact.hydroelastic_modulus=1e8", "effects.contact.approximation=sap"], True),  # the old defaults
])
def test_matched_contact_steps_like_drakes_implicit_step(overrides, floored):
    """A 20 t box released at zero penetration onto the quay: the vertical contact mode's
    one-step map. Drake's discrete contact is implicit Euler (det 1/D, D = 1 + h^2 k/m + h c/m);
    the matched MuJoCo rows reproduce its eigenvalues (module docstring)."""
    from testbed.engines.mujoco.model import drake_step_factor

    scenario = load_scenario("defaults", overrides=overrides)
    drake = _step_map_roots(_drake_steps(scenario, 0.1)[:, 0, 2])
    mj = _step_map_roots(simulate_mujoco(scenario, duration=0.1).tables["steps"]["p_WB"][:, 0, 2])
    (pair,) = build_model(scenario)[2].pairs
    D = drake_step_factor(pair.stiffness, pair.damping, 20000.0, scenario.plant.time_step)
    # Drake is that implicit step: 1% (Hunt-Crossley's force is k x (1 + d xdot), whose
    # damping grows with the overlap; the linearised c = d W leaves 0.5% at 1e9 Pa)
    assert abs(np.prod(drake)) == pytest.approx(1.0 / D, rel=0.01)
    # MuJoCo decays per step as Drake does: 1% on |lambda| (the same Hunt-Crossley nonlinearity)
    np.testing.assert_allclose(np.abs(mj), np.abs(drake), rtol=0.01)
    # MuJoCo's own map is the docstring's: det = 1/D, trace = 2 - (1 - 1/D) - h^2 k/(m lam)
    h2k_m = scenario.plant.time_step**2 * pair.stiffness / 20000.0
    trace = 1.0 + 1.0 / D - h2k_m / pair.mass_factor
    turn = math.acos(trace / (2.0 * math.sqrt(1.0 / D)))  # [rad] per step
    assert abs(np.angle(mj[0])) == pytest.approx(turn, rel=0.01)
    if floored:  # d0 held at 0.1 (lam 1.44 > D = 1.18): the mode turns 11% slower than Drake's
        assert abs(np.angle(mj[0])) < 0.95 * abs(np.angle(drake[0]))
    else:  # lam = D: it turns per step as Drake's, 1% (as above)
        assert abs(np.angle(mj[0])) == pytest.approx(abs(np.angle(drake[0])), rel=0.01)


def test_scene_contact_overrides_reach_the_matched_pairs():
    """effects.contact.hydroelastic_modulus replaces the SDF's on every geometry (as in
    Drake): the matched stiffness follows, and MuJoCo rests where Drake does (0.162 mm at
    1e8 Pa, ten times the shipped depth)."""
    scenario = load_scenario("defaults", overrides=["effects.contact.hydroelastic_modulus=1e8"])
    (pair,) = build_model(scenario)[2].pairs
    size = scenario.containers[0].container_type().size
    assert pair.stiffness == pytest.approx(1e8 * size[0] * size[1] / (0.5 * min(size)), rel=1e-12)
    drake = _drake_steps(scenario, 0.3)[:, 0, 2]
    mj = simulate_mujoco(scenario, duration=0.3).tables["steps"]["p_WB"][:, 0, 2]
    # 1%: both settled (0.3 s = 300 steps of amplitude x0.92); the static k is the same
    assert mj[-1] - mj[0] == pytest.approx(drake[-1] - drake[0], rel=0.01)
    assert drake[0] - drake[-1] == pytest.approx(20000.0 * GRAVITY / pair.stiffness, rel=0.01)


def test_hydroelastic_margin_does_not_move_drakes_rest():
    """Why MuJoCo does not translate effects.contact.hydroelastic_margin: Drake's margin
    widens contact detection only; a resting box sits at the same depth with or without it."""
    depths = [(lambda z: z[0] - z[-1])(_drake_steps(load_scenario("defaults", overrides=o), 0.2)[:, 0, 2])
              for o in ([], ["effects.contact.hydroelastic_margin=1e-3"])]
    # 1e-8 m: 0.06% of the 16.2 um depth; a margin acting as an offset would move it by ~1e-3 m
    assert depths[1] == pytest.approx(depths[0], abs=1e-8)


def test_wind_slide_matches_drake():
    """quay_wind_slide: an empty 2.2 t box under a 36 m/s side wind (1.7x its sliding
    threshold) slides as far in MuJoCo as in Drake (0.92 m in 1 s; a translation without
    Drake's step damping bounced the box and slid it 1.58 m)."""
    scenario = load_scenario("quay_wind_slide")
    drake = _drake_steps(scenario, 1.0)[-1, 0]
    mj = simulate_mujoco(scenario, duration=1.0).tables["steps"]["p_WB"][-1, 0]
    # 2%: measured 0.4%; the box also rocks on its lee edge (MuJoCo lifts 27 mm, Drake 14 mm:
    # two corner springs against Drake's edge pressure patch), which shifts its friction load
    assert mj[1] == pytest.approx(drake[1], rel=0.02)
    assert drake[1] > 0.5  # it did slide (the premise)


@pytest.fixture(scope="module")
def drop_final_error():
    """[m] single_drop (20 t box released 0.3 m up, tilted 0.5 and 0.3 deg): distance
    between where Drake and matched MuJoCo leave it at rest after 1 s."""
    scenario = load_scenario("single_drop")
    drake = _drake_steps(scenario, 1.0)[-1, 0]
    mj = simulate_mujoco(scenario, duration=1.0).tables["steps"]["p_WB"][-1, 0]
    return float(np.linalg.norm(mj - drake))


def test_edge_landing_gap_is_pinned(drop_final_error):
    """The known gap of the next test, pinned: 69.7 mm measured (MuJoCo's default parameters
    86 mm; the continuous-zeta translation 183 mm). Lower bound: a change that closes part of
    the gap should move the band and the xfail below; upper: worse fails here."""
    assert 0.05 < drop_final_error < 0.09


@pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
    "edge-first landing: Drake's hydroelastic edge patch stiffens with the overlap, MuJoCo's matched "
    "set is 4 linear corner springs sized for face-on-face rest; the box leaves the impact with "
    "0.15 m/s sideways in MuJoCo, 0.55 m/s in Drake, and rests 70 mm apart"))
def test_edge_landing_rests_where_drakes_does(drop_final_error):
    # 10 mm: Drake's own step error on this scene at 1 ms against 0.2 ms is 13 mm
    assert drop_final_error < 0.01
