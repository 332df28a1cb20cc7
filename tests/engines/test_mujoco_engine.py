"""The MuJoCo engine (testbed/engines/): translation, matched contact, runs, compare, errors."""

import builtins
import json
import math

import numpy as np
import pytest

from testbed.bodies.containers import HYDROELASTIC_MODULUS
from testbed.errors import OptionalDependencyError
from testbed.physics import GRAVITY
from testbed.scenario import load_scenario

mujoco = pytest.importorskip("mujoco")

from testbed.engines.base import UnsupportedSceneError  # noqa: E402
from testbed.engines.mujoco.model import CONTACTS_PER_FACE, build_model, mujoco_module, scenario_to_mjcf  # noqa: E402
from testbed.engines.mujoco.run import simulate_mujoco  # noqa: E402

# A scene with every translated feature: three container types, a COM offset, a rotated
# pose, an initial spatial velocity, a welded container, friction override.
MIXED = """
name: mixed
duration: 0.1
containers:
- {name: base, type: 1AA, mass: 25000.0, fixed: true, X_WC: {translation: [0, 0, 1.2955]}}
- name: hc
  type: 1AAA
  mass: 18000.0
  com_offset: [1.5, -0.2, 0.3]
  X_WC: {translation: [0.4, 0.1, 4.2], rotation: !Rpy {deg: [3.0, -2.0, 25.0]}}
  V_WC: [0.3, -0.2, 0.5, 1.0, -0.5, 0.2]
- {name: small, type: 1CC, X_WC: {translation: [20, 0, 1.2955]}, V_WC: [0, 0, 0.1, 0.5, 0, 0]}
effects:
  contact: {}
  friction: {mu: 0.3}
"""


def _drake_scene(scenario):
    from testbed.builder import build_scene

    return build_scene(scenario)


def test_translated_model_matches_the_scene_exactly():
    scenario = load_scenario(text=MIXED)
    model, data, tr = build_model(scenario)
    drake = _drake_scene(scenario)
    assert tr.body_names == drake.body_names  # same indices in both engines' contact rows
    for spec in scenario.containers:
        b = model.body(spec.name)
        body = drake.bodies[spec.name]
        com = np.asarray(spec.com_offset, float)
        I_drake = body.default_spatial_inertia().Shift(body.default_com()).CalcRotationalInertia().CopyToFullMatrix3()
        # exact: the same numbers pass through repr() into the MJCF
        assert b.mass[0] == pytest.approx(body.default_mass(), rel=1e-12)
        np.testing.assert_allclose(b.ipos, com, atol=1e-12)
        np.testing.assert_allclose(b.ipos, body.default_com(), atol=1e-12)
        np.testing.assert_allclose(np.diag(b.inertia), I_drake, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(b.iquat, [1, 0, 0, 0], atol=1e-12)  # principal axes = C's axes
        np.testing.assert_allclose(model.geom(spec.name).size, spec.container_type().half_size, atol=1e-12)
        X = spec.pose()
        np.testing.assert_allclose(data.xpos[b.id], X.translation(), atol=1e-12)
        np.testing.assert_allclose(data.xmat[b.id].reshape(3, 3), X.rotation().matrix(), atol=1e-12)
        assert (model.body_jntnum[b.id] == 0) == spec.fixed  # welded = no joint
    assert model.opt.gravity[2] == -GRAVITY
    # every pair that can touch has an explicit pair with the scene's friction, condim 3
    assert model.npair == 2 + 2 + 1  # quay-hc, quay-small, base-hc, base-small, hc-small
    np.testing.assert_allclose(model.pair_friction[:, 0], 0.3)
    assert set(model.pair_dim) == {3}


def test_initial_velocity_is_drakes_V_WC_of_the_frame_origin():
    """Finite differences of the translated initial state (no gravity, no contact) give
    back Drake's V_WC = [w_W, v_W of C's origin]: MuJoCo's free joint holds v of the body
    origin in W and w in the body frame."""
    scenario = load_scenario(text=MIXED)
    model, data, _ = build_model(scenario)
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_GRAVITY) | int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    dt = 1e-7
    model.opt.timestep = dt
    before = {s.name: (data.xpos[model.body(s.name).id].copy(), data.xmat[model.body(s.name).id].reshape(3, 3).copy())
              for s in scenario.containers if not s.fixed}
    mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    for spec in scenario.containers:
        if spec.fixed:
            continue
        p0, R0 = before[spec.name]
        b = model.body(spec.name).id
        v = (data.xpos[b] - p0) / dt
        W = (data.xmat[b].reshape(3, 3) - R0) / dt @ R0.T  # skew(w_W) to O(dt)
        w = np.array([W[2, 1], W[0, 2], W[1, 0]])
        # 1e-5 rad/s, m/s: the O(dt |w|^2 |p|) change of a free body's velocity over dt = 1e-7 s
        np.testing.assert_allclose(w, spec.V_WC[:3], atol=1e-5)
        np.testing.assert_allclose(v, spec.V_WC[3:], atol=1e-5)


