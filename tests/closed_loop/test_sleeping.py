"""Sleeping islands in the learned contact step (native/src/step_sleep.c, cc_step_sleep_plan;
testbed/effects/learned_dynamics/step.py, SleepingConfig).

The scene: two 3-high stacks of 20 ft containers (20, 15, 10 t bottom up) 0.3 m apart, so two
islands, and a spare container parked on the quay 30 m away, run in the MuJoCo-hosted learned
loop (MuJoCo's own contact holds the quay; the learned step every container pair), with the
default SleepingConfig switched on: v_sleep = w_sleep = 1e-3, t_sleep = 0.3 s,
eps_p = eps_R = 1e-4. A settled stack falls asleep and stays held, a disturbed stack wakes
while its neighbour sleeps on, a landing wakes the stack it lands on and is asked, and a reused
answer stays within the wake bound of a fresh one. The Drake host threads its held state
through its abstract state; its stacks sleep too.
"""

import numpy as np
import pytest

from testbed.effects.learned_dynamics.step import SleepingConfig, elastic
from testbed.gates.closed_loop import DRIFT_TOL_M_PER_MIN
from testbed.physics import GRAVITY
from testbed.scenario import load_scenario

mujoco = pytest.importorskip("mujoco")
pytest.importorskip("learned_contact._native")

SCENE = """
name: sleeping_stacks
duration: 3.0
yards:
- name: s
  type: 1CC
  rows: 2
  bays: 1
  tiers: 3
  row_gap: 0.3
  masses: [20000.0, 15000.0, 10000.0]
containers:
- name: spare
  type: 1CC
  mass: 10000.0
  X_WC: {translation: [30.0, 0.0, 1.2955], rotation: !Rpy {deg: [0.0, 0.0, 0.0]}}
effects:
  contact: {model: hydroelastic_with_fallback, approximation: auto}
  friction: {}
"""
SLEEP = SleepingConfig(enabled=True)
SETTLED = 2.0  # [s] by then both stacks have come to rest and slept (the first test shows when)


class Loop:
    """The MuJoCo-hosted learned loop of SCENE, stepped by hand (the engine's own classes)."""

    def __init__(self, sleeping: SleepingConfig = SLEEP):
        from testbed.engines.mujoco.model import build_model
        from testbed.engines.mujoco_learned.loop import LearnedContact, prepare

        prepared = prepare(load_scenario(text=SCENE), None)
        prepared.effect.config.sleeping = sleeping
        self.model, self.data, _ = build_model(prepared.physics, container_contact=False)
        self.law = LearnedContact(prepared, self.model)
        self.predictor = prepared.effect.predictor
        names = [c.name for c in prepared.learned.containers]
        self.stack = [[names.index(f"s_r{r}_b1_t{t}") for t in (1, 2, 3)] for r in (1, 2)]
        self.spare = names.index("spare")
        mujoco.mj_forward(self.model, self.data)
        self.counts, self.moving = [], []  # per step: sleep_counts(); whether a body was off rest

    def step(self, n: int = 1, kick=None) -> None:
        """n steps; kick(data) is called before each step's mj_step1 (None: nothing)."""
        law, q = self.law, self.law.step.sleeping
        for _ in range(n):
            if kick is not None:
                kick(self.data)
            mujoco.mj_step1(self.model, self.data)
            law.apply(self.data)
            _, _, w, v = law.state(self.data)
            free = law.free
            self.moving.append(bool(np.any((np.linalg.norm(v[free], axis=1) >= q.v_sleep)
                                           | (np.linalg.norm(w[free], axis=1) >= q.w_sleep))))
            self.counts.append(law.step.sleep_counts())
            mujoco.mj_step2(self.model, self.data)

    def poses(self):
        """(p (m, 3) [m], R (m, 3, 3)) of the containers now."""
        p, R, _, _ = self.law.state(self.data)
        return p.copy(), R.copy()

    def qvel(self, body: int) -> np.ndarray:
        """The 6 dofs of container `body`'s free joint in data.qvel (v_W, then w)."""
        return self.data.qvel[self.law.dof[body]:self.law.dof[body] + 6]

    def pairs_of(self, bodies):
        """Rows of the latest step's candidate pairs with both bodies in `bodies`."""
        last = self.law.last
        return np.flatnonzero(np.isin(last.ia, bodies) & np.isin(last.ib, bodies))

    def fresh(self, rows):
        """The predictor's own answer (point_A [m], normal_A) on the latest step's poses of rows."""
        last, size = self.law.last, self.law.size
        point, normal = self.predictor.predict(last.p_AB[rows], last.R_AB[rows], size_A=size[last.ia[rows]],
                                               size_B=size[last.ib[rows]])
        return np.asarray(point).reshape(-1, 3), np.asarray(normal).reshape(-1, 3)


