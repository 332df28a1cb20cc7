"""`crane` in Bullet (testbed/engines/bullet/loads.py): testbed/effects/crane.py's RopeModel
applied each step as external forces. A load swung by a trolley nudge follows the pendulum's
closed form; a load lowered onto the quay is released when seated. Skipped where pybullet is
not installed."""

import math

import numpy as np
import pytest

from testbed.effects.crane import Profile
from testbed.engines.bullet.model import INSTALL
from testbed.scenario import load_scenario

G = 9.81  # [m/s^2]
ROPE = 2.0  # [m] the hanging rope length (sheaves to the top corner castings)

pytest.importorskip("pybullet", reason=f"pybullet is not installed; install it with: {INSTALL}")

SWING = f"""name: swing
duration: 2.5
containers:
- name: load
  type: 1AA
  mass: 25000.0
  X_WC: {{translation: [0.0, 0.0, 6.0], rotation: !Rpy {{deg: [0.0, 0.0, 90.0]}}}}
effects:
  contact: {{}}
  crane:
    container: load
    trolley_height: {6.0 + 2.591 / 2 + ROPE}
    moves:
    - {{kind: trolley, target: 0.3, speed: 0.6, acceleration: 1.0}}
"""  # yard_swing_strike's load and nudge in the open, on 2 m ropes: it swings 0.26 m about the trolley

LANDING = """name: landing
duration: 0.8
containers:
- name: load
  type: 1CC
  mass: 20000.0
  X_WC: {translation: [0.0, 0.0, 1.3455]}
effects:
  contact: {}
  friction: {}
  crane:
    container: load
    trolley_height: 6.0
    moves:
    - {kind: pause, duration: 0.1}
    - {kind: hoist, target: 0.2, speed: 0.2, acceleration: 1.0}
"""  # a 1CC 5 cm above the quay, still for 0.1 s, then paid out 0.2 m at 0.2 m/s: it lands at about 0.45 s


def _run(text):
    from testbed.engines.bullet.run import simulate_bullet

    scenario = load_scenario(text=text)
    return scenario, simulate_bullet(scenario, contacts=False)


def _pendulum(profile: Profile, times: np.ndarray, dt: float = 1e-3) -> np.ndarray:
    """x [m] of a point pendulum of length ROPE hanging from the trolley x_T(t) (profile), from rest:
    theta'' = -(g / L) sin(theta) - x_T''(t) cos(theta) / L, x = x_T + L sin(theta) (the four ropes
    form a parallelogram: the load translates level, every point on that circle), by RK4 at dt."""

    def accel(t):  # x_T'' [m/s^2], piecewise constant (central difference of the profile's speed)
        return (profile(t + 1e-7)[1] - profile(t - 1e-7)[1]) / 2e-7

    def f(t, y):
        return np.array([y[1], -(G / ROPE) * math.sin(y[0]) - accel(t) * math.cos(y[0]) / ROPE])

    y, out, t = np.zeros(2), [], 0.0
    for target in times:
        while t < target - 1e-12:
            step = min(dt, target - t)
            k1 = f(t, y)
            k2 = f(t + step / 2, y + step / 2 * k1)
            k3 = f(t + step / 2, y + step / 2 * k2)
            k4 = f(t + step, y + step * k3)
            y, t = y + step / 6 * (k1 + 2 * k2 + 2 * k3 + k4), t + step
        out.append(profile(t)[0] + ROPE * math.sin(y[0]))
    return np.array(out)


def test_a_nudged_load_swings_as_the_pendulum():
    """The load's x follows the closed-form pendulum within 2 mm (under 1% of its 0.26 m swing
    about the trolley; measured 0.55 mm: the step and the ropes' 0.1 mm static stretch), stays
    level (angular speed below 1e-3 rad/s, measured 5e-4) and is never released (no contact)."""
    scenario, run = _run(SWING)
    steps = run.tables["steps"]
    times = steps["time"][::10]
    x = steps["p_WB"][::10, 0, 0]
    profile = Profile(scenario.effects.crane.moves, 0.0)
    swing = np.abs(x - np.array([profile(t)[0] for t in times])).max()
    assert swing > 0.2
    np.testing.assert_allclose(x, _pendulum(profile, times), atol=2e-3)
    assert np.abs(steps["V_WB"][:, 0, :3]).max() < 1e-3
    assert run.summary["crane_release_time_s"] is None


def test_a_lowered_load_is_released_when_seated_and_rests_on_the_quay():
    """Hangs still at t = 0 (the ropes carry the weight: under 0.1 mm in the first 0.1 s), lands,
    and the twistlocks open once it touches and descends slower than seated_speed; it then rests
    on the quay (its bottom within 1 mm of z = 0, at rest)."""
    scenario, run = _run(LANDING)
    steps = run.tables["steps"]
    z = steps["p_WB"][:, 0, 2]
    h = run.summary["time_step_s"]
    assert np.abs(z[: int(0.1 / h)] - z[0]).max() < 1e-4
    released = run.summary["crane_release_time_s"]
    assert released is not None and 0.3 < released < 0.8
    assert abs(z[-1] - 2.591 / 2) < 1e-3
    assert np.abs(steps["V_WB"][-1, 0]).max() < scenario.effects.crane.seated_speed
