"""`deck_motion`: the deck's inertial wrenches are exact, the tilt closed forms hold, twistlocks
hold a stack, a deck at rest adds nothing, and bad input gets one line naming the field.

Frames (testbed/effects/deck/motion.py): the plant's world is the deck D; W is the inertial
world; X_WD(t) is the deck's prescribed pose.
"""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from testbed.builder import build_scene
from testbed.effects.deck.law import DeckMotionLaw, mass_properties
from testbed.effects.deck.motion import DeckMotion, Harmonic
from testbed.effects.deck_motion import lock_mode_rates
from testbed.errors import ScenarioError
from testbed.scenario import load_scenario

G = 9.81  # [m/s^2] Drake's default gravity


def simulate(text: str, times, bodies=("box",), overrides=()):
    """Builds the scene `text`, runs it and samples `bodies` at `times` [s] (n,): (scene,
    p_DC (n, b, 3) [m], R_DC (n, b, 3, 3), v_DC (n, b, 3) [m/s]), b = len(bodies); a single
    body name (str) drops the b axis."""
    scene = build_scene(load_scenario(text=text, overrides=list(overrides)))
    context = scene.create_context()
    simulator = Simulator(scene.diagram, context)
    plant_context = scene.plant.GetMyContextFromRoot(context)
    names = [bodies] if isinstance(bodies, str) else list(bodies)
    p, R, v = [], [], []
    for t in times:
        simulator.AdvanceTo(float(t))
        X = [scene.plant.EvalBodyPoseInWorld(plant_context, scene.bodies[n]) for n in names]
        p.append([x.translation() for x in X])
        R.append([x.rotation().matrix() for x in X])
        v.append([scene.plant.EvalBodySpatialVelocityInWorld(plant_context, scene.bodies[n]).translational() for n in names])
    p, R, v = np.array(p), np.array(R), np.array(v)
    return (scene, p, R, v) if not isinstance(bodies, str) else (scene, p[:, 0], R[:, 0], v[:, 0])


# ----------------------------------------------------------------------------- 1. exactness

FREE_FLIGHT = """name: deck_free_flight
duration: 1.0
plant: {{time_step: {h}}}
containers:
- name: box
  type: 1CC
  mass: 20000.0
  X_WC: {{translation: [1.0, 2.0, 6.0]}}
effects:
  deck_motion:
    roll: {{amplitude: 18.0, period: 4.0, phase_deg: 0.0}}
    pitch: {{amplitude: 5.0, period: 3.0, phase_deg: 0.0}}
    heave: {{amplitude: 2.0, period: 5.0, phase_deg: 0.0}}
    pivot: [0.5, -0.3, -6.0]
    ramp_time: 0.0
"""


P0, V0_W, W0 = np.array([1.0, 2.0, 6.0]), np.array([0.3, -0.2, 1.0]), 0.5  # [m], [m/s], [rad/s] in W at t = 0


def _free_flight(h: float):
    """A 1CC container in free flight (no contact effect) seen from a rolling, pitching and
    heaving deck, started at P0 moving at V0_W and spinning at W0 about its largest principal
    axis (C's y) in W, where X_WD(0) = I but the deck already turns and heaves (ramp_time 0).
    Returns (scene text, the --set giving its initial velocity relative to D, expected(t): the
    analytic world-frame flight seen from the deck, X_DW(t) X_WC(t), as (p_DC, R_DC))."""
    scenario = load_scenario(text=FREE_FLIGHT.format(h=h))
    c = scenario.effects.deck_motion
    motion = DeckMotion((c.roll, c.pitch, c.heave), c.pivot, c.ramp_time)
    d0 = motion.state(0.0)
    assert np.allclose(d0.R_WD, np.eye(3)) and np.allclose(d0.p_WDo, 0.0)
    heave_rate = motion.coordinates(0.0)[1][2]
    v_rel = V0_W - np.array([0.0, 0.0, heave_rate]) - np.cross(d0.Omega_D, P0 - motion.pivot)  # relative to D
    w_rel = np.array([0.0, W0, 0.0]) - d0.Omega_D
    override = f"containers[0].V_WC=[{', '.join(repr(float(x)) for x in (*w_rel, *v_rel))}]"

    def expected(t: float):
        d = motion.state(t)
        p_W = P0 + V0_W * t + 0.5 * np.array([0.0, 0.0, -G]) * t * t  # analytic world-frame flight
        cw, sw = math.cos(W0 * t), math.sin(W0 * t)
        R_W = np.array([[cw, 0.0, sw], [0.0, 1.0, 0.0], [-sw, 0.0, cw]])  # torque-free spin about a principal axis
        return d.R_WD.T @ (p_W - d.p_WDo), d.R_WD.T @ R_W

    return FREE_FLIGHT.format(h=h), override, expected


