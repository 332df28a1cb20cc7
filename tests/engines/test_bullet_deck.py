"""`deck_motion` in Bullet (testbed/engines/bullet/loads.py): the deck's one law
(testbed/effects/deck/law.py) applied as external forces each step. A cheap subset of
tests/effects/test_deck_motion.py's checks of Drake and MuJoCo, with their tolerances: the free
flight seen from the deck, sliding at tan(phi) = mu, tipping at w/h, locked twistlocks holding a
stack that open ones let slide. Skipped where pybullet is not installed."""

import math

import numpy as np
import pytest

from testbed.effects.deck.motion import DeckMotion
from testbed.effects.deck_motion import build_law
from testbed.engines.bullet.model import INSTALL
from testbed.geometry.rotations import rotation_from_quaternion
from testbed.scenario import load_scenario

G = 9.81  # [m/s^2]

pytest.importorskip("pybullet", reason=f"pybullet is not installed; install it with: {INSTALL}")


def _run(text, overrides=(), **kwargs):
    """(scenario, steps table) of a Bullet run of the scene `text` (no contact rows)."""
    from testbed.engines.bullet.run import simulate_bullet

    scenario = load_scenario(text=text, overrides=list(overrides))
    return scenario, simulate_bullet(scenario, contacts=False, **kwargs).tables["steps"]


def _motion(scenario) -> DeckMotion:
    c = scenario.effects.deck_motion
    return DeckMotion((c.roll, c.pitch, c.heave), c.pivot, c.ramp_time)


def _angle(R_a, R_b) -> float:
    return math.acos(min(1.0, max(-1.0, (np.trace(R_a.T @ R_b) - 1) / 2)))


FREE_FLIGHT = """name: deck_free_flight
duration: 1.0
containers:
- name: box
  type: 1CC
  mass: 20000.0
  X_WC: {translation: [1.0, 2.0, 6.0]}
effects:
  deck_motion:
    roll: {amplitude: 18.0, period: 4.0, phase_deg: 0.0}
    pitch: {amplitude: 5.0, period: 3.0, phase_deg: 0.0}
    heave: {amplitude: 2.0, period: 5.0, phase_deg: 0.0}
    pivot: [0.5, -0.3, -6.0]
    ramp_time: 0.0
"""
P0, V0_W, W0 = np.array([1.0, 2.0, 6.0]), np.array([0.3, -0.2, 1.0]), 0.5  # [m], [m/s], [rad/s] in W at t = 0


def test_a_free_flight_in_the_deck_frame_is_the_world_free_flight_seen_from_the_deck():
    """test_deck_motion's free flight (a 1CC box thrown and spun about its y axis in W, seen from a
    rolling, pitching and heaving deck, no contact) at h = 1 ms within Drake's bounds: position
    error at 1 s within h t |a|_max / 2 (|a|_max = 3 g; 14.7 mm; Bullet measured 8.0 mm, first
    order: 4.0 mm at h / 2), orientation within 1e-3 rad (measured 1.2e-4)."""
    scenario = load_scenario(text=FREE_FLIGHT)
    motion = _motion(scenario)
    d0 = motion.state(0.0)
    heave_rate = motion.coordinates(0.0)[1][2]
    v_rel = V0_W - np.array([0.0, 0.0, heave_rate]) - np.cross(d0.Omega_D, P0 - motion.pivot)  # relative to D
    w_rel = np.array([0.0, W0, 0.0]) - d0.Omega_D
    override = f"containers[0].V_WC=[{', '.join(repr(float(x)) for x in (*w_rel, *v_rel))}]"
    _, steps = _run(FREE_FLIGHT, [override])
    assert steps["time"][-1] == pytest.approx(1.0)
    d = motion.state(1.0)
    p_W = P0 + V0_W + 0.5 * np.array([0.0, 0.0, -G])  # the analytic world flight at t = 1 s
    c, s = math.cos(W0), math.sin(W0)
    R_W = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    p_e, R_e = d.R_WD.T @ (p_W - d.p_WDo), d.R_WD.T @ R_W
    assert np.linalg.norm(steps["p_WB"][-1, 0] - p_e) <= 0.5 * 1e-3 * 1.0 * 3 * G
    assert _angle(np.asarray(rotation_from_quaternion(steps["q_WB"][-1, 0])).reshape(3, 3), R_e) <= 1e-3


