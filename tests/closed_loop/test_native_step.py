"""The one learned contact step: the native core's step (native/src/step.c,
through testbed/effects/learned_dynamics/step.py) answers as the numba kernels it replaced, and
both hosts (Drake, MuJoCo) get the same wrenches from it.

The oracle: tests/data/learned_step_reference.npz, inputs and outputs of the former numba
kernels (kernels.py, glue.py at d9168fa; tests/data/make_learned_step_reference.py wrote it):
states of the MuJoCo-hosted loop on a yard block, a mixed stack, a slide and a tilted drop
(some with perturbed velocities), each under several force-law settings, with the predictor's
answers recorded so the force law is judged on the same inputs.
"""

from pathlib import Path

import numpy as np
import pytest

from testbed.effects.learned_dynamics import step as step_module
from testbed.effects.learned_dynamics.step import BODY, ROW, ContactStep, NativeCoreMissing

_native = pytest.importorskip("learned_contact._native")

REFERENCE = Path(__file__).resolve().parents[1] / "data" / "learned_step_reference.npz"
SHIPPED = Path(__file__).resolve().parents[2] / "learned_contact" / "shipped" / "weights.npz"
RTOL = 1e-10  # relative to each array's largest magnitude (the step is bitwise the kernels' on this machine)


@pytest.fixture(scope="module")
def reference():
    with np.load(REFERENCE) as z:
        return {k: z[k] for k in z.files}


def _cases(ref):
    for i, label in enumerate(ref["labels"]):
        s = int(ref[f"{i}/state"])
        yield str(label), {k.split("/", 1)[1]: v for k, v in ref.items() if k.startswith(f"state{s}/")}, \
            {k.split("/", 1)[1]: v for k, v in ref.items() if k.startswith(f"{i}/")}


def _core(state, params):
    p = tuple(float(x) for x in params[:9]) + (int(params[9]), int(params[10]))
    core = _native.step_new(np.ascontiguousarray(state["size"]), np.ascontiguousarray(state["free"]),
                            np.ascontiguousarray(state["mass"]), np.ascontiguousarray(state["I_Bo"]),
                            np.ascontiguousarray(state["type_index"], dtype=np.int64),
                            np.ascontiguousarray(state["kappa_tt"]), p)
    _native.step_held_set(core, np.ascontiguousarray(state["keys"], dtype=np.int64),
                          np.ascontiguousarray(state["rows"]).reshape(-1, ROW), np.ascontiguousarray(state["history"]))
    return core


def _close(name, got, want, label):
    got, want = np.asarray(got, float), np.asarray(want, float)
    assert got.shape == want.shape, f"{label}: {name} shape {got.shape}, expected {want.shape}"
    if want.size:
        scale = max(float(np.abs(want).max()), 1e-300)
        worst = float(np.abs(got - want).max()) / scale
        assert worst <= RTOL, f"{label}: {name} differs by {worst:.3g} of its largest magnitude"
    return 0.0 if not want.size else float(np.abs(got - want).max()) / max(float(np.abs(want).max()), 1e-300)


def _run_split(state, case):
    """The native step on a recorded state with the recorded predictor answers: every output."""
    core = _core(state, case["params"])
    m = len(state["free"])
    k = _native.step_candidates(core, np.ascontiguousarray(state["p"]), np.ascontiguousarray(state["R"]))
    out = {n: np.empty(shape) for n, shape in (("p_AB", (k, 3)), ("R_AB", (k, 3, 3)), ("fn", (k,)), ("f_W", (k, 3)),
                                               ("p_W", (k, 3)), ("n_W", (k, 3)), ("area", (k,)), ("wrench", (m, 6)))}
    out["ia"], out["ib"] = np.empty(k, np.int64), np.empty(k, np.int64)
    _native.step_read(core, out["ia"], out["ib"], out["p_AB"], out["R_AB"], None, None, None, None, None, None, None,
                      None, None)
    if k != len(case["ia"]):
        return out, None
    _native.step_force_law(core, np.ascontiguousarray(state["w"]), np.ascontiguousarray(state["v"]),
                           np.ascontiguousarray(case["point_A"]), np.ascontiguousarray(case["normal_A"]), out["wrench"])
    _native.step_read(core, None, None, None, None, None, None, None, None, out["fn"], out["f_W"], out["p_W"], out["n_W"],
                      out["area"])
    s = _native.step_held_count(core)
    out["keys_next"], out["rows_next"], out["history_next"] = np.empty(s, np.int64), np.empty((s, ROW)), np.empty((m, BODY))
    _native.step_held_get(core, out["keys_next"], out["rows_next"], out["history_next"])
    return out, core