def test_matched_contact_rows_follow_the_derivation():
    """R = (1 - d0)/d0 (1/m_a + 1/m_b) and 4 contacts per face-on-face pair, as the module
    docstring's derivation assumes (measured on MuJoCo 4.0.0; a new MuJoCo may change it)."""
    scenario = load_scenario("two_stack")
    model, data, tr = build_model(scenario)
    for _ in range(5):
        mujoco.mj_step(model, data)
    assert data.ncon == 2 * CONTACTS_PER_FACE
    masses = {"bottom": 20000.0, "top": 10000.0}
    for i in range(data.ncon):
        c = data.contact[i]
        names = [tr.body_names[j] for j in (0, 1, 2) if model.geom(tr.body_names[j]).id in (c.geom1, c.geom2)]
        inv_mass = sum(1.0 / masses[n] for n in names if n in masses)
        d0 = c.solimp[0]
        assert data.efc_R[c.efc_address] == pytest.approx((1 - d0) / d0 * inv_mass, rel=1e-9)


def test_matched_static_penetration_is_drakes():
    """One 20 t 1CC on the quay: Drake's hydroelastic spring k = E A / (w/2) = 1.21e10 N/m
    (E = 1e9 Pa, the shipped SDF's) sinks it W/k = 0.0162 mm; the matched MuJoCo contact must
    rest at the same depth."""
    scenario = load_scenario("defaults")  # 20 t 1CC resting on the quay
    run = simulate_mujoco(scenario, duration=1.0)
    size = scenario.containers[0].container_type().size
    k = HYDROELASTIC_MODULUS * size[0] * size[1] / (0.5 * min(size))
    expected = 20000.0 * GRAVITY / k
    c = run.tables["contacts"]
    last = c["step"] == c["step"].max()
    # 1%: after 1 s (1000 steps of amplitude x0.78 each, as Drake's step) the contact mode is gone
    assert -c["phi"][last][0] == pytest.approx(expected, rel=0.01)
    assert run.summary["params"] == "matched"


@pytest.mark.parametrize("params", ["matched", "default"])
@pytest.mark.parametrize("scene", ["two_stack", "five_stack"])
def test_resting_stack_carries_its_weight_and_does_not_drift(scene, params):
    scenario = load_scenario(scene)
    run = simulate_mujoco(scenario, duration=2.0, params=params)
    assert not run.summary["diverged"]
    c, s = run.tables["contacts"], run.tables["steps"]
    weight = GRAVITY * sum(spec.total_mass() for spec in scenario.containers)
    ground = c["a"] == 0
    per_step = np.bincount(c["step"][ground], c["f_W"][ground][:, 2])  # (steps,) [N] the quay's reaction
    # within 1% (the bound), averaged over the last 0.5 s: the stack's slow vertical
    # mode still rings there with the matched (lightly damped, as in Drake) contact, a few
    # per cent peak for five_stack; the mean over whole periods is the weight if nothing
    # accelerates on average
    assert per_step[-500:].mean() == pytest.approx(weight, rel=0.01)
    last = (c["step"] == c["step"].max()) & ground
    np.testing.assert_allclose(c["n_W"][last], [[0, 0, 1]] * last.sum(), atol=1e-6)
    # no drift: 0.1 mm sideways in 2 s (Drake's settling moves two_stack's top box 0.018 mm,
    # MuJoCo's 0.005 mm; a creeping friction or a ringing stack would show here), and the
    # settling stays below the summed static penetrations of the stiffest reading, 6 mm for
    # five_stack (matched at 1e9 Pa: 0.34 mm, default: 1.7 mm)
    moved = s["p_WB"][-1] - s["p_WB"][0]
    assert np.abs(moved[:, :2]).max() < 1e-4
    assert np.all(moved[:, 2] < 0) and np.all(moved[:, 2] > -6e-3)
    # energy is not created: mechanical energy never above its start (1 J of float noise)
    energy = s["kinetic_energy"] + s["potential_energy"]
    assert energy.max() <= energy[0] + 1.0