@pytest.fixture(scope="module")
def settled():
    """SCENE run SETTLED seconds with sleeping on (a Loop)."""
    loop = Loop()
    loop.step(int(round(SETTLED / loop.law.h)))
    return loop


def test_a_settled_stack_falls_asleep_after_t_sleep_and_stays_held():
    loop = Loop()
    h = loop.law.h
    loop.step(int(round(1.5 / h)))
    asked = np.array([c["asked"] for c in loop.counts])
    moving = np.array(loop.moving)
    last_moving = int(np.flatnonzero(moving).max())  # the last step a body was off rest
    first_asleep = int(np.flatnonzero(asked == 0).min())
    # both stacks sleep exactly t_sleep after every body came to rest (rest time counted in
    # steps of h: the step after t_sleep / h steps at rest), and not before
    assert first_asleep == last_moving + int(round(SLEEP.t_sleep / h)) + 1
    assert loop.counts[first_asleep]["islands_asleep"] == 2 and loop.counts[first_asleep]["bodies_asleep"] == 6
    p0, R0 = loop.poses()
    loop.step(int(round(1.0 / h)))
    asked = np.array([c["asked"] for c in loop.counts])
    assert (asked[first_asleep:] == 0).all()  # no pair asked for 1 s after falling asleep
    assert all(c["reused"] == 4 for c in loop.counts[first_asleep:])  # 2 pairs per stack, none to the quay
    p1, _ = loop.poses()
    _, _, _, v = loop.law.state(loop.data)
    stacks = loop.stack[0] + loop.stack[1]
    # held, not frozen: over 1 s asleep no body drifted by more than the closed-loop gates'
    # resting-drift limit allows in 1 s (1 mm per simulated minute: 1.7e-5 m; measured 1e-12 m)
    assert np.abs(p1[stacks] - p0[stacks]).max() < DRIFT_TOL_M_PER_MIN / 60.0
    # at rest: every speed below 1e-7 m/s (measured 3e-11), so the top container's vertical
    # momentum changes by at most m 2e-7 m/s per step, 2e-5 of m g h: the learned contact
    # under it, made of reused answers, carries its weight within 1e-4 (measured 2e-15)
    assert np.abs(v[stacks]).max() < 1e-7
    last = loop.law.last
    for stack in loop.stack:
        (row,) = np.flatnonzero((last.ia == stack[1]) & (last.ib == stack[2]))
        weight = loop.law.mass[stack[2]] * GRAVITY
        assert last.f_W[row, 2] == pytest.approx(weight, rel=1e-4)


def test_a_disturbed_stack_wakes_and_its_neighbour_sleeps_on(settled):
    loop = settled
    before = len(loop.counts)
    assert loop.counts[-1]["asked"] == 0 and loop.counts[-1]["islands_asleep"] == 2
    top = loop.stack[0][2]
    loop.qvel(top)[:3] += (0.02, 0.0, 0.0)  # a 2 cm/s shove (20 v_sleep) to stack 1's top container
    loop.step()
    c = loop.counts[-1]
    # stack 1 (its 2 pairs) asked, stack 2 (0.3 m away: another island) asleep on its cached answers
    assert (c["asked"], c["reused"], c["islands_asleep"], c["bodies_asleep"]) == (2, 2, 1, 3)
    loop.step(int(round(0.2 / loop.law.h)))
    assert all(c["asked"] <= 2 and c["bodies_asleep"] >= 3 for c in loop.counts[before:])  # never stack 2


def test_a_landing_wakes_the_stack_it_lands_on_and_is_asked():
    loop = Loop()
    loop.step(int(round(SETTLED / loop.law.h)))
    assert loop.counts[-1]["islands_asleep"] == 2
    target, spare = loop.stack[1], loop.spare
    p, _ = loop.poses()
    qadr = loop.model.jnt_qposadr[loop.model.body_jntadr[loop.law.body[spare]]]
    # the spare container placed 2 cm above stack 2's top (within the 5 cm candidate margin),
    # aligned with it, coming down at 0.1 m/s
    loop.data.qpos[qadr:qadr + 3] = p[target[2]] + (0.0, 0.0, 2 * 1.2955 + 0.02)
    loop.data.qpos[qadr + 3:qadr + 7] = (1.0, 0.0, 0.0, 0.0)
    loop.qvel(spare)[:] = (0.0, 0.0, -0.1, 0.0, 0.0, 0.0)
    mujoco.mj_forward(loop.model, loop.data)
    loop.step()
    c = loop.counts[-1]
    # stack 2's island (its 2 pairs and the new one) asked; stack 1 still asleep
    assert (c["asked"], c["reused"], c["islands_asleep"], c["bodies_asleep"]) == (3, 2, 1, 3)
    rows = loop.pairs_of(target + [spare])
    assert len(rows) == 3
    point, normal = loop.fresh(rows)
    # asked, not reused: the predictor's own answers on this step's poses (1e-9 m: the native
    # predictor inside the step and predictor.predict agree to rounding)
    np.testing.assert_allclose(loop.law.last.point_A[rows], point, rtol=0, atol=1e-9)
    np.testing.assert_allclose(loop.law.last.normal_A[rows], normal, rtol=0, atol=1e-9)