def test_the_reference_covers_the_law(reference):
    """The oracle holds what the comparison must exercise: fixed and free bodies, several
    container types, pairs near but not touching, stuck anchors held from the last step and a
    body history, sticking and slipping pairs, every friction setting."""
    touching = stuck_in = slipped = fixed = not_touching = 0
    types, settings = set(), set()
    for label, state, case in _cases(reference):
        held = np.asarray(state["rows"]).reshape(-1, ROW)
        stuck_in += int((held[:, 6] > 0).sum())
        touch = case["fn"] > 0
        touching += int(touch.sum())
        not_touching += int((~touch).sum())
        fixed += int((~state["free"][case["ia"][touch]]).sum())
        types |= set(np.unique(state["type_index"]).tolist())
        settings.add(label.rsplit("/", 1)[1])
        if case["params"][4] > 0 and touch.any():  # stick: a pair at the cone re-anchors (its force is mu fn)
            ft = case["f_W"][touch] - case["fn"][touch, None] * case["n_W"][touch]
            slipped += int((np.linalg.norm(ft, axis=1) >= case["params"][3] * case["fn"][touch] * (1 - 1e-9)).sum())
    assert touching > 300 and not_touching > 20 and stuck_in > 100 and fixed > 0 and slipped > 0
    assert len(types) >= 2 and settings == {"stick", "coulomb", "frictionless", "no_torsion", "coulomb_no_torsion"}
    assert any(np.isfinite(state["history"]).all() for _, state, _ in _cases(reference))


def test_the_native_step_is_the_numba_kernels(reference):
    """Candidate pairs, their poses, the wrenches, every per-pair record and the next held
    state equal the numba kernels' on every recorded case (to 1e-10 of each array's scale)."""
    worst = {}
    for label, state, case in _cases(reference):
        out, core = _run_split(state, case)
        assert np.array_equal(out["ia"], case["ia"]) and np.array_equal(out["ib"], case["ib"]), label
        assert core is not None
        assert np.array_equal(out["keys_next"], case["keys_next"]), label
        for name in ("p_AB", "R_AB", "wrench", "fn", "f_W", "p_W", "n_W", "area", "rows_next", "history_next"):
            want = case[name].reshape(-1, ROW) if name == "rows_next" else case[name]
            worst[name] = max(worst.get(name, 0.0), _close(name, out[name], want, label))
    assert set(worst) >= {"wrench", "fn", "history_next"}


def test_the_broad_phase_lists_the_kernels_candidates(reference):
    """Before the narrow tests: the broad phase's candidate count is the kernels' (sort and sweep)."""
    for label, state, case in _cases(reference):
        core = _core(state, case["params"])
        _native.step_candidates(core, np.ascontiguousarray(state["p"]), np.ascontiguousarray(state["R"]))
        assert _native.step_counts(core) == (len(case["cand_a"]), len(case["ia"])), label


