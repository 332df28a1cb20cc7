"""Resting islands asleep in MuJoCo (testbed/engines/mujoco_learned/sleep.py): a settled yard's trees
sleep in MuJoCo itself (mjENBL_SLEEP) with exact +0.0 applied rows, a landing load wakes the stack it
lands on, and the final poses with sleeping agree with the always-awake run's within 1 mm (max) and
0.05 mm (mean); where nothing may sleep (a rolling deck loads every box) the two runs are the same bits.

Measured 2026-12-07 (2 shared cores): a 25 t load hoisted onto a 24-box yard that fell asleep first
(test_a_landing_wakes_its_stack_...): 1.4e-4 mm max, 6.0e-5 mm mean apart from the awake run. While some
trees sleep the learned step runs on the awake containers and their near neighbours alone (subset.py):
that landing steps 10 of its 25 bodies a step on average, and ends where the whole step's run does.
"""

import dataclasses

import numpy as np
import pytest

from testbed import variants
from testbed.effects.learned_dynamics.step import SleepingConfig
from testbed.scenario import load_scenario

mujoco = pytest.importorskip("mujoco")

from testbed.engines.mujoco_learned.loop import LearnedContact, simulate  # noqa: E402
from testbed.engines.mujoco_learned.subset import Subset  # noqa: E402
from testbed.studies.scale.settings import ScaleConfig  # noqa: E402
from testbed.studies.scale.yard import top_name, yard_scenario  # noqa: E402


def _watched(record: dict):
    """A LearnedContact that keeps MuJoCo's model and data, and each step's asleep trees (bool per body)."""

    class Watched(LearnedContact):
        def __init__(self, prepared, model):
            super().__init__(prepared, model)
            record["model"], record["asleep"], record["law"] = model, [], self
            self._names = [c.name for c in prepared.learned.containers]
            record["names"] = self._names

        def apply(self, data):
            record["data"] = data
            trees = record["model"].body_treeid[self.body]
            record["asleep"].append(np.where(trees >= 0, data.tree_asleep[np.maximum(trees, 0)] >= 0, False))
            super().apply(data)

    return Watched


def test_a_settled_yard_sleeps_in_mujoco_with_zero_byte_rows():
    record = {}
    run = simulate(load_scenario("yard_small"), duration=1.0, record_every=1000, contact=_watched(record))
    model, data = record["model"], record["data"]
    assert model.opt.enableflags & int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    free = [model.body(c.name).id for c in load_scenario("yard_small").containers if not c.fixed]
    trees = model.body_treeid[free]
    asleep = data.tree_asleep[trees] >= 0
    assert asleep.sum() > 0 and data.ntree_awake < model.ntree  # MuJoCo's own count
    for body, tree in zip(free, trees):
        if data.tree_asleep[tree] >= 0:
            assert data.xfrc_applied[body].tobytes() == bytes(48)  # +0.0, not -0.0, no residue
            dofs = slice(model.tree_dofadr[tree], model.tree_dofadr[tree] + model.tree_dofnum[tree])
            assert data.qfrc_applied[dofs].tobytes() == bytes(8 * model.tree_dofnum[tree])
    sleep = run.summary["mujoco_sleep"]
    assert sleep["trees_asleep_at_end"] == int(asleep.sum()) and sleep["learned_steps_skipped"] > 0
    assert not run.trajectory.error


def _landing(sleep: bool, record: dict, subset: bool | None = None):
    """A 24-box yard (4 tiers) that falls asleep while a 25 t load hangs 0.3 m above its middle stack for
    0.6 s; then the hoist lands it at 0.5 m/s and lets go."""
    config = dataclasses.replace(ScaleConfig(), crane_gap=0.3, crane_speed=0.5)
    scenario = yard_scenario(24, config, "crane", duration=2.0, hold=0.6)
    run = simulate(scenario, duration=2.0, sleep=sleep, record_every=2000, contact=_watched(record), subset=subset)
    return run, top_name(24, config)