def test_a_reused_answer_is_within_the_wake_bound_of_a_fresh_one():
    """A stack nudged along at 0.5 mm/s (below v_sleep: at rest, so asleep) wakes whenever a
    body has moved eps_p or turned eps_R: a reused answer is then never from poses further
    than that from the ones it is used on. The bound on the point: a relative shift s of the
    boxes moves the pressure centroid by at most s (2 eps_p: both bodies may move), a relative
    tilt t by t L^2 / (12 d) (the Winkler centroid over a face of length L at mean penetration
    d = F / k_n, the law's own figures at this pose), t <= 2 eps_R."""
    loop = Loop()
    loop.step(int(round(SETTLED / loop.law.h)))
    stack = loop.stack[0]
    speed = 5e-4  # [m/s] half v_sleep
    law = loop.law

    def nudge(data):
        for body in stack:
            loop.qvel(body)[:] = (speed, 0.0, 0.0, 0.0, 0.0, 0.0)

    worst, worst_normal, reused_steps = 0.0, 0.0, 0
    for _ in range(60):
        loop.step(10, kick=nudge)
        rows = loop.pairs_of(stack)
        if loop.counts[-1]["reused"] < len(rows) + 2:  # stack 1 was asked this step (stack 2's 2 are always reused)
            continue
        reused_steps += 1
        last = law.last
        point, normal = loop.fresh(rows)
        for n, r in enumerate(rows):
            hA, hB = 0.5 * law.size[last.ia[r]], 0.5 * law.size[last.ib[r]]
            F, _, k_n = elastic(last.p_AB[r], last.R_AB[r], hA, hB,
                                law.kappa_tt[law.type_index[last.ia[r]], law.type_index[last.ib[r]]], law.cfg.grid)
            L = 2 * max(hA[0], hA[1])  # the face's longer side (aligned stacks touch on their z faces)
            bound = 2 * SLEEP.eps_p + 2 * SLEEP.eps_R * L**2 / (12 * F / k_n)
            worst = max(worst, float(np.linalg.norm(last.point_A[r] - point[n])) / bound)
            worst_normal = max(worst_normal, float(np.linalg.norm(last.normal_A[r] - normal[n])))
    woken = sum(1 for c in loop.counts[-600:] if c["asked"] > 0)
    assert reused_steps >= 30  # most of the checks landed on reused answers
    assert woken >= 2  # 0.3 mm of travel: woken by the bounds more than once
    assert worst <= 1.0, f"a reused point is {worst:.2f} of its bound from the fresh answer"
    # the normal: the boxes turned at most 2 eps_R relative to each other, and a unit vector
    # turned by an angle a changes by at most a (measured 0.44 of that here)
    assert worst_normal <= 2 * SLEEP.eps_R


def test_the_drake_host_sleeps_too_and_ends_where_it_ends_awake():
    """two_stack (10 t with a 0.8 m off-centre payload on 20 t) in the Drake-hosted loop, whose
    held state goes through Drake's abstract state each step while the sleeping state stays in
    the step: with sleeping on, the stack falls asleep (pairs reused, fewer asked) and ends
    where the run without sleeping ends, within the wake bound."""
    from testbed.builder import build_scene
    from testbed.simulation import record_run

    runs = {}
    for on in (False, True):
        scenario = load_scenario("two_stack", overrides=[
            "effects.learned_dynamics={}", "effects.shadow_contact=null", "duration=1.5",
            f"effects.learned_dynamics.sleeping.enabled={'true' if on else 'false'}"])
        runs[on] = record_run(build_scene(scenario), 1.5, 100)
    off, on = runs[False], runs[True]
    assert not off.error and not on.error
    assert off.costs["reused_pairs"] == 0 and on.costs["reused_pairs"] > 0
    assert on.costs["predict_pairs"] + on.costs["reused_pairs"] == off.costs["predict_pairs"]  # same candidates
    # every container's final position within eps_p (0.1 mm) of the awake run's: the runs
    # differ only by answers reused from poses within eps_p of the current ones, on a stack
    # at rest in both (measured 2.5e-6 m)
    assert np.abs(on.p_WB[-1] - off.p_WB[-1]).max() < SLEEP.eps_p