def test_the_hosts_glue_is_the_kernels(reference):
    """Drake's state -> bodies, MuJoCo's arrays -> bodies, wrenches -> MuJoCo's xfrc_applied."""
    g = {k.split("/", 1)[1]: v for k, v in reference.items() if k.startswith("glue/")}
    m, nb = len(g["free"]), len(g["xpos"])
    p, R, w, v = np.empty((m, 3)), np.empty((m, 3, 3)), np.empty((m, 3)), np.empty((m, 3))
    _native.bodies_from_drake(g["x"], g["q_start"].astype(np.int64), g["v_start"].astype(np.int64), g["fixed_p"],
                              g["fixed_R"], g["free"], p, R, w, v)
    for name, got in (("p", p), ("R", R), ("w", w), ("v", v)):
        _close(name, got, g[f"drake_{name}"], "bodies_from_drake")
    _native.bodies_from_mujoco(g["xpos"], g["xmat"], g["qvel"], g["body"].astype(np.int64), g["dof"].astype(np.int64),
                               g["free"], p, R, w, v)
    for name, got in (("p", p), ("R", R), ("w", w), ("v", v)):
        _close(name, got, g[f"mj_{name}"], "bodies_from_mujoco")
    xfrc = np.full((nb, 6), 7.0)
    _native.wrench_to_mujoco(g["wrench"], g["body"].astype(np.int64), g["free"], g["xpos"], g["xipos"], xfrc)
    _close("xfrc", xfrc, g["xfrc"], "wrench_to_mujoco")


def _shipped_model():
    """The shipped improved predictor as a learned_contact._native.Model (its weights file)."""
    z = dict(np.load(SHIPPED))
    codes = {"tanh": 0, "silu": 1, "relu": 2}

    def mlp(prefix):
        n = sum(1 for k in z if k.startswith(f"{prefix}/W"))
        return (z[f"{prefix}/x_mean"], z[f"{prefix}/x_std"], tuple(z[f"{prefix}/W{i}"] for i in range(n)),
                tuple(z[f"{prefix}/b{i}"] for i in range(n)), codes[str(z[f"{prefix}/activation"])])

    return _native.Model(1, z["supported_sizes"], mlp("mlp"), mlp("expert"), z["expert/domain"])


def test_the_fused_step_is_the_split_step(reference):
    """cc_contact_step (the predictor inside the native step) gives exactly what the split step
    gives with the same native predictor called between its halves, on every recorded state."""
    model = _shipped_model()
    compared = 0
    for label, state, case in _cases(reference):
        if not label.endswith("/stick"):
            continue
        m = len(state["free"])
        args = [np.ascontiguousarray(state[k]) for k in ("p", "R", "w", "v")]
        fused = _core(state, case["params"])
        wrench_fused, seconds = np.empty((m, 6)), np.full(3, -1.0)
        k = _native.step_contact(fused, model, *args, wrench_fused, seconds)
        assert k == len(case["ia"]) and (seconds >= 0).all(), label
        split = _core(state, case["params"])
        assert _native.step_candidates(split, args[0], args[1]) == k
        p_AB, R_AB, ia, ib = np.empty((k, 3)), np.empty((k, 3, 3)), np.empty(k, np.int64), np.empty(k, np.int64)
        _native.step_read(split, ia, ib, p_AB, R_AB, None, None, None, None, None, None, None, None, None)
        size = np.ascontiguousarray(state["size"])
        point, normal = np.empty((k, 3)), np.empty((k, 3))
        assert _native.predict(model, p_AB, R_AB, size[ia], size[ib], point, normal, None)[0] == 0
        wrench_split = np.empty((m, 6))
        _native.step_force_law(split, args[2], args[3], point, normal, wrench_split)
        assert np.array_equal(wrench_fused, wrench_split), label
        got_point = np.empty((k, 3))
        _native.step_read(fused, None, None, None, None, None, None, got_point, None, None, None, None, None, None)
        assert np.array_equal(got_point, point), label
        compared += int(np.abs(wrench_fused).max() > 0)
    assert compared >= 4


