"""The crane effect: a hanging container is in equilibrium, trolley motion makes it sway
with the pendulum period, and the twistlocks release once it is seated."""

import math

import numpy as np
import pytest

from testbed import load_scenario, run_scenario
from testbed.effects.crane import CraneMove, Profile

H = 2.591
G = 9.81

SCENE = """
name: crane_probe
duration: {duration}
containers:
- name: load
  type: 1CC
  mass: 20000
  X_WC: {{translation: [0.0, 0.0, {z}]}}
effects:
  contact: {{model: hydroelastic}}
  friction: {{}}
  contact_log: {{}}
  crane:
    container: load
    trolley_height: {height}
    moves: {moves}
"""


def _run(*, duration, z, height=12.0, moves="[]"):
    text = SCENE.format(duration=duration, z=z, height=height, moves=moves)
    return run_scenario(load_scenario(text=text))


def test_trapezoid_profile_reaches_its_targets():
    p = Profile([CraneMove(kind="trolley", target=3.0, speed=1.0, acceleration=0.5),
                 CraneMove(kind="pause", duration=1.0),
                 CraneMove(kind="hoist", target=0.8, speed=0.4, acceleration=0.4)], x0=-1.0)
    assert p(0.0)[0] == -1.0
    x, v, _, _ = p(2.0)  # end of the acceleration ramp: 0.5 * 0.5 * 2^2 = 1 m covered, at 1 m/s
    assert x == pytest.approx(0.0) and v == pytest.approx(1.0)
    assert p(p.end_time + 1.0)[0] == pytest.approx(3.0) and p(p.end_time + 1.0)[2] == pytest.approx(0.8)
    assert p(p.end_time)[1] == 0.0 and p(p.end_time)[3] == 0.0


def test_hanging_container_is_in_static_equilibrium():
    """No moves: the ropes start at their static-equilibrium length, so the load stays
    put. Tolerance 1 mm over 1 s: the stretch under 20 t is ~7 mm, so an error in the
    equilibrium length would show as a bounce of that size."""
    result = _run(duration=1.0, z=3.0)
    p = result.tables["steps"]["p_WB"][:, 0]  # (n, 3)
    assert np.max(np.linalg.norm(p - p[0], axis=1)) < 1e-3


def test_trolley_acceleration_makes_a_pendulum_sway():
    """Trolley moves 1 m quickly, then stops; the load keeps swinging with the period of a
    pendulum of the rope length, 2 pi sqrt(L / g), within 3% (rope stretch and the
    rigid-body rotation of the box make it a compound pendulum, slightly longer)."""
    height, z = 12.0, 4.0
    result = _run(duration=8.0, z=z, height=height,
                  moves="[{kind: trolley, target: 1.0, speed: 1.0, acceleration: 2.0}]")
    s = result.tables["steps"]
    after = s["time"] > 1.5
    x = s["p_WB"][after, 0, 0] - 1.0  # (n,) sway about the trolley [m]
    t = s["time"][after]
    assert np.ptp(x) > 0.05  # it sways (decimetres)
    crossings = t[1:][np.diff(np.sign(x)) != 0]
    period = 2 * np.mean(np.diff(crossings))
    rope = height - (z + H / 2)
    assert period == pytest.approx(2 * math.pi * math.sqrt(rope / G), rel=0.03)
    assert result.summary["crane_release_time_s"] is None  # never seated: never released


def test_twistlocks_release_when_seated_and_the_load_rests():
    """Lowered 0.5 m onto the quay at 0.3 m/s: the locks release after touchdown, and
    then the ground alone carries the weight (1%, the physics gate of the project)."""
    result = _run(duration=4.0, z=H / 2 + 0.3, moves="[{kind: hoist, target: 0.5, speed: 0.3, acceleration: 0.3}]")
    released = result.summary["crane_release_time_s"]
    c = result.tables["contacts"]
    first_contact = c["time"].min()
    assert released is not None and first_contact <= released < first_contact + 1.0
    last = c["step"] == c["step"].max()
    assert c["fn"][last].sum() == pytest.approx(20000 * G, rel=0.01)


def test_crane_config_errors_name_the_field():
    from testbed.errors import ScenarioError

    bad = SCENE.format(duration=0.1, z=3.0, height=12.0, moves="[{kind: teleport}]")
    with pytest.raises(ScenarioError, match=r"effects\.crane\.moves\[0\]\.kind.*teleport"):
        load_scenario(text=bad)
    with pytest.raises(ScenarioError, match=r"effects\.crane\.container"):
        load_scenario(text=bad.replace("container: load", "container: ghost"))