def test_the_split_step_sleeps_as_the_fused_step():
    """A user's model called from Python (the split step: candidates, step_sleep_plan, the
    predictor on the asked rows only, the law) asks and reuses the same pairs as the fused
    step and gives the same wrenches, on the same states through falling asleep."""
    from testbed.effects.learned_dynamics.step import ContactStep, wrench_to_mujoco

    loop = Loop()
    law = loop.law
    split = ContactStep(law.size, law.free, law.mass, law.I_Bo, law.type_index, law.kappa_tt, law.cfg, law.mu, law.h,
                        law.predictor)
    split.model = None  # predictor.predict from Python on the candidates it is given
    asked = []
    for i in range(int(round(1.5 / law.h))):
        mujoco.mj_step1(loop.model, loop.data)
        p, R, w, v = law.state(loop.data)
        wrench_fused, _ = law.step.step(p, R, w, v)
        wrench_split, _ = split.step(p, R, w, v)
        assert split.sleep_counts() == law.step.sleep_counts(), i
        # 1e-9 of the largest wrench: the native predictor and predictor.predict agree to rounding
        np.testing.assert_allclose(wrench_split, wrench_fused, rtol=0, atol=1e-9 * np.abs(wrench_fused).max())
        asked.append(split.sleep_counts()["asked"])
        wrench_to_mujoco(loop.data, wrench_fused, law.body, law.free)
        mujoco.mj_step2(loop.model, loop.data)
    assert asked[0] == 4 and asked[-1] == 0  # both stacks asked at first, asleep at the end
    assert split.costs()["reused_pairs"] == law.step.costs()["reused_pairs"] > 0


@pytest.mark.parametrize("scene, duration", [("nine_mixed_stack", 2.0), ("yard_block", 1.5),
                                             ("yard_block_landing", 2.5)])
def test_sleeping_moves_no_gate_figure_of_the_reference_scenes(monkeypatch, scene, duration):
    """The scenes the native step's reference was recorded on (a mixed stack, a yard block) and
    a yard crane landing, in the MuJoCo-hosted loop with sleeping on and off: the final poses,
    the deepest penetration and the crane's release agree within 1 % of the closed-loop gates'
    limits (testbed/gates/closed_loop.py), so no verdict can change unless a figure already sits
    within 1 % of its limit."""
    from testbed.engines.mujoco_learned import loop as loop_module
    from testbed.gates.closed_loop import FINAL_ANGLE_TOL_DEG, FINAL_POSITION_TOL_M, MAX_PENETRATION_M

    prepare, sleeping = loop_module.prepare, {}

    def prepare_with(*args, **kwargs):
        prepared = prepare(*args, **kwargs)
        prepared.effect.config.sleeping = sleeping["config"]
        return prepared

    monkeypatch.setattr(loop_module, "prepare", prepare_with)
    runs = {}
    for on in (False, True):
        sleeping["config"] = SleepingConfig(enabled=on)
        runs[on] = loop_module.simulate(load_scenario(scene), duration=duration, record_every=10)
    off, on = runs[False], runs[True]
    assert not off.trajectory.error and not on.trajectory.error
    assert on.summary["cost"]["predict_pairs"] < off.summary["cost"]["predict_pairs"]  # it slept
    p_off, p_on = off.trajectory.p_WB[-1], on.trajectory.p_WB[-1]
    assert np.abs(p_on - p_off).max() < 0.01 * FINAL_POSITION_TOL_M
    q_off, q_on = off.trajectory.q_WB[-1], on.trajectory.q_WB[-1]
    angle = np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(q_off * q_on, axis=1)), 0.0, 1.0)))
    assert angle.max() < 0.01 * FINAL_ANGLE_TOL_DEG
    assert abs(on.summary["max_penetration_m"] - off.summary["max_penetration_m"]) < 0.01 * MAX_PENETRATION_M
    if off.summary["crane_release_time_s"] is not None:
        assert on.summary["crane_release_time_s"] == off.summary["crane_release_time_s"]


@pytest.mark.parametrize("field, value", [("t_sleep", "-0.1"), ("eps_p", ".nan"), ("v_sleep", "-1")])
def test_a_bad_sleeping_figure_is_refused_in_one_line(field, value):
    from testbed.errors import ScenarioError

    with pytest.raises(ScenarioError, match=f"effects.learned_dynamics.sleeping.{field}") as error:
        load_scenario("two_stack", overrides=["effects.learned_dynamics={}", "effects.shadow_contact=null",
                                              f"effects.learned_dynamics.sleeping.{field}={value}"])
    assert "\n" not in str(error.value) and "non-negative" in str(error.value)
