"""Writes tests/data/learned_step_reference.npz: inputs and outputs of the learned contact
step's former numba kernels (testbed/effects/learned_dynamics/kernels.py and
testbed/engines/mujoco_learned/glue.py at commit d9168fa), the oracle of
tests/closed_loop/test_native_step.py now that the kernels are C (native/src/step.c).

Run once, with the numba kernels importable (they are gone from the tree since; to rerun,
check out d9168fa's two files into a scratch directory and put it first on sys.path):

    .venv/bin/python tests/data/make_learned_step_reference.py

States come from the MuJoCo-hosted learned loop on shipped scenes (a yard block, a mixed
stack, a slide, a tilted drop: free and fixed bodies, several container types, held stick
anchors, body history), at chosen steps, some with velocities perturbed so that pairs slip;
each state (state{s}/...) is stepped by the kernels under several force-law settings (stick friction,
regularised Coulomb, frictionless, no torsion, coarse grid, one sweep). The predictor's
answers are recorded with each case ({i}/..., its state index in {i}/state), so the C force law is judged on the same inputs.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import testbed.effects.learned_dynamics.kernels as K
from testbed.engines.mujoco_learned import glue, loop
from testbed.scenario import load_scenario

OUT = Path(__file__).resolve().parent / "learned_step_reference.npz"
SCENES = {"yard_block": (0, 40), "nine_mixed_stack": (1, 30), "stack_slide_rest": (5, 60), "tests/scenes/tilted_drop.yaml": (80, 150)}
NEAR = 0.05
# (label, overrides of the config: dissipation, mu, slip, stiction, torsional, grid, stick_hw, stick_zeta, sweeps)
VARIANTS = [("stick", {}), ("coulomb", {"stick_hw": 0.0}), ("frictionless", {"mu": 0.0}),
            ("no_torsion", {"torsional": False, "grid": 2, "sweeps": 1}),
            ("coulomb_no_torsion", {"stick_hw": 0.0, "torsional": False, "stiction": 0.2, "slip": 1e-3})]


def capture(name: str, steps) -> list[dict]:
    """The learned contact's inputs at the given steps of the MuJoCo-hosted loop."""
    got = []
    original = loop.LearnedContact.apply
    count = {"n": -1}  # the first apply is simulate's warm-up call

    def apply(self, data):
        if count["n"] in steps:
            p, R, w, v = self.state(data)
            keys, rows, history = (np.array(a, copy=True) for a in self.anchors)
            got.append({"scene": name, "step": count["n"], "law": self, "p": p, "R": R, "w": w, "v": v,
                        "keys": keys, "rows": rows, "history": history})
        count["n"] += 1
        return original(self, data)

    loop.LearnedContact.apply = apply
    try:
        loop.simulate(load_scenario(name), duration=(max(steps) + 2) * 1e-3, record_every=1000)
    finally:
        loop.LearnedContact.apply = original
    return got


def step_case(law, p, R, w, v, keys, rows, history, params) -> dict:
    """One step of the numba kernels: every intermediate and output."""
    ca, cb = K.broad_phase(p, R, law.half, law.free, NEAR)
    keep, p_AB, R_AB = K.near_pairs(p, R, ca, cb, law.half, law.radius, law.free, NEAR)
    ia, ib = ca[keep], cb[keep]
    kappa, held = K.gather_pairs(ia, ib, law.n, keys, rows, law.type_index, law.kappa_tt)
    size_A, size_B = law.size[ia], law.size[ib]
    if len(ia):
        point_A, normal_A = law.predictor.predict(p_AB, R_AB, size_A=size_A, size_B=size_B)
    else:
        point_A, normal_A = np.zeros((0, 3)), np.zeros((0, 3))
    point_A, normal_A = np.ascontiguousarray(point_A, float), np.ascontiguousarray(normal_A, float)
    c = params
    out, fn, f_W, p_W, n_W, area, anchors_next, stuck_next, history_next = K.pair_wrenches(
        p, R, w, v, law.mass, law.I_Bo, ia, ib, kappa, point_A, normal_A, p_AB, R_AB, 0.5 * size_A, 0.5 * size_B,
        c["dissipation"], c["mu"], c["slip"], c["stiction"], law.h, c["torsional"], c["grid"],
        np.ascontiguousarray(held[:, :6]), np.ascontiguousarray(held[:, 6]), c["stick_hw"], c["stick_zeta"],
        np.ascontiguousarray(held[:, 7]), history, c["sweeps"])
    keys_next, rows_next = K.pack_anchors(ia, ib, law.n, anchors_next, stuck_next, fn)
    return {"cand_a": ca, "cand_b": cb, "ia": ia, "ib": ib, "p_AB": p_AB, "R_AB": R_AB, "point_A": point_A,
            "normal_A": normal_A, "wrench": out, "fn": fn, "f_W": f_W, "p_W": p_W, "n_W": n_W, "area": area,
            "keys_next": keys_next, "rows_next": rows_next, "history_next": history_next}