def test_contact_rows_point_under_the_load():
    """two_stack's top box carries its payload 0.8 m off centre: the reduced contact point
    of the top pair sits under that COM, the quay pair's under the stack's (0.267 m)."""
    run = simulate_mujoco(load_scenario("two_stack"), duration=1.0)
    c = run.tables["contacts"]
    last = c["step"] == c["step"].max()
    rows = {(int(a), int(b)): i for a, b, i in zip(c["a"][last], c["b"][last], np.flatnonzero(last))}
    # 5 mm: the settled moment balance; MuJoCo's 4 corner contacts resolve the CoP exactly
    assert c["p_W_cop"][rows[(1, 2)]][0] == pytest.approx(0.8, abs=5e-3)
    assert c["p_W_cop"][rows[(0, 1)]][0] == pytest.approx(0.8 / 3, abs=5e-3)
    assert c["f_W"][rows[(1, 2)]][2] == pytest.approx(10000 * GRAVITY, rel=0.01)


def test_wind_matches_the_drake_effect_force():
    """windy_stack: the top container is pushed along +y by the wind effect's force."""
    from testbed.engines.mujoco.run import wind_force_W

    scenario = load_scenario("windy_stack")
    wind = scenario.effects.wind
    size = scenario.containers[0].container_type().size
    f = wind_force_W(wind, size, np.eye(3), 10.0)
    q = 0.5 * wind.air_density * wind.speed**2 * wind.drag_coefficient
    np.testing.assert_allclose(f, [0, q * size[0] * size[2], 0], atol=1e-9)
    run = simulate_mujoco(scenario, duration=0.5)
    c = run.tables["contacts"]
    last = (c["step"] == c["step"].max()) & (c["a"] == 0)
    # the quay takes the ramped wind (t = 0.5 s of a 2 s ramp: 25%) within 5% (oscillation)
    total = sum(wind_force_W(wind, size, np.eye(3), 0.499)[1] for _ in scenario.containers)
    assert -c["f_W"][last][:, 1].sum() == pytest.approx(total, rel=0.05)


def test_learned_dynamics_scene_is_reported_unsupported(capsys, tmp_path):
    from testbed.cli import main

    scenario = load_scenario("two_stack", overrides=["effects.learned_dynamics={}"])
    with pytest.raises(UnsupportedSceneError, match=r"two_stack.*effects\.learned_dynamics.*not supported"):
        scenario_to_mjcf(scenario)
    scene = tmp_path / "learned.yaml"
    from testbed.scenario import dump_scenario

    scene.write_text(dump_scenario(scenario))
    # compare runs every candidate that no predictor decides on the scene's dynamics without the
    # learned loop (as its Drake truth): MuJoCo runs beside Drake, not refused
    out = tmp_path / "x"
    assert main(["compare", str(scene), "--engine", "mujoco", "--duration", "0.02", "--no-replay", "--out", str(out)]) == 0
    figures = json.loads((out / "compare.json").read_text())
    assert figures["engine"] == "mujoco" and figures["simulated_s_learned"] == pytest.approx(0.02)


def test_crane_lands_and_releases():
    """crane_hard_landing: the hoist lowers the 20 t box at 2 m/s onto the 4-high stack; the
    twistlocks open once it is seated and it rests on tier4 (as in Drake, release ~0.8 s)."""
    scenario = load_scenario("crane_hard_landing")
    run = simulate_mujoco(scenario, duration=1.5)
    assert not run.summary["diverged"]
    assert 0.5 < run.summary["crane_release_time_s"] < 1.2  # the profile lands it at ~0.8 s
    p = run.tables["steps"]["p_WB"][-1]
    h = scenario.containers[-1].container_type().size[2]
    # seated: the load's centre one box height above tier4's, less the matched contact's
    # static compression (0.016 mm per 20 t at 1e9 Pa) and the still-ringing landing: 2 mm
    assert p[-1, 2] - p[-2, 2] == pytest.approx(h, abs=2e-3)
    np.testing.assert_allclose(p[-1, :2], p[-2, :2], atol=1e-3)  # 1 mm: it landed square