def test_both_hosts_apply_the_same_wrenches_step_after_step():
    """Drake's LearnedDynamics and MuJoCo's LearnedContact, fed the same states for several
    steps (held state threaded by each host its own way: Drake's abstract state, the MuJoCo
    host's step object), apply the same wrenches: the MuJoCo rows are Drake's moved to the COM."""
    mujoco = pytest.importorskip("mujoco")
    from testbed.builder import build_scene
    from testbed.engines.mujoco.model import build_model
    from testbed.engines.mujoco_learned.loop import LearnedContact, prepare
    from testbed.scenario import load_scenario

    prepared = prepare(load_scenario("nine_mixed_stack"), None)
    model, data, _ = build_model(prepared.physics, container_contact=False)
    law = LearnedContact(prepared, model)
    drake = build_scene(prepared.learned).effects["learned_dynamics"].system
    held = drake._no_history()
    rng = np.random.default_rng(37)
    touched = 0
    for _ in range(6):
        data.qvel[:] += 2e-3 * rng.standard_normal(model.nv)
        mujoco.mj_step1(model, data)
        law.apply(data)
        p, R, w, v = law.state(data)
        wrench = drake.wrenches(p, R, w, v, anchors=held)
        held = drake._next_anchors
        touched += int(np.abs(wrench).max() > 1e4)
        for i, body in enumerate(law.body):
            if not law.free[i]:
                continue
            f = wrench[i, 3:]
            tau_com = wrench[i, :3] - np.cross(data.xipos[body] - data.xpos[body], f)
            np.testing.assert_allclose(data.xfrc_applied[body], np.concatenate([f, tau_com]), rtol=1e-12, atol=1e-9)
        mujoco.mj_step2(model, data)
    assert touched >= 4  # (the stack starts a hair apart: its first step may not touch)
    assert len(held[0]) > 0 and np.isfinite(held[2]).all()  # anchors held, every body's history known


def test_bad_arguments_are_refused_in_one_line():
    size, free, mass = np.ones((2, 3)), np.ones(2, bool), np.ones(2)
    inertia, types, kappa = np.tile(np.eye(3), (2, 1, 1)), np.zeros(2, np.int64), np.ones((1, 1))
    params = (0.05, 1e-3, 5.0, 0.4, 0.3, 0.5, 1e-4, 0.5, 1.0, 4, 4)
    core = _native.step_new(size, free, mass, inertia, types, kappa, params)
    with pytest.raises(ValueError, match="grid >= 0, sweeps >= 1"):
        _native.step_new(size, free, mass, inertia, types, kappa, params[:9] + (-1, 4))
    with pytest.raises(ValueError, match="grid >= 0, sweeps >= 1"):
        _native.step_new(size, free, mass, inertia, types, kappa, params[:9] + (0, 0))
    _native.step_new(size, free, mass, inertia, types, kappa, params[:9] + (0, 4))  # grid 0: the exact field contact
    with pytest.raises(ValueError, match="step_new"):
        _native.step_new(size, free, mass, inertia, np.array([0, 1], np.int64), kappa, params)  # type beyond kappa
    with pytest.raises(TypeError, match="p_WB: expected float64"):
        _native.step_candidates(core, np.zeros((2, 3), np.float32), np.zeros((2, 3, 3)))
    with pytest.raises(ValueError, match="R_WB: expected 18 elements"):
        _native.step_candidates(core, np.zeros((2, 3)), np.zeros((3, 3, 3)))
    with pytest.raises(ValueError, match="run step_candidates first"):
        _native.step_force_law(core, np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((0, 3)), np.zeros((0, 3)),
                               np.zeros((2, 6)))
    with pytest.raises(ValueError, match="keys ascending"):
        _native.step_held_set(core, np.array([1, 1], np.int64), np.zeros((2, ROW)), None)


def test_without_the_native_core_the_step_says_so_in_one_line(monkeypatch):
    monkeypatch.setattr(step_module, "_native", None)
    monkeypatch.setattr(step_module, "_WHY", "No module named 'learned_contact._native'")
    with pytest.raises(NativeCoreMissing) as error:
        ContactStep(np.ones((1, 3)), [True], [1.0], np.eye(3)[None], [0], [[1.0]], None, 0.4, 1e-3, None)
    assert "\n" not in str(error.value) and "build_ext --inplace" in str(error.value)


