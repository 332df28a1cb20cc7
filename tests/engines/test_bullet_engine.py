"""The Bullet engine (testbed/engines/bullet/): registration, translation, physics against closed
forms (a drop comes to rest, a slide stops, wind is held by friction), two_stack against Drake,
refusals, the crane and the moving deck accepted (their physics: test_bullet_crane.py,
test_bullet_deck.py). Skipped where pybullet is not installed (install: pip install pybullet==3.2.7)."""

import sys

import numpy as np
import pytest

from testbed.engines import alternatives, candidates, engine
from testbed.engines.base import UnsupportedSceneError
from testbed.engines.bullet.model import CONTACTS_PER_FACE, INSTALL, PybulletMissingError, translate
from testbed.errors import OptionalDependencyError
from testbed.physics import GRAVITY
from testbed.scenario import load_scenario

MASS = 20000.0  # [kg] the dropped box
DROP_HEIGHT = 0.3  # [m] its bottom face above the quay at t = 0
DROP = f"""
name: drop
duration: 3.5
containers:
- {{name: box, type: 1CC, mass: {MASS}, X_WC: {{translation: [0, 0, {1.2955 + DROP_HEIGHT}]}}}}
effects:
  contact: {{}}
  friction: {{}}
"""
SPEED, MU = 3.0, 0.4  # [m/s], [-] the slide's initial speed and friction coefficient
SLIDE = f"""
name: slide
duration: 1.2
containers:
- {{name: box, type: 1CC, mass: 2200.0, X_WC: {{translation: [0, 0, 1.2955]}}, V_WC: [0, 0, 0, {SPEED}, 0, 0]}}
effects:
  contact: {{}}
  friction: {{mu: {MU}}}
"""


@pytest.fixture
def pb():
    """pybullet, or the test skips naming the install command."""
    return pytest.importorskip("pybullet", reason=f"pybullet is not installed; install it with: {INSTALL}")


def _run(text, params, **kwargs):
    from testbed.engines.bullet.run import simulate_bullet

    return simulate_bullet(load_scenario(text=text), params=params, **kwargs)


def test_bullet_is_registered_as_an_alternative():
    e = engine("bullet")
    assert (e.label, e.order, e.param_sets) == ("Bullet", 25, ("matched", "default"))
    assert "bullet" in candidates() and e in alternatives() and not (e.reference or e.gated or e.learned)


def test_a_missing_pybullet_names_its_install_command(monkeypatch):
    monkeypatch.setitem(sys.modules, "pybullet", None)  # import pybullet -> ImportError
    reason = engine("bullet").unavailable()
    assert reason is not None and reason.endswith(f"install it with: {INSTALL}") and "\n" not in reason
    with pytest.raises(PybulletMissingError) as caught:
        engine("bullet").run(load_scenario(text=DROP), duration=0.01)
    assert isinstance(caught.value, OptionalDependencyError)


def test_the_initial_state_is_drakes(pb):
    """Bullet keeps a body's COM pose and velocity; the recorded first state gives back the
    scene's X_WC and V_WC of the frame origin C for a box with a COM offset, rotated and
    spinning (round trip through Bullet: exact up to float rounding, 1e-9)."""
    text = """
name: spin
duration: 0.001
containers:
- name: hc
  type: 1AAA
  mass: 18000.0
  com_offset: [1.5, -0.2, 0.3]
  X_WC: {translation: [0.4, 0.1, 9.0], rotation: !Rpy {deg: [3.0, -2.0, 25.0]}}
  V_WC: [0.3, -0.2, 0.5, 1.0, -0.5, 0.2]
effects:
  contact: {}
"""
    scenario = load_scenario(text=text)
    run = _run(text, "matched")
    X = scenario.containers[0].pose()
    np.testing.assert_allclose(run.tables["steps"]["p_WB"][0, 0], X.translation(), atol=1e-9)
    q = run.tables["steps"]["q_WB"][0, 0]
    np.testing.assert_allclose(q * np.sign(q[0]), X.rotation().ToQuaternion().wxyz(), atol=1e-9)
    np.testing.assert_allclose(run.tables["steps"]["V_WB"][0, 0], scenario.containers[0].V_WC, atol=1e-9)