def main() -> None:
    rng = np.random.default_rng(37)
    arrays: dict[str, np.ndarray] = {}
    labels, states = [], []
    for name, steps in SCENES.items():
        for state in capture(name, steps):
            law = state["law"]
            perturbed = [("", state["w"], state["v"])]
            moving = law.free[:, None]
            perturbed.append(("+slip", state["w"] + 0.002 * rng.standard_normal(state["w"].shape) * moving,
                              state["v"] + 0.005 * rng.standard_normal(state["v"].shape) * moving))
            for tag, w, v in perturbed:
                s = len(states)
                states.append(f"{name}@{state['step']}{tag}")
                scene = {"size": law.size, "free": law.free, "mass": law.mass, "I_Bo": law.I_Bo,
                         "type_index": law.type_index, "kappa_tt": law.kappa_tt, "p": state["p"], "R": state["R"],
                         "w": w, "v": v, "keys": state["keys"], "rows": state["rows"], "history": state["history"]}
                for key, value in scene.items():
                    arrays[f"state{s}/{key}"] = np.asarray(value)
                for variant, over in (VARIANTS[:2] if law.n > 20 else VARIANTS):
                    cfg = law.cfg
                    params = {"dissipation": cfg.dissipation, "mu": law.mu, "slip": cfg.slip_speed,
                              "stiction": cfg.stiction, "torsional": cfg.torsional_friction, "grid": cfg.grid,
                              "stick_hw": cfg.stick_hw, "stick_zeta": cfg.stick_damping, "sweeps": cfg.normal_sweeps}
                    params.update(over)
                    case = step_case(law, state["p"], state["R"], w, v, state["keys"], state["rows"],
                                     state["history"], params)
                    label = f"{name}@{state['step']}{tag}/{variant}"
                    i = len(labels)
                    labels.append(label)
                    scalars = np.array([NEAR, law.h, params["dissipation"], params["mu"], params["stick_hw"],
                                        params["stick_zeta"], params["slip"], params["stiction"],
                                        float(params["torsional"]), params["grid"], params["sweeps"]])
                    arrays[f"{i}/state"] = np.asarray(s)
                    for key, value in {**case, "params": scalars}.items():
                        arrays[f"{i}/{key}"] = np.asarray(value)
                    print(label, "pairs", len(case["ia"]), "touching", int((case["fn"] > 0).sum()),
                          "held", len(case["keys_next"]), file=sys.stderr)
    # the hosts' glue: Drake's state -> bodies, MuJoCo's arrays -> bodies, wrenches -> xfrc_applied
    m, nb = 7, 10
    free = np.array([True, False, True, True, False, True, True])
    q = rng.standard_normal((m, 4)) * rng.uniform(0.5, 2.0, (m, 1))  # not unit: the kernel normalises
    x = np.concatenate([np.concatenate([q[i], rng.standard_normal(3)]) for i in range(m)] + [rng.standard_normal(6 * m)])
    q_start = np.array([7 * i if free[i] else -1 for i in range(m)])
    v_start = np.array([7 * m + 6 * i if free[i] else -1 for i in range(m)])
    fixed_p, fixed_R = rng.standard_normal((m, 3)), rng.standard_normal((m, 3, 3))
    drake = K.bodies_from_state(x, q_start, v_start, fixed_p, fixed_R, free)
    body = np.array([3, 1, 4, 9, 5, 2, 6])
    dof = np.array([6 * i if free[i] else -1 for i in range(m)])
    xpos, xmat, xipos = rng.standard_normal((nb, 3)), rng.standard_normal((nb, 9)), rng.standard_normal((nb, 3))
    qvel = rng.standard_normal(6 * m)
    mj = glue.body_state(xpos, xmat, qvel, body, dof, free)
    wrench = rng.standard_normal((m, 6))
    xfrc = rng.standard_normal((nb, 6))
    glue.write_wrenches(xfrc, wrench, body, free, xpos, xipos)
    glue_arrays = {"free": free, "x": x, "q_start": q_start, "v_start": v_start, "fixed_p": fixed_p, "fixed_R": fixed_R,
                   "drake_p": drake[0], "drake_R": drake[1], "drake_w": drake[2], "drake_v": drake[3],
                   "body": body, "dof": dof, "xpos": xpos, "xmat": xmat, "xipos": xipos, "qvel": qvel,
                   "mj_p": mj[0], "mj_R": mj[1], "mj_w": mj[2], "mj_v": mj[3], "wrench": wrench, "xfrc": xfrc}
    for key, value in glue_arrays.items():
        arrays[f"glue/{key}"] = np.asarray(value)
    arrays["labels"] = np.array(labels)
    arrays["states"] = np.array(states)
    np.savez_compressed(OUT, **arrays)
    print(f"{OUT}: {len(labels)} cases, {OUT.stat().st_size / 1e3:.0f} kB", file=sys.stderr)


if __name__ == "__main__":
    main()
