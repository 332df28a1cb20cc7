"""The learned contact hosted in MuJoCo (testbed/engines/mujoco_learned): the Drake-hosted
loop's force law on MuJoCo's state, judged by the closed-loop gates against Drake hydroelastic."""

import numpy as np
import pytest

from testbed.engines import alternatives, engine
from testbed.engines.base import UnsupportedSceneError
from testbed.scenario import load_scenario

mujoco = pytest.importorskip("mujoco")

from testbed.engines.mujoco.model import build_model  # noqa: E402
from testbed.engines.mujoco_learned.loop import LearnedContact, prepare, simulate  # noqa: E402


def test_registered_beside_mujoco_and_in_compare_all():
    e = engine("mujoco_learned")
    assert e.learned and not e.gated and not e.reference and e.param_sets == ()  # its predictor is no contact-parameter set
    assert "mujoco_learned" in [a.name for a in alternatives()]  # so `compare --engine all` and validate's engine case run it


def test_its_wrenches_are_the_drake_hosted_loops():
    """At the same (perturbed, in-contact) state the MuJoCo host applies exactly the wrenches the
    Drake-hosted LearnedDynamics system computes, moved from the body origin to the COM."""
    from testbed.builder import build_scene

    prepared = prepare(load_scenario("two_stack"), None)
    model, data, _ = build_model(prepared.physics, container_contact=False)
    law = LearnedContact(prepared, model)
    rng = np.random.default_rng(3)
    data.qpos[9] -= 1e-4  # the upper box 0.1 mm down: in contact
    data.qvel[:] = 1e-3 * rng.standard_normal(model.nv)
    mujoco.mj_step1(model, data)
    law.apply(data)
    p, R, w, v = law.state(data)
    drake = build_scene(prepared.learned).effects["learned_dynamics"].system.wrenches(p, R, w, v)  # (m, 6) [tau_Bo, f]
    assert np.abs(drake).max() > 1e4  # touching
    for i, body in enumerate(law.body):
        f = drake[i, 3:]
        tau_com = drake[i, :3] - np.cross(data.xipos[body] - data.xpos[body], f)
        np.testing.assert_allclose(data.xfrc_applied[body], np.concatenate([f, tau_com]), rtol=1e-9, atol=1e-6)


def test_two_stack_within_the_closed_loop_gates_against_drake():
    """compare_engine: judged at the learned law's modulus against Drake hydroelastic; the
    resting stack stays within the closed-loop gates (2 cm, 0.5 deg, 2 cm penetration)."""
    from testbed.compare import compare_engine

    f = compare_engine("two_stack", "mujoco_learned", duration=0.4, with_point=False)
    assert f["hydroelastic_modulus_Pa"] == 1e8 and not f["diverged"] and f["predictor"] == "improved"
    assert f["final_position_error_max_m"] < 1e-3 and f["final_angle_error_max_deg"] < 0.05
    assert f["max_penetration_m"] < 0.002 and f["pair_steps_learned"] == 400
    assert f["contact_rows_compared"] > 0


def test_yard_costs_split_and_candidate_pairs_are_the_stacked_ones():
    """yard_small (2 x 2 x 2): one predictor call a step for the 2 stacked pairs... of each
    column (4), not the 28 pairs; the cost split adds up; container rows are logged."""
    run = simulate(load_scenario("yard_small"), duration=0.05, record_every=10)
    s = run.summary
    assert not s["diverged"] and s["steps"] == 50
    assert s["cost"]["predict_pairs"] == 4 * 50 and s["cost"]["predict_calls"] == 50
    split = s["cost"]["ms_per_step"]
    assert split["total"] == pytest.approx(sum(v for k, v in split.items() if k != "total"))
    rows = run.contacts
    assert np.any(rows["a"] > 0) and np.any(rows["a"] == 0)  # container pairs (learned) and the quay (MuJoCo)
    assert np.all(rows["phi"][rows["a"] > 0] < 0)  # resting: a few um deep


def test_python_predictor_and_crane():
    """Any predictor (here module:attribute, the geometric prior) and the crane (ropes, twistlocks
    released on the learned contact) run."""
    run = simulate(load_scenario("two_stack"), duration=0.05, predictor="closed_loop_alternatives:prior")
    assert not run.summary["diverged"] and run.summary["predictor"] == "closed_loop_alternatives:prior"
    crane = simulate(load_scenario("crane_misaligned"), duration=0.05, record_every=10)
    assert not crane.summary["diverged"]