def _angle(R_a, R_b) -> float:
    return math.acos(min(1.0, max(-1.0, (np.trace(R_a.T @ R_b) - 1) / 2)))


def test_free_flight_in_the_deck_frame_is_the_world_free_flight_seen_from_the_deck():
    """The law is exact: what remains is the time stepping's error, first order in h.

    At h = 1 ms the position error after 1 s must be within the symplectic Euler bound
    h t |a|_max / 2 with |a|_max = 3 g (gravity plus the deck's accelerations at this
    distance from the pivot: |alpha| r + |Omega|^2 r + |h''| + 2 |Omega| |v| < 2 g here), and
    the orientation error within 1e-3 rad (0.06 deg). Halving h must halve both errors
    (ratio 2 +- 0.2): the remaining error is the integrator's, not the law's. And the
    Richardson combination 2 X(h/2) - X(h) must be 10x closer still (the O(h) term cancels):
    a wrong inertial term leaves an error that does not shrink with h.
    """
    runs = {}
    for h in (1e-3, 5e-4):
        text, override, expected = _free_flight(h)
        _, p, R, _ = simulate(text, [1.0], "box", overrides=[override])
        runs[h] = (p[0], R[0])
    p_e, R_e = expected(1.0)
    err_p = {h: np.linalg.norm(p - p_e) for h, (p, _) in runs.items()}
    err_R = {h: _angle(R, R_e) for h, (_, R) in runs.items()}
    assert err_p[1e-3] <= 0.5 * 1e-3 * 1.0 * 3 * G
    assert err_R[1e-3] <= 1e-3
    assert err_p[1e-3] / err_p[5e-4] == pytest.approx(2.0, abs=0.2)
    assert err_R[1e-3] / err_R[5e-4] == pytest.approx(2.0, abs=0.2)
    richardson = 2 * runs[5e-4][0] - runs[1e-3][0]
    assert np.linalg.norm(richardson - p_e) <= 0.1 * err_p[1e-3]


def test_the_mujoco_engine_flies_the_same_free_flight():
    """The MuJoCo translation (mujoco_rows on the free joints' qpos, qvel) reproduces the same
    free flight within the same bounds as Drake's at h = 1 ms (first-order stepping there too)."""
    pytest.importorskip("mujoco")
    from testbed.engines.mujoco.run import simulate_mujoco
    from testbed.geometry.rotations import rotation_from_quaternion

    text, override, expected = _free_flight(1e-3)
    steps = simulate_mujoco(load_scenario(text=text, overrides=[override])).tables["steps"]
    k = int(np.argmin(np.abs(steps["time"] - 1.0)))
    assert steps["time"][k] == pytest.approx(1.0)
    p_e, R_e = expected(1.0)
    assert np.linalg.norm(steps["p_WB"][k, 0] - p_e) <= 0.5 * 1e-3 * 1.0 * 3 * G
    assert _angle(np.asarray(rotation_from_quaternion(steps["q_WB"][k, 0])).reshape(3, 3), R_e) <= 1e-3