class _PythonOnly:
    """A predictor that hides its native model: the step must call its predict (split path)."""

    def __init__(self, inner):
        self.inner, self.supported_sizes, self.calls = inner, inner.supported_sizes, 0

    def predict(self, p_AB, R_AB, *, size_A, size_B):
        self.calls += 1
        return self.inner.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)


def test_the_shipped_predictor_runs_inside_the_step_and_answers_as_its_predict(reference):
    """ContactStep runs the shipped (compiled) predictor inside the native step, and the
    wrenches and records equal those of the split path, which calls that predictor's predict
    from Python on the candidates (over three steps, held state carried by each step)."""
    from learned_contact import load_predictor
    from testbed.effects.learned_dynamics.effect import LearnedDynamicsConfig

    predictor = load_predictor("improved")
    label, state, case = next(c for c in _cases(reference) if c[0] == "yard_block@40+slip/stick")
    prm = case["params"]
    config = LearnedDynamicsConfig(dissipation=prm[2], stick_hw=prm[4], stick_damping=prm[5], slip_speed=prm[6],
                                   stiction=prm[7], torsional_friction=bool(prm[8]), grid=int(prm[9]),
                                   normal_sweeps=int(prm[10]))
    wrapped = _PythonOnly(predictor)
    steps = [ContactStep(state["size"], state["free"], state["mass"], state["I_Bo"], state["type_index"],
                         state["kappa_tt"], config, prm[3], prm[1], pred, prm[0]) for pred in (predictor, wrapped)]
    assert steps[0].model is not None and steps[1].model is None
    held = (state["keys"], state["rows"].reshape(-1, ROW), state["history"])
    p, R, w, v = (np.ascontiguousarray(state[k]) for k in ("p", "R", "w", "v"))
    for _ in range(3):
        (wa, pa), (wb, pb) = (s.step(p, R, w, v, held=held) for s in steps)
        assert np.array_equal(wa, wb) and np.abs(wa).max() > 1e4
        for name in ("ia", "ib", "fn", "p_W", "n_W", "f_W", "area", "p_AB", "R_AB", "point_A", "normal_A"):
            assert np.array_equal(getattr(pa, name), getattr(pb, name)), name
        ha, hb = steps[0].held(), steps[1].held()
        assert all(np.array_equal(a, b) for a, b in zip(ha, hb))
        held, p = ha, p + 1e-4 * v  # the next state: moved a little, from the same held state
    assert wrapped.calls == 3
    costs = steps[0].costs()
    assert costs["steps"] == 3 and costs["predict_pairs"] == 3 * len(case["ia"]) and costs["predict_s"] > 0


def test_a_pose_the_native_predictor_refuses_raises_the_predictors_own_error():
    """A candidate whose R_AB is not a rotation: the step inside the core stops, and the step
    raises what the predictor's predict raises on that pose (not a bare status)."""
    from learned_contact import load_predictor
    from learned_contact.errors import PredictorInputError
    from testbed.effects.learned_dynamics.effect import LearnedDynamicsConfig

    size = np.array([[12.192, 2.438, 2.591]] * 2)
    step = ContactStep(size, [False, True], [np.inf, 2e4], np.tile(1e4 * np.eye(3), (2, 1, 1)), [0, 0], [[1e9]],
                       LearnedDynamicsConfig(), 0.4, 1e-3, load_predictor("improved"))
    assert step.model is not None
    p, R = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 2.59]]), np.tile(np.eye(3), (2, 1, 1))
    R[1, 0, 1] = 0.2
    with pytest.raises(PredictorInputError, match=r"R_AB\[0\] is not a rotation"):
        step.step(p, R, np.zeros((2, 3)), np.zeros((2, 3)))
    R[1, 0, 1] = 0.0
    wrench, pairs = step.step(p, R, np.zeros((2, 3)), np.zeros((2, 3)))
    assert len(pairs) == 1 and pairs.fn[0] > 0 and wrench[1, 5] > 0  # the same step answers a valid pose