def test_refusals_are_one_line():
    box = load_scenario(text="""
name: cube
duration: 0.05
containers:
- {name: a, type: box, mass: 1.0, X_WC: {translation: [0, 0, 0.05]}, box: {size: [0.1, 0.1, 0.1]}}
- {name: b, type: box, mass: 1.0, X_WC: {translation: [0, 0, 0.15]}, box: {size: [0.1, 0.1, 0.1]}}
effects: {contact: {}}
""")
    with pytest.raises(UnsupportedSceneError) as e:
        engine("mujoco_learned").check(box)
    assert "\n" not in str(e.value) and "containers[0].type" in str(e.value)
    with pytest.raises(UnsupportedSceneError) as e:
        simulate(load_scenario("two_stack"), duration=0.01, predictor="no_such_file.onnx")
    assert "\n" not in str(e.value) and "predictor" in str(e.value)


def test_a_step_the_explicit_law_cannot_take():
    """check refuses it (the learned loop's stability check, one line); a run at it (a validate
    time-step sweep) ends at once with that error instead of raising."""
    from testbed import variants

    coarse = variants.derive(load_scenario("two_stack"), variants.timing(time_step=1e-2))
    with pytest.raises(UnsupportedSceneError, match="unstable at plant.time_step = 0.01 s"):
        engine("mujoco_learned").check(coarse)
    run = engine("mujoco_learned").run(coarse, duration=0.1, contacts=True)
    assert "unstable" in run.trajectory.error and run.trajectory.simulated_s == 0 and len(run.contacts["step"]) == 0


def test_one_wind_law_for_every_engine():
    """The one wind law (testbed/effects/wind.py's WindLaw, which Drake's WindLoad and both
    MuJoCo engines call): per container pressure 0.5 rho v^2 Cd on the projected area, along
    the wind, ramped, applied at C (MuJoCo's row: the torque about the COM), restated here."""
    import math

    from testbed.effects.wind import WindLaw
    from testbed.geometry.rotations import rotation_from_quaternion

    s = load_scenario("yard_wind")
    w = s.effects.wind
    free = [c for c in s.containers if not c.fixed][:4]
    sizes = np.array([c.container_type().size for c in free], dtype=float)
    com = np.array([[0.3, -0.1, 0.2]] * len(free))
    q = np.random.default_rng(1).standard_normal((len(free), 4))
    R = rotation_from_quaternion(q / np.linalg.norm(q, axis=1, keepdims=True))
    t = 0.7 * w.ramp_time
    got = WindLaw(w, sizes).mujoco_rows(R, com, t)
    d = np.array([math.cos(math.radians(w.direction_deg)), math.sin(math.radians(w.direction_deg)), 0.0])
    for k in range(len(free)):
        lx, ly, lz = sizes[k]
        area = sum(a * abs(R[k][:, i] @ d) for i, a in enumerate((ly * lz, lx * lz, lx * ly)))
        f = 0.7 * 0.5 * w.air_density * w.speed**2 * w.drag_coefficient * area * d
        assert np.linalg.norm(f) > 0
        np.testing.assert_allclose(got[k], np.concatenate([f, np.cross(-(R[k] @ com[k]), f)]), rtol=1e-12, atol=1e-9)

def test_a_blow_up_ends_the_run_with_an_error():
    """A state past MAX_SPEED (here a box launched at 150 m/s) ends the run there, saying so,
    instead of running on with containers kilometres away. (The yard landing, a 25 t load at
    1 m/s onto an empty 40 ft box, blew up the explicit law this way; the linearly implicit
    normal force lands it: tests/closed_loop/test_yard_loop.py.)"""
    landing = load_scenario(text="""
name: launched
duration: 0.1
containers:
- {name: b1, type: 1AA, mass: 24000.0, X_WC: {translation: [0, 0, 1.2955]}}
- {name: load, type: 1AA, mass: 25000.0, X_WC: {translation: [0, 0, 50.0]}, V_WC: [0, 0, 0, 0, 0, -99.995]}
effects: {contact: {}, friction: {}}
""")
    run = engine("mujoco_learned").run(landing, duration=0.1)
    assert "blew up at t = " in run.trajectory.error and run.trajectory.simulated_s < 0.1
