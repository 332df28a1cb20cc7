"""The crane effect: a hanging container is in equilibrium, trolley motion makes it sway
with the pendulum period, and the twistlocks release once it is seated."""

import math

import numpy as np
import pytest

from testbed import load_scenario, run_scenario
from testbed.effects.crane import CraneConfig, CraneMove, Profile, RopeModel
from testbed.errors import ScenarioError
from testbed.scenario import SCENES_DIR

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
    bad = SCENE.format(duration=0.1, z=3.0, height=12.0, moves="[{kind: teleport}]")
    with pytest.raises(ScenarioError, match=r"effects\.crane\.moves\[0\]\.kind.*teleport"):
        load_scenario(text=bad)
    with pytest.raises(ScenarioError, match=r"effects\.crane\.container"):
        load_scenario(text=bad.replace("container: load", "container: ghost"))


def test_yard_crane_slot_hangs_from_sheaves_turned_with_the_load():
    """The load is yawed 90 degrees (long side across the trolley's travel): the sheaves turn
    with it, so its ropes hang vertically at t = 0 (they ran 7 m sideways before, and the
    ~3 m of excess stretch shot the 25 t load up at ~86 m/s). A box yawed 45 degrees is
    refused with one line naming the field; a 2 degree yaw (crane_misaligned) is accepted."""
    scenario = load_scenario("yard_crane_slot")
    spec = next(c for c in scenario.containers if c.name == "load")
    config = CraneConfig(container="load", trolley_height=14.0)
    assert RopeModel(config, spec).initial_tilt_rad() < 1e-9
    load_scenario("crane_misaligned")
    with pytest.raises(ScenarioError, match=r"effects\.crane\.container.*deg off vertical") as info:
        load_scenario(text=(SCENES_DIR / "yard_crane_slot.yaml").read_text().replace("deg: [0.0, 0.0, 90.0]", "deg: [0.0, 0.0, 45.0]"))
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("moves, duration", [
    (None, 0.4),  # the shipped profile: the trolley starts, the load hangs
    ("[{kind: hoist, target: 0.2, speed: 0.5, acceleration: 1.0}]", 0.7),  # lowered 0.2 m at once (0.3 m clear of the stacks)
])
def test_yard_crane_slot_load_follows_the_hoist(moves, duration):
    """Before it lands the load's vertical speed follows the hoist's (within 0.05 m/s: the
    ropes' vertical bounce, omega ~ 43 rad/s, under 1 m/s^2 of hoist acceleration is
    ~0.02 m/s) and never exceeds its 0.5-1 m/s; the stacks only settle by their static
    compression (measured 1.3 mm at the top tier), the load does not move sideways by more
    than the trolley's travel."""
    overrides = ["effects.contact.model=point", f"duration={duration}"]
    if moves is not None:
        overrides.append(f"effects.crane.moves={moves}")
    scenario = load_scenario("yard_crane_slot", overrides=overrides)
    names = [c.name for c in scenario.containers]
    spec = scenario.containers[names.index("load")]
    steps = run_scenario(scenario).tables["steps"]
    t, p = steps["time"], steps["p_WB"]  # (n,), (n, bodies, 3)
    i = names.index("load")
    vz = np.diff(p[:, i, 2]) / np.diff(t)  # (n - 1,) [m/s]
    ropes = RopeModel(scenario.effects.crane, spec)
    hoist = np.array([-ropes.profile(tk)[3] for tk in t[1:]])  # (n - 1,) [m/s] the hoist's lowering speed, down < 0
    speed = max(m.speed for m in scenario.effects.crane.moves if m.kind == "hoist") if moves else 0.0
    assert np.max(np.abs(vz - hoist)) < 0.05
    assert np.max(np.abs(vz)) <= speed + 0.05
    x_T = np.array([ropes.profile(tk)[0] for tk in t])
    assert np.max(np.abs(p[:, i, 0] - x_T)) < 0.05 and np.max(np.abs(p[:, i, 1])) < 1e-3
    others = [j for j in range(len(names)) if j != i]
    assert np.max(np.abs(p[:, others] - p[0, others])) < 3e-3