def test_mujoco_rows_are_the_same_law_as_drakes():
    """mujoco_rows (qpos, qvel of free joints) and wrenches_D (poses, velocities) agree to
    rounding (1e-9 relative) on a random state: one law for every engine."""
    rng = np.random.default_rng(3)
    motion = DeckMotion((Harmonic(15, 6, 20), Harmonic(5, 4, 50), Harmonic(1.5, 7, 10)), [0.3, -0.2, -5], 1.0)
    law = DeckMotionLaw(motion, (0, 0, -G), [2e4, 5e3], rng.normal(size=(2, 3)) * 0.2,
                        np.array([np.diag([1e4, 3e4, 2.5e4]), np.diag([2e3, 9e3, 8e3])]))
    q = rng.normal(size=(2, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    R = np.array([[[1 - 2 * (y[i]**2 + z[i]**2), 2 * (x[i] * y[i] - w[i] * z[i]), 2 * (x[i] * z[i] + w[i] * y[i])],
                   [2 * (x[i] * y[i] + w[i] * z[i]), 1 - 2 * (x[i]**2 + z[i]**2), 2 * (y[i] * z[i] - w[i] * x[i])],
                   [2 * (x[i] * z[i] - w[i] * y[i]), 2 * (y[i] * z[i] + w[i] * x[i]), 1 - 2 * (x[i]**2 + y[i]**2)]]
                  for i in range(2)])
    p, v, w_C = rng.normal(size=(2, 3)), rng.normal(size=(2, 3)), rng.normal(size=(2, 3))
    rows = law.mujoco_rows(np.hstack([p, q]), np.hstack([v, w_C]), 1.7)
    direct = law.wrenches_D(1.7, p, R, v, np.einsum("kij,kj->ki", R, w_C))
    assert np.abs(direct).max() > 1e3  # the state is not trivial
    np.testing.assert_allclose(rows, direct, rtol=1e-9, atol=1e-9 * np.abs(direct).max())



def test_the_deck_power_is_its_wrenches_power():
    """power_W (what the closed-loop energy gate integrates: testbed/compare/external_work.py) is
    the power of wrenches_D, here moved to the body origins: sum F . v_o + (tau + (c - o) x F) . w
    on a random state [W]; a deck at rest adds no power."""
    rng = np.random.default_rng(5)
    motion = DeckMotion((Harmonic(15, 6, 20), Harmonic(5, 4, 50), Harmonic(1.5, 7, 10)), [0.3, -0.2, -5], 1.0)
    com = rng.normal(size=(2, 3)) * 0.2
    inertia = np.array([np.diag([1e4, 3e4, 2.5e4]), np.diag([2e3, 9e3, 8e3])])
    law = DeckMotionLaw(motion, (0, 0, -G), [2e4, 5e3], com, inertia)
    R = np.array([_rot(rng.normal(size=3)) for _ in range(2)])
    p, v, w = (rng.normal(size=(2, 3)) for _ in range(3))
    rows = law.wrenches_D(1.7, p, R, v, w)
    arm = np.einsum("kij,kj->ki", R, com)
    expected = np.sum(rows[:, :3] * v) + np.sum((rows[:, 3:] + np.cross(arm, rows[:, :3])) * w)
    assert abs(expected) > 1e3
    assert law.power_W(1.7, p, R, v, w) == pytest.approx(expected, rel=1e-12)
    still = DeckMotionLaw(DeckMotion((Harmonic(), Harmonic(), Harmonic()), [0, 0, -5], 0.0), (0, 0, -G),
                          [2e4, 5e3], com, inertia)
    assert still.power_W(1.7, p, R, v, w) == 0.0


def _rot(axis_angle) -> np.ndarray:
    """The rotation matrix of a rotation vector [rad] (Rodrigues)."""
    angle = np.linalg.norm(axis_angle)
    k = np.array([[0, -axis_angle[2], axis_angle[1]], [axis_angle[2], 0, -axis_angle[0]],
                  [-axis_angle[1], axis_angle[0], 0]]) / angle
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


# ----------------------------------------------------------------------------- 2. tilt closed forms

TILT = """name: deck_tilt
duration: 3.0
containers:
- name: box
  type: box
  mass: {mass}
  X_WC: {{translation: [0.0, 0.0, {z}]}}
  box: {{size: {size}, corner_spheres: {spheres}}}
effects:
  contact: {{model: {model}, approximation: auto}}
  friction: {{mu: {mu}}}
  deck_motion:
    roll: {{amplitude: 30.0, period: 24.0, phase_deg: 0.0}}
    pivot: [0.0, 0.0, 0.0]
    ramp_time: 0.5
    twistlocks: open
"""
# a slow roll: 30 deg amplitude, 24 s period, through the friction and tipping angles
# (16.7, 17.7 deg) near t = 2.3 - 2.5 s at 7.7 deg/s. Not quite quasi-static: the Euler term
# |phi''| z (0.016 m/s^2 at a COM 0.75 m above the roll axis) turns the apparent gravity by
# 0.09 deg more than the roll; the closed forms below use the apparent gravity's angle phi_a
# at the COM at rest in D (g_D - a_P - alpha x r - Omega x (Omega x r), the deck's state), and
# phi_a' for its rate.
SAMPLE = 0.005  # [s] sampling of the onset: 0.04 deg of roll at 7.7 deg/s


def _apparent_tilt(scene, t: float, z: float) -> tuple[float, float]:
    """(phi_a [rad], phi_a' [rad/s]): the angle from D's -z of the apparent gravity at a point
    at rest in D, z [m] above the roll axis on it, at t [s]; the rate by central differences."""
    motion = scene.effects["deck_motion"].systems[0].law.motion

    def angle(time):
        d = motion.state(time)
        r = np.array([0.0, 0.0, z]) - motion.pivot
        a = d.R_WD.T @ np.array([0.0, 0.0, -G]) - d.a_P_D - np.cross(d.alpha_D, r) - np.cross(d.Omega_D, np.cross(d.Omega_D, r))
        return math.atan2(-a[1], -a[2])

    return angle(t), (angle(t + 1e-4) - angle(t - 1e-4)) / 2e-4


def test_a_low_flat_box_starts_sliding_at_the_friction_angle():
    """tan(phi) = mu at onset (mu 0.3: 16.70 deg; Drake's discrete solver uses mu_dynamic,
    set equal to mu_static here). Onset is detected when the sliding speed passes 1 mm/s, which
    lags the true onset by tau = sqrt(2 v / j), j = g phi' (cos phi + mu sin phi) the rate of
    the sliding acceleration g (sin phi - mu cos phi): the detected apparent tilt must lie within
    0.1 deg of phi_mu + phi_a' tau (sampling 0.04 deg; Drake's stiction creep below 1 mm/s;
    the Coriolis force of the slow start, 2 phi' v, below 1e-4 g). The box
    (2 x 2 x 0.5 m, w/h = 4) cannot tip first."""
    mu, threshold = 0.3, 1e-3
    times = np.arange(1.8, 3.0, SAMPLE)
    scene, p, _, v = simulate(TILT.format(mass=2000.0, z=0.25, size=[2.0, 2.0, 0.5], spheres=0.0,
                                          model="hydroelastic_with_fallback", mu=mu), times, "box")
    assert abs(p[0, 1]) < 1e-4  # at rest (within 0.1 mm) before the friction angle
    k = int(np.argmax(np.abs(v[:, 1]) > threshold))
    assert k > 0 and v[k, 1] < 0  # slides downhill (-y in D when the roll is positive)
    phi_mu = math.atan(mu)
    t_mu = times[int(np.argmax([_apparent_tilt(scene, t, 0.25)[0] > phi_mu for t in times]))]
    rate = _apparent_tilt(scene, t_mu, 0.25)[1]
    tau = math.sqrt(2 * threshold / (G * rate * (math.cos(phi_mu) + mu * math.sin(phi_mu))))
    detected = _apparent_tilt(scene, times[k], 0.25)[0]
    assert math.degrees(detected) == pytest.approx(math.degrees(phi_mu + rate * tau), abs=0.1)


def test_a_tall_narrow_box_with_high_friction_tips_at_w_over_h():
    """tan(phi) = w/h at onset for a box standing on its edges: with corner spheres of radius
    r (point contact at the corners, no compliant patch moving the support inward) the support
    edges are at +-(w/2 - r), so tan(phi_tip) = (w/2 - r) / (h/2): 17.74 deg for 0.5 x 1.5 m,
    r = 1 cm (w/h = 18.43 deg as r -> 0). mu = 1.5 (56 deg): it cannot slide. Onset is detected
    when the tilt relative to the deck passes 0.005 deg (16x the contact's compliant tilt
    before it, 3e-4 deg); the toppling moment m g L (phi - phi_tip) with L the COM-to-edge
    distance turns it by that angle after tau = (6 I theta / (m g L phi'))^(1/3), I about the
    edge: the detected apparent tilt must lie within 0.1 deg of phi_tip + phi_a' tau (sampling
    0.04 deg; the tilt's own feedback in the toppling moment, m g L theta, shortens tau by a few %)."""
    w, h, r, m, threshold = 0.5, 1.5, 0.01, 500.0, math.radians(0.005)
    times = np.arange(1.8, 3.0, SAMPLE)
    scene, _, R, _ = simulate(TILT.format(mass=m, z=h / 2, size=[1.0, w, h], spheres=r, model="point", mu=1.5), times, "box")
    tilt = np.abs(np.arctan2(R[:, 2, 1], R[:, 2, 2]))  # about D's x, relative to the deck
    assert tilt[0] < math.radians(1e-3)
    k = int(np.argmax(tilt > threshold))
    assert k > 0
    phi_tip = math.atan((w / 2 - r) / (h / 2))
    t_tip = times[int(np.argmax([_apparent_tilt(scene, t, h / 2)[0] > phi_tip for t in times]))]
    rate = _apparent_tilt(scene, t_tip, h / 2)[1]
    L = math.hypot(w / 2 - r, h / 2)
    I_edge = m / 12 * (w * w + h * h) + m * L * L
    tau = (6 * I_edge * threshold / (m * G * L * rate)) ** (1 / 3)
    detected = _apparent_tilt(scene, times[k], h / 2)[0]
    assert math.degrees(detected) == pytest.approx(math.degrees(phi_tip + rate * tau), abs=0.1)


# ----------------------------------------------------------------------------- 3. twistlocks

def _apparent_lateral(scene, t: float, z: float) -> float:
    """|a_y| [m/s^2]: the lateral (D's y) apparent acceleration at a point at rest in D, z [m]
    above the roll axis, at t [s] (as _apparent_tilt)."""
    motion = scene.effects["deck_motion"].systems[0].law.motion
    d = motion.state(t)
    r = np.array([0.0, 0.0, z]) - motion.pivot
    a = d.R_WD.T @ np.array([0.0, 0.0, -G]) - d.a_P_D - np.cross(d.alpha_D, r) - np.cross(d.Omega_D, np.cross(d.Omega_D, r))
    return abs(float(a[1]))


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
"""


def _stack_slip(locks: str) -> tuple[float, float, object]:
    """The slip at each interface over the roll to 22 deg [m]: (largest |y| of the bottom box's
    bottom-face centre on the deck, largest |y| of the top box's bottom-face centre relative to
    the bottom box's top-face centre, in the bottom box's frame), and the built scene. Face
    centres, not box centres: a box rocking on its compliant contact is no slip."""
    times = np.arange(0.1, 1.6 + 1e-9, 0.1)
    scene, p, R, _ = simulate(STACK.format(locks=locks), times, bodies=("bottom", "top"))
    half = np.array([0.0, 0.0, 2.591 / 2])  # [m] half the 1CC's height
    base = p[:, 0] - R[:, 0] @ half  # bottom face of the bottom box, in D
    seat = np.einsum("nji,nj->ni", R[:, 0], p[:, 1] - R[:, 1] @ half - p[:, 0]) - half  # in the bottom box's frame
    return float(np.abs(base[:, 1]).max()), float(np.abs(seat[:, 1]).max()), scene


def test_locked_twistlocks_hold_the_stack_where_open_ones_let_it_slide():
    """The roll reaches 22 deg at 1.6 s, past the friction angle (mu 0.3: 16.7 deg) from 1.1 s.
    Open: the stack slides (more than 2 cm by 1.6 s). Locked: each tier's slip is at most the
    locks' elastic stretch under the whole lateral load, F / (4 k) with F = m a_y of the mass above
    the locks (a_y: the largest apparent lateral acceleration, gravity's and the Euler and
    centrifugal terms', at the top box's COM, the highest: 3.9 m above the roll axis), times 2
    (dynamic amplification of a step load on a damped spring: at most 2);
    friction carries part of it, so the stretch is smaller still. 4 locks per tier: the deck's
    under the bottom box, the bottom box's under the top one."""
    open_bottom, open_top, _ = _stack_slip("open")
    bottom, top, scene = _stack_slip("locked")
    assert max(open_bottom, open_top) > 0.02
    law = scene.effects["deck_motion"].systems[0].law
    assert law.upper.size == 8 and sorted(law.lower.tolist()) == [-1] * 4 + [0] * 4  # found at t = 0
    k, load = law.k, max(_apparent_lateral(scene, t, 3.8865) for t in np.linspace(0.0, 1.6, 161))
    assert bottom <= 2 * 4400.0 * load / (4 * k)
    assert top <= 2 * 2200.0 * load / (4 * k)


# ----------------------------------------------------------------------------- 4. a deck at rest

def test_a_deck_at_rest_adds_exactly_nothing():
    """Zero amplitudes: the law's wrenches are exactly 0 on any state, and a stack settles
    bit for bit as without the effect (the same final poses and velocities)."""
    law = DeckMotionLaw(DeckMotion((Harmonic(), Harmonic(), Harmonic()), [0, 0, -6], 2.0), (0, 0, -G),
                        [2e4], [[0.1, 0, 0]], [np.diag([1e4, 3e4, 2.5e4])])
    rng = np.random.default_rng(7)
    rows = law.wrenches_D(1.3, rng.normal(size=(1, 3)), np.eye(3)[None], rng.normal(size=(1, 3)), rng.normal(size=(1, 3)))
    assert np.all(rows == 0.0)
    text = STACK.format(locks="open").replace("duration: 1.6", "duration: 0.2")
    without = "\n".join(line for line in text.splitlines() if not line.startswith("  deck_motion") and not line.startswith("    "))
    states = []
    for scene_text in (text.replace("amplitude: 30.0", "amplitude: 0.0"), without):
        scene = build_scene(load_scenario(text=scene_text))
        context = scene.create_context()
        Simulator(scene.diagram, context).AdvanceTo(0.2)
        states.append(scene.plant.GetPositionsAndVelocities(scene.plant.GetMyContextFromRoot(context)))
    assert "deck_motion" not in without and np.abs(states[1] - states[0]).max() == 0.0
    assert np.abs(states[0][7:14] - np.array([1, 0, 0, 0, 0, 0, 3.8865])).max() < 1e-2  # settled, not flown off


# ----------------------------------------------------------------------------- 5. bad input

GOOD = STACK.replace("duration: 1.6", "duration: 0.01").format(locks="open")


@pytest.mark.parametrize("edit, field", [
    (("period: 12.0", "period: -3.0"), "effects.deck_motion.roll.period"),
    (("amplitude: 30.0", "amplitude: .nan"), "effects.deck_motion.roll.amplitude"),
    (("ramp_time: 0.5", "ramp_time: .inf"), "effects.deck_motion.ramp_time"),
    (("pivot: [0.0, 0.0, 0.0]", "pivot: [0.0, .nan, 0.0]"), "effects.deck_motion.pivot"),
    (("twistlocks: open", "twistlocks: welded"), "effects.deck_motion.twistlocks"),
    (("twistlocks: open", "twistlocks: locked\n    twistlock_stiffness: 1.0e12"), "effects.deck_motion.twistlock_stiffness"),
    (("twistlocks: open", "time_series: no_such_motion.csv"), "effects.deck_motion.time_series"),
])
def test_bad_fields_get_one_line_naming_the_field(edit, field):
    text = GOOD.replace(*edit)
    assert text != GOOD
    with pytest.raises(ScenarioError) as info:
        load_scenario(text=text)
    message = str(info.value)
    assert field in message and "\n" not in message


@pytest.mark.parametrize("name, content, needle", [
    ("nan.csv", "t, roll, pitch, heave\n0, 0, 0, 0\n1, nan, 0, 0\n", "roll of sample 1"),
    ("words.csv", "0, 0, 0, 0\n1, 2, three, 0\n", "line 2"),
    ("short.csv", "0, 0, 0, 0\n1, 2, 3, 0\n", "cover"),
    ("backwards.csv", "0, 0, 0, 0\n0, 1, 0, 0\n2, 2, 0, 0\n", "strictly increasing"),
    ("missing.npz", None, "has no array heave"),
])
def test_bad_time_series_files_get_one_line_naming_file_and_field(tmp_path, name, content, needle):
    """Untrusted data: parsed by numpy only, every problem one line naming the file and the field."""
    path = tmp_path / name
    if content is None:
        np.savez(path, t=np.array([0.0, 1.0]), roll=np.zeros(2), pitch=np.zeros(2))
    else:
        path.write_text(content)
    scene = tmp_path / "scene.yaml"
    scene.write_text(GOOD.replace("duration: 0.01", "duration: 1.5").replace("twistlocks: open", f"time_series: {name}"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(scene)
    message = str(info.value)
    assert "effects.deck_motion.time_series" in message and str(path) in message and needle in message
    assert "\n" not in message


def test_a_good_time_series_drives_the_deck(tmp_path):
    """A CSV of a slow roll is read and splined: its roll at the samples is the file's (the ramp
    is 1 there) within the spline's exact interpolation (1e-12 rad)."""
    t = np.linspace(0.0, 2.0, 21)
    roll = 10.0 * np.sin(t)
    (tmp_path / "roll.csv").write_text("t, roll, pitch, heave\n" + "".join(f"{float(a)!r}, {float(b)!r}, 0, 0\n" for a, b in zip(t, roll)))
    scene = tmp_path / "scene.yaml"
    scene.write_text(GOOD.replace("duration: 0.01", "duration: 2.0").replace("ramp_time: 0.5", "ramp_time: 0.0")
                     .replace("twistlocks: open", "time_series: roll.csv"))
    built = build_scene(load_scenario(scene))
    motion = built.effects["deck_motion"].systems[0].law.motion
    for k in (5, 13):
        assert motion.coordinates(t[k])[0][0] == pytest.approx(math.radians(roll[k]), abs=1e-12)


# ----------------------------------------------------------------------------- 6. the locks' explicit stability

EMPTY_PAIR = """name: empty_pair
duration: 0.2
containers:
- name: bottom
  type: 1CC
  X_WC: {{translation: [0.0, 0.0, 1.2955]}}
- name: top
  type: 1CC
  X_WC: {{translation: [0.0, 0.0, 3.8865]}}
  V_WC: [0.0, 0.0, 0.02, 0.0, 0.0, 0.0]
effects:
  contact: {{model: hydroelastic_with_fallback, approximation: auto}}
  friction: {{mu: 0.0}}
  deck_motion:
    twistlocks: locked
{extra}"""  # two empty 20 ft boxes (tare 2200 kg) locked on the deck, at rest; the top one yawing at 0.02 rad/s


def test_the_lock_check_refuses_a_damping_just_above_the_yaw_limit():
    """Two equal bodies locked in a chain, yaw stiffness and damping 4 k (a^2 + b^2), 4 c (a^2 + b^2)
    per interface, inertia I_zz (mass_properties): the chain's largest eigenvalue is
    (3 + sqrt 5) / 2 times one body's on the deck, mu = (3 + sqrt 5) / 2 x 4 (a^2 + b^2) / I_zz,
    the largest of the modes here; c h mu <= 1 allows c up to 1 / (h mu): 1.01 of it is refused,
    naming the field and the figure, 0.99 of it accepted."""
    scenario = load_scenario(text=EMPTY_PAIR.format(extra=""))
    spec = scenario.containers[0]
    a, b, _ = spec.container_type().half_size
    I_zz = mass_properties([spec])[2][0][2, 2]
    mu = (3 + math.sqrt(5)) / 2 * 4 * (a * a + b * b) / I_zz
    rates = lock_mode_rates(scenario)
    assert rates["yaw"] == pytest.approx(mu, rel=1e-9) and max(rates.values()) == pytest.approx(mu, rel=1e-9)
    limit = float(1 / (scenario.plant.time_step * mu))
    with pytest.raises(ScenarioError) as info:
        load_scenario(text=EMPTY_PAIR.format(extra=f"    twistlock_damping: {1.01 * limit!r}\n"))
    message = str(info.value)
    assert "effects.deck_motion.twistlock_damping" in message and "yaw" in message and "1.01 > 1" in message
    assert f"{limit:.3g}" in message and "\n" not in message
    load_scenario(text=EMPTY_PAIR.format(extra=f"    twistlock_damping: {0.99 * limit!r}\n"))


def test_a_yawing_locked_pair_of_empty_boxes_without_friction_comes_to_rest_in_bullet():
    """The pair above with the default locks, in Bullet (no friction to absorb the yaw: the old
    damping, 2e5 N s/m, c h mu = 2.86, diverged to nan within 0.06 s): the kinetic energy never
    exceeds its initial value and falls below 1e-4 of it by 0.2 s (measured 1e-9)."""
    pytest.importorskip("pybullet")
    from testbed.engines.bullet.run import simulate_bullet
    from testbed.geometry.rotations import rotation_from_quaternion

    scenario = load_scenario(text=EMPTY_PAIR.format(extra=""))
    steps = simulate_bullet(scenario, contacts=False).tables["steps"]
    masses, _, inertia = mass_properties(scenario.containers)
    R = rotation_from_quaternion(steps["q_WB"])  # (t, 2, 3, 3)
    w, v = steps["V_WB"][:, :, :3], steps["V_WB"][:, :, 3:]
    energy = 0.5 * (np.einsum("b,tbi,tbi->t", masses, v, v)
                    + np.einsum("tbi,tbij,bjk,tblk,tbl->t", w, R, inertia, R, w))
    assert steps["time"][-1] == pytest.approx(0.2) and np.all(np.isfinite(energy))
    assert energy.max() <= energy[0] * (1 + 1e-6) and energy[-1] < 1e-4 * energy[0]