def test_a_landing_wakes_its_stack_and_ends_where_the_awake_run_does():
    awake_record, sleep_record = {}, {}
    awake, top = _landing(False, awake_record)
    asleep, _ = _landing(True, sleep_record)
    assert awake.summary["mujoco_sleep"] is None and not np.any(awake_record["asleep"])
    history = np.array(sleep_record["asleep"])  # (steps + warm-up, scene bodies)
    i_top = sleep_record["names"].index(top)
    slept = np.flatnonzero(history[:, i_top])
    assert len(slept) and slept[0] < 1000  # the stack fell asleep under the hanging load
    assert not history[-1, i_top]  # and the landing woke it
    assert history[-1].sum() > 0  # the rest of the yard sleeps on
    a, b = awake.trajectory, asleep.trajectory
    assert not a.error and not b.error and len(a.p_WB) == len(b.p_WB) == 2
    names = list(a.names)
    assert np.linalg.norm(a.p_WB[-1, names.index(top)] - a.p_WB[0, names.index(top)]) > 5e-4  # the landing pressed it
    d = np.linalg.norm(b.p_WB[-1] - a.p_WB[-1], axis=1)
    assert d.max() <= 1e-3 and d.mean() <= 5e-5, (d.max(), d.mean())
    assert asleep.summary["crane_release_time_s"] == awake.summary["crane_release_time_s"]
    # the learned step ran on the awake part alone: fewer bodies than the yard holds, most steps
    sleep = asleep.summary["mujoco_sleep"]
    assert sleep["subset_steps"] > 1000 and sleep["learned_bodies_per_step"] < 0.5 * len(names), sleep
    whole, _ = _landing(True, {}, subset=False)  # the old path: the whole step whenever it runs
    assert "subset_steps" not in whole.summary["mujoco_sleep"]
    d = np.linalg.norm(b.p_WB[-1] - whole.trajectory.p_WB[-1], axis=1)
    assert d.max() <= 1e-3 and d.mean() <= 5e-5, (d.max(), d.mean())


def test_the_held_state_goes_to_a_subset_and_back_bit_for_bit():
    """Subset's remap of the held state (anchors, stuck flags, last normal forces, body histories) is lossless:
    the whole step's held state moved onto a subset step and back is the same bits."""
    record = {}
    simulate(yard_scenario(24, ScaleConfig(), duration=0.05), sleep=False, record_every=50, contact=_watched(record))
    law = record["law"]
    keys, rows, history = law.step.held()
    assert len(keys) > 10
    part = Subset(law, None)
    idx = np.flatnonzero(np.arange(law.n) % 3 != 0)  # two in three containers: pairs inside, across and outside
    w = np.zeros(law.n, bool)
    part.switch(idx, w)
    assert part.sub.n == len(idx) and 0 < len(part.sub.held()[0]) < len(keys)
    part.switch(None, w)
    after = law.step.held()
    for x, y in zip((keys, rows, history), after):
        assert x.tobytes() == y.tobytes()


def test_where_every_box_is_loaded_nothing_sleeps_and_the_runs_are_the_same():
    """ship_bay_roll: the deck's inertial loads act on every box, so no tree may sleep; MuJoCo's sleeping
    switched on changes no bit of the run."""
    on = simulate(load_scenario("ship_bay_roll"), duration=0.15, sleep=True, record_every=150)
    off = simulate(load_scenario("ship_bay_roll"), duration=0.15, sleep=False, record_every=150)
    assert on.summary["mujoco_sleep"]["tree_steps_asleep"] == 0
    assert np.array_equal(on.trajectory.p_WB, off.trajectory.p_WB) and np.array_equal(on.trajectory.q_WB, off.trajectory.q_WB)


def test_the_flag_turns_it_off():
    """SleepingConfig.mujoco_trees False: MuJoCo's sleeping stays off (the learned step's own sleeping stays on)."""
    learned = variants.derive(load_scenario("yard_small"), variants.learned_loop(None))
    learned.effects.learned_dynamics.sleeping = SleepingConfig(mujoco_trees=False)
    record = {}
    run = simulate(learned, duration=0.05, record_every=50, contact=_watched(record))
    assert run.summary["mujoco_sleep"] is None
    assert not record["model"].opt.enableflags & int(mujoco.mjtEnableBit.mjENBL_SLEEP)


def test_a_sleeping_container_keeps_its_quay_rows_in_the_contact_log():
    """MuJoCo solves no contact of a sleeping tree: its quay rows are held from its last recorded step, so the
    log has the rows of the always-awake run, pair for pair, step for step, at the same forces within 1e-4."""
    runs = [simulate(load_scenario("yard_small"), duration=1.0, sleep=sleep, record_every=50) for sleep in (False, True)]
    (awake, asleep) = (r.contacts for r in runs)
    assert runs[1].summary["mujoco_sleep"]["trees_asleep_at_end"] > 0
    key = [np.lexsort((c["b"], c["a"], c["step"])) for c in (awake, asleep)]
    for name in ("step", "a", "b"):
        assert np.array_equal(awake[name][key[0]], asleep[name][key[1]]), name
    np.testing.assert_allclose(asleep["fn"][key[1]], awake["fn"][key[0]], rtol=1e-4)  # the awake quay force wanders by 1e-5