@pytest.mark.parametrize("params", ["matched", "default"])
def test_a_dropped_container_comes_to_rest_on_the_quay(pb, params):
    run = _run(DROP, params)
    steps, rows = run.tables["steps"], run.tables["contacts"]
    h = run.summary["time_step_s"]
    W = MASS * GRAVITY  # [N]
    v_impact = np.sqrt(2 * GRAVITY * DROP_HEIGHT)  # [m/s]
    if params == "matched":
        k = CONTACTS_PER_FACE * translate(load_scenario(text=DROP)).bodies[1].stiffness  # [N/m] the face's spring
        # the undamped spring's deepest point from the drop's energy, W (d + x) = k x^2 / 2: Drake's implicit
        # step and Bullet's (the same CFM/ERP form) only dissipate, so they stay above it
        bound = (W + np.sqrt(W * W + 2 * k * W * DROP_HEIGHT)) / k  # 3.13 mm; measured 1.91 mm
    else:
        # rigid contact: the velocity constraint stops the box within the step after impact (+ Bullet's
        # 10 um contact slop); measured 0.46 mm against 2.4 mm
        bound = v_impact * h + 1e-5
    assert 0 < run.summary["max_penetration_m"] <= bound
    # no energy gain: kinetic + potential never above the start (tolerance: float rounding of a 3e5 J sum)
    energy = steps["kinetic_energy"] + steps["potential_energy"]
    assert np.max(energy - energy[0]) <= 1e-9 * abs(energy[0])
    # at rest (the last second): the contact's normal force carries the weight. Tolerance 1e-3: a step
    # at rest is a balance of impulses solved by 50 Gauss-Seidel sweeps (measured 5e-6 matched, 1e-4 default)
    last = rows["step"] >= rows["step"].max() - int(round(1.0 / h))
    assert set(rows["a"][last]) == {0} and set(rows["b"][last]) == {1}
    fz = rows["f_W"][last, 2]
    np.testing.assert_allclose(fz / W, 1.0, atol=1e-3)
    # Bullet's sleeping is on: after 2 s at rest the box is deactivated, its velocity exactly 0
    np.testing.assert_array_equal(steps["V_WB"][-1], 0.0)
    if params == "matched":  # the spring holds the weight at W / k (the deepest of the 4 points; 1%: measured 0.2%)
        np.testing.assert_allclose(-rows["phi"][last], W / k, rtol=1e-2)


@pytest.mark.parametrize("params", ["matched", "default"])
def test_a_sliding_container_stops_after_v2_over_2_mu_g(pb, params):
    run = _run(SLIDE, params)
    steps, rows = run.tables["steps"], run.tables["contacts"]
    h = run.summary["time_step_s"]
    closed = SPEED**2 / (2 * MU * GRAVITY)  # [m] 1.147 m
    x = steps["p_WB"][-1, 0, 0]
    # the semi-implicit Euler step (v first, then x with the new v) stops v h / 2 short of the
    # continuous closed form: the sum of h (v0 - k mu g h) over the steps to rest
    assert abs(x - closed) <= SPEED * h
    # 50 um: the box rests 12 um deep and pitches under the friction moment while sliding (measured 4 um)
    assert x == pytest.approx(closed - SPEED * h / 2, abs=5e-5)
    assert abs(steps["V_WB"][-1, 0, 3]) < 1e-5  # at rest (m/s; Bullet's resting jitter is 1e-6)
    # while sliding, the friction on the box is mu times the normal force, against the motion
    # (1e-3: the cone is solved by Gauss-Seidel sweeps; measured 3e-6)
    sliding = (rows["step"] > 10) & (rows["step"] < int(0.7 * SPEED / (MU * GRAVITY) / h))
    f = rows["f_W"][sliding]
    np.testing.assert_allclose(-f[:, 0] / f[:, 2], MU, rtol=1e-3)