TILT = """name: deck_tilt
duration: 3.0
containers:
- name: box
  type: box
  mass: {mass}
  X_WC: {{translation: [0.0, 0.0, {z}]}}
  box: {{size: {size}}}
effects:
  contact: {{model: hydroelastic_with_fallback, approximation: auto}}
  friction: {{mu: {mu}}}
  deck_motion:
    roll: {{amplitude: 30.0, period: 24.0, phase_deg: 0.0}}
    pivot: [0.0, 0.0, 0.0]
    ramp_time: 0.5
    twistlocks: open
"""  # test_deck_motion's slow roll (7.7 deg/s through 16.7 - 18.4 deg near t = 2.3 - 2.6 s)


def _apparent_tilt(motion, t: float, z: float) -> tuple[float, float]:
    """(phi_a [rad], phi_a' [rad/s]): the apparent gravity's angle from D's -z at a point at rest
    in D, z [m] above the roll axis, at t [s] (test_deck_motion's), and its rate."""

    def angle(time):
        d = motion.state(time)
        r = np.array([0.0, 0.0, z]) - motion.pivot
        a = d.R_WD.T @ np.array([0.0, 0.0, -G]) - d.a_P_D - np.cross(d.alpha_D, r) - np.cross(d.Omega_D, np.cross(d.Omega_D, r))
        return math.atan2(-a[1], -a[2])

    return angle(t), (angle(t + 1e-4) - angle(t - 1e-4)) / 2e-4


def _crossing(motion, times, z: float, angle: float) -> float:
    """[s] the first of `times` after 1.8 s at which the apparent tilt at height z [m] exceeds `angle` [rad]."""
    times = times[times > 1.8]
    return times[int(np.argmax([_apparent_tilt(motion, t, z)[0] > angle for t in times]))]


def test_a_low_flat_box_starts_sliding_at_the_friction_angle():
    """tan(phi) = mu at onset (mu 0.3: 16.70 deg), detected when the sliding speed passes 1 mm/s:
    within 0.1 deg of phi_mu + phi_a' tau, tau = sqrt(2 v / j) (test_deck_motion's closed form and
    tolerance; Bullet measured 0.005 deg off). At rest before: within 0.1 mm (measured 0.06 mm)."""
    mu, threshold = 0.3, 1e-3
    scenario, steps = _run(TILT.format(mass=2000.0, z=0.25, size=[2.0, 2.0, 0.5], mu=mu), duration=2.4)
    motion, t = _motion(scenario), steps["time"]
    y, v = steps["p_WB"][:, 0, 1], steps["V_WB"][:, 0, 4]
    k = int(np.argmax(np.abs(v) > threshold))
    assert k > 0 and v[k] < 0  # slides downhill (-y in D when the roll is positive)
    assert np.abs(y[:k]).max() < 1e-4
    phi_mu = math.atan(mu)
    rate = _apparent_tilt(motion, _crossing(motion, t, 0.25, phi_mu), 0.25)[1]
    tau = math.sqrt(2 * threshold / (G * rate * (math.cos(phi_mu) + mu * math.sin(phi_mu))))
    detected = _apparent_tilt(motion, t[k], 0.25)[0]
    assert math.degrees(detected) == pytest.approx(math.degrees(phi_mu + rate * tau), abs=0.1)