@pytest.mark.slow
def test_crane_release_time_matches_drake():
    from testbed.simulation import run_scenario

    scenario = load_scenario("crane_hard_landing")
    drake = run_scenario(scenario, duration=1.5).summary["crane_release_time_s"]
    mujoco_release = simulate_mujoco(scenario, duration=1.5).summary["crane_release_time_s"]
    # 20 ms: the landing's impact and bounce differ between the contact models; the rope
    # dynamics before it are the same model (measured: 0.788 s against Drake's 0.789 s)
    assert mujoco_release == pytest.approx(drake, abs=0.02)


def test_missing_mujoco_gives_the_install_command(monkeypatch):
    real_import = builtins.__import__

    def no_mujoco(name, *args, **kwargs):
        if name == "mujoco" or name.startswith("mujoco."):
            raise ImportError("No module named 'mujoco'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_mujoco)
    with pytest.raises(OptionalDependencyError, match=r"pip install -e '\.\[study\]'"):
        mujoco_module()
    with pytest.raises(OptionalDependencyError, match="mujoco"):
        simulate_mujoco(load_scenario("defaults"), duration=0.01)


def test_compare_engine_mujoco_writes_the_learned_compare_keys(tmp_path):
    """`testbed compare SCENE --engine mujoco` writes every figure the learned compare has
    (compare_figures, the wall times) under the same keys, MuJoCo's as the run under test
    and under its label in `candidates` (beside Drake point), no predictor, no verdict, plus
    the contact point/normal errors and Drake's modulus."""
    from testbed.cli import main
    from testbed.compare.contact_figures import SatDepth
    from testbed.compare.metrics import compare_figures
    from testbed.compare.runs import run_variant, variant

    out = tmp_path / "cmp"
    assert main(["compare", "two_stack", "--engine", "mujoco", "--duration", "0.05", "--no-replay", "--out", str(out)]) == 0
    figures = json.loads((out / "compare.json").read_text())
    scenario = load_scenario("two_stack")
    truth = run_variant(variant(scenario, "truth"), 0.02, 10)
    learned_keys = set(compare_figures(truth, truth, scenario.containers, SatDepth()))
    learned_keys |= {"scene", "duration_s", "time_step_s", "record_period_s", "wall_per_sim_s_truth",
                     "wall_per_sim_s_learned", "wall_per_sim_s_point", "speedup_vs_truth", "speedup_vs_point"}
    assert learned_keys <= set(figures)
    assert figures["engine"] == "mujoco" and figures["params"] == "matched" and "predictor" not in figures
    assert figures["verdict"] is None and figures["exit_status"] == 0
    assert list(figures["candidates"]) == ["MuJoCo (matched)", "Drake point"]
    mine = figures["candidates"]["MuJoCo (matched)"]
    assert all(figures[k] == mine[k] for k in learned_keys - {"scene", "duration_s", "time_step_s", "record_period_s"})
    assert figures["hydroelastic_modulus_Pa"] == HYDROELASTIC_MODULUS  # the shipped SDF's: two_stack sets none
    with np.load(out / "trajectories.npz") as series:
        assert {"truth_p_WB", "mujoco_p_WB", "point_p_WB"} <= set(series.files)
        assert not [k for k in series.files if k.startswith("learned")]
    for key in ("contact_point_error_median_m", "contact_point_error_max_m", "contact_normal_error_max_deg",
                "wall_per_sim_s_learned"):
        assert math.isfinite(figures[key])
    assert figures["diverged"] is False
    assert figures["position_error_max_m"] < 1e-3  # 0.05 s of a resting stack: sub-mm apart
    assert {"trajectories.npz", "divergence.png", "error_map.png", "mujoco.xml", "compare.json", "report.html",
            "report.md"} == {p.name for p in out.iterdir()}


def test_generic_box_and_ground_surface_translate():
    """A `type: box` entry keeps its size, given inertia and friction (Drake's 2ab/(a+b) with
    the ground's); a ground_surface is a plane at its height."""
    scenario = load_scenario(text="""
name: cube
duration: 0.05
ground_surface: {shape: halfspace, height: -0.0011, contact: {mu_dynamic: 0.2}}
containers:
- name: cube
  type: box
  mass: 0.37
  X_WC: {translation: [0, 0, 0.051]}
  box: {size: [0.1048, 0.1048, 0.1048], inertia: [8.1e-4, 8.2e-4, 8.3e-4], contact: {mu_dynamic: 0.3}}
effects: {contact: {}, friction: {}}
""")
    model, data, _ = build_model(scenario)
    np.testing.assert_allclose(model.geom("cube").size, [0.0524] * 3, atol=1e-12)
    np.testing.assert_allclose(model.body("cube").inertia, [8.1e-4, 8.2e-4, 8.3e-4], rtol=1e-12)
    assert model.geom("quay_ground").pos[2] == -0.0011
    assert model.pair_friction[0, 0] == pytest.approx(2 * 0.2 * 0.3 / 0.5, rel=1e-12)


def test_sampled_run_has_the_simulation_study_keys():
    from testbed.engines import engine
    from testbed.studies.sim import configure, engine_sampled_run, sampled_run, summarize_run

    def sampled_run_mujoco(scenario):
        return engine_sampled_run(engine("mujoco"), scenario)

    base = load_scenario("two_stack")
    kw = dict(model="hydroelastic_with_fallback", approximation="sap", time_step=2e-3, duration=0.06)
    drake = sampled_run(configure(base, **kw))
    mj = sampled_run_mujoco(configure(base, **kw))
    assert set(mj) == set(drake)
    np.testing.assert_allclose(mj["times"], drake["times"])
    assert mj["p_WB"].shape == drake["p_WB"].shape
    figures = summarize_run(mj, drake)
    assert figures["status"] == "ok" and figures["deviation_m"] < 1e-3  # a resting stack: sub-mm apart


def test_jacobian_is_auto_and_the_sparse_path_solves_as_the_dense_one():
    """jacobian="auto" (model.py JACOBIAN, chosen by measurement): every engine-comparison scene
    (nv < 60) keeps the dense path, so its figures do not move; a larger scene takes the sparse
    one (3.7x faster on the 96-container yard). MuJoCo 4.0.0's sparse Newton factorisation bug (MuJoCo issue 3767)
    does not show on these scenes: at the same states, the converged sparse
    solution equals the dense one to rounding (README.md, "Solver path", also on 3.17.0)."""
    from testbed.validation.cases.engine import DEFAULT_SCENES, FULL_EXTRA

    for scene, _ in DEFAULT_SCENES + FULL_EXTRA:
        model, _, _ = build_model(load_scenario(scene))
        assert model.opt.jacobian == mujoco.mjtJacobian.mjJAC_AUTO and not mujoco.mj_isSparse(model), scene
    ten = "name: ten\nduration: 0.01\ncontainers:\n" + "".join(
        f"- {{name: c{i}, type: 1CC, X_WC: {{translation: [{7 * (i % 5)}, 0, {1.2955 + 2.6 * (i // 5)}]}}}}\n"
        for i in range(10)) + "effects:\n  contact: {}\n  friction: {}\n"
    model, data, _ = build_model(load_scenario(text=ten))
    assert model.nv == 60 and mujoco.mj_isSparse(model)
    dense = mujoco.MjModel.from_xml_string(build_model(load_scenario(text=ten))[2].mjcf.replace(
        'jacobian="auto"', 'jacobian="dense"'))
    for m in (model, dense):
        m.opt.tolerance, m.opt.iterations = 1e-15, 1000  # converged: what the factorisation decides
    check = mujoco.MjData(dense)
    for step in range(60):
        mujoco.mj_step(model, data)
        if step % 20 == 19:
            check.qpos[:], check.qvel[:] = data.qpos, data.qvel
            mujoco.mj_forward(model, data)
            mujoco.mj_forward(dense, check)
            assert data.ncon > 0
            np.testing.assert_allclose(data.qacc, check.qacc, rtol=0, atol=1e-9 * max(9.81, np.abs(check.qacc).max()))