def test_wind_is_held_by_friction(pb):
    """quay_wind_hold: an empty box under 77% of its sliding load stays, the quay's friction on it
    balancing the wind force of testbed/effects/wind.py (applied at C) once the ramp is over."""
    from testbed.effects.wind import WindLaw
    from testbed.engines.bullet.run import simulate_bullet

    scenario = load_scenario("quay_wind_hold")
    run = simulate_bullet(scenario, duration=1.0)
    rows, steps = run.tables["contacts"], run.tables["steps"]
    h = run.summary["time_step_s"]
    spec = scenario.containers[0]
    wind = WindLaw(scenario.effects.wind, np.array([spec.container_type().size]))
    f_wind = wind.forces_W(np.eye(3)[None], 1.0)[0]  # [N] at full load
    held = rows["step"] >= int(round(0.8 / h))  # after the 0.5 s ramp and its transient
    # force balance of the resting box (1e-3 of the wind force: the impulse solver's residual, measured 1.2e-6)
    np.testing.assert_allclose(rows["f_W"][held, :2], -np.broadcast_to(f_wind[:2], (held.sum(), 2)),
                               atol=1e-3 * np.linalg.norm(f_wind))
    # it does not move: less than the resting penetration (16 um) sideways (measured 2.2 um)
    assert np.max(np.abs(steps["p_WB"][:, 0, :2] - spec.pose().translation()[:2])) < 1.6e-5


def test_two_stack_against_drake(pb):
    """two_stack (a 10 t box, payload 0.8 m off centre, on a 20 t one) with the matched contact
    against Drake's hydroelastic truth: the final position error stays below the stack's own
    static compression in Drake (24 um under the bottom box + 16 um between them = 40 um):
    matched springs leave no more than that to disagree on. Measured: 12.4 um final, 27.5 um max."""
    from testbed.compare import compare_engine

    scenario = load_scenario("two_stack")
    f = compare_engine(scenario, "bullet", with_point=False)
    _, bottom, top = translate(scenario).bodies  # quay, bottom, top; stiffness per contact point [N/m]
    k_ground = CONTACTS_PER_FACE * bottom.stiffness  # Drake's E A / D against the rigid quay
    k_pair = CONTACTS_PER_FACE / (1 / bottom.stiffness + 1 / top.stiffness)  # Drake's E A / (D_a + D_b)
    masses = [c.total_mass() for c in scenario.containers]
    compression = sum(masses) * GRAVITY / k_ground + masses[1] * GRAVITY / k_pair  # [m] 40 um
    assert not f["diverged"]
    assert f["final_position_error_max_m"] < compression
    assert f["position_error_max_m"] < compression
    assert f["energy_gain_max_J"] == 0.0


@pytest.mark.parametrize("scene, overrides, field", [
    ("two_stack", ["effects.learned_dynamics={}"], "effects.learned_dynamics"),
])
def test_an_untranslated_effect_is_refused_in_one_line(scene, overrides, field):
    scenario = load_scenario(scene, overrides=overrides)
    with pytest.raises(UnsupportedSceneError) as caught:
        engine("bullet").check(scenario)
    e = caught.value
    assert e.field == field and "\n" not in str(e)
    assert str(e).startswith(f"scene '{scenario.name}': {field} is not supported by the Bullet engine: ")


@pytest.mark.parametrize("scene", ["crane_hard_landing", "yard_swing_strike", "ship_bay_roll", "ship_bay_open"])
def test_the_crane_and_the_moving_deck_are_accepted(scene):
    """Their laws are applied as external forces (testbed/engines/bullet/loads.py; physics in
    tests/engines/test_bullet_crane.py and test_bullet_deck.py); a crane's load and every body on a
    moving deck never sleep."""
    scenario = load_scenario(scene)
    engine("bullet").check(scenario)
    driven = {b.name for b in translate(scenario).bodies if not b.sleeping}
    crane = scenario.effects.crane
    assert driven == ({crane.container} if crane else {c.name for c in scenario.containers})


def test_a_predictor_is_refused():
    with pytest.raises(ValueError, match="no predictor decides its contact"):
        engine("bullet").run(load_scenario(text=DROP), duration=0.01, predictor="improved")