def test_a_tall_narrow_box_with_high_friction_tips_at_w_over_h():
    """tan(phi) = w/h at onset (0.5 x 1.5 m: 18.43 deg; Bullet's box-plane manifold is the
    corners: no corner spheres, r = 0 in test_deck_motion's formula), mu 1.5: it cannot slide.
    Detected when its tilt relative to the deck passes 0.005 deg: within 0.1 deg of
    phi_tip + phi_a' tau, tau = (6 I theta / (m g L phi'))^(1/3) (Bullet measured 0.06 deg early)."""
    w, h, m, threshold = 0.5, 1.5, 500.0, math.radians(0.005)
    scenario, steps = _run(TILT.format(mass=m, z=h / 2, size=[1.0, w, h], mu=1.5), duration=2.65)
    motion, t = _motion(scenario), steps["time"]
    R = rotation_from_quaternion(steps["q_WB"][:, 0])
    tilt = np.abs(np.arctan2(R[:, 2, 1], R[:, 2, 2]))
    k = int(np.argmax(tilt > threshold))
    assert k > 0 and tilt[t < 1.8].max() < math.radians(1e-3)  # upright before (measured 4e-4 deg)
    phi_tip = math.atan(w / h)
    rate = _apparent_tilt(motion, _crossing(motion, t, h / 2, phi_tip), h / 2)[1]
    L = math.hypot(w / 2, h / 2)
    I_edge = m / 12 * (w * w + h * h) + m * L * L
    tau = (6 * I_edge * threshold / (m * G * L * rate)) ** (1 / 3)
    detected = _apparent_tilt(motion, t[k], h / 2)[0]
    assert math.degrees(detected) == pytest.approx(math.degrees(phi_tip + rate * tau), abs=0.1)


STACK = """name: deck_stack
duration: 1.6
containers:
- name: bottom
  type: 1CC
  mass: 2200.0
  X_WC: {{translation: [0.0, 0.0, 1.2955]}}
- name: top
  type: 1CC
  mass: 2200.0
  X_WC: {{translation: [0.0, 0.0, 3.8865]}}
effects:
  contact: {{model: hydroelastic_with_fallback, approximation: auto}}
  friction: {{mu: 0.3}}
  deck_motion:
    roll: {{amplitude: 30.0, period: 12.0, phase_deg: 0.0}}
    pivot: [0.0, 0.0, 0.0]
    ramp_time: 0.5
    twistlocks: {locks}
"""  # test_deck_motion's stack: the roll reaches 22 deg at 1.6 s, past mu 0.3's 16.7 deg from 1.1 s


def _stack_slip(locks: str) -> tuple[float, float]:
    """(largest |y| of the bottom box's bottom-face centre on the deck, largest |y| of the top
    box's bottom-face centre from the bottom box's top-face centre, in the bottom box's frame) [m]."""
    _, steps = _run(STACK.format(locks=locks))
    p, R = steps["p_WB"], rotation_from_quaternion(steps["q_WB"])
    half = np.array([0.0, 0.0, 2.591 / 2])  # [m] half the 1CC's height
    base = p[:, 0] - R[:, 0] @ half
    seat = np.einsum("nji,nj->ni", R[:, 0], p[:, 1] - R[:, 1] @ half - p[:, 0]) - half
    return float(np.abs(base[:, 1]).max()), float(np.abs(seat[:, 1]).max())


def test_locked_twistlocks_hold_the_stack_where_open_ones_let_it_slide():
    """test_deck_motion's bounds: open, the stack slides more than 2 cm by 1.6 s; locked, each
    tier's slip stays within twice the locks' elastic stretch under the whole lateral load,
    2 m a_y / (4 k), a_y the largest apparent lateral acceleration at the top box's COM."""
    assert max(_stack_slip("open")) > 0.02
    bottom, top = _stack_slip("locked")
    scenario = load_scenario(text=STACK.format(locks="locked"))
    law = build_law(scenario.effects.deck_motion, scenario, scenario.containers)
    assert law.upper.size == 8 and sorted(law.lower.tolist()) == [-1] * 4 + [0] * 4
    motion = _motion(scenario)
    r = np.array([0.0, 0.0, 3.8865])
    load = 0.0
    for t in np.arange(0.0, 1.6 + 1e-9, 0.01):
        d = motion.state(t)
        a = d.R_WD.T @ np.array([0.0, 0.0, -G]) - d.a_P_D - np.cross(d.alpha_D, r) - np.cross(d.Omega_D, np.cross(d.Omega_D, r))
        load = max(load, abs(float(a[1])))
    k = scenario.effects.deck_motion.twistlock_stiffness
    assert bottom <= 2 * 4400.0 * load / (4 * k)
    assert top <= 2 * 2200.0 * load / (4 * k)
