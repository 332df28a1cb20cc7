"""The scale study's timed window as the continuation of the settling run (the MuJoCo-hosted
learned loop): one run from rest of settle_s + the window (+ one step), the window timed
inside it, so that the learned step's sleeping islands (SleepingConfig in
testbed/effects/learned_dynamics/step.py: asleep after t_sleep = 0.3 s below v_sleep) that fell
asleep while settling are still asleep when the window starts. A fresh run from the settled
state would restart every island's rest timer at 0: no island could sleep in a 0.1 s window.

The loop (testbed/engines/mujoco_learned/loop.py) times its whole run and keeps its step's
sleep state to itself, so the window is clocked from inside the run: the loop is handed, as the
class that applies its learned contact (loop.simulate's `contact`), a subclass of its
LearnedContact (Watched) whose apply, called once a step after mj_step1, notes
at the window's first step and at the step after its last this process's wall
(perf_counter) and CPU clocks (process_time) and the step's cost counters. Between those two
calls lie exactly the window's steps (the learned contact, the crane's ropes, mj_step2 and the
next mj_step1): the same work the loop's own timers cover, and nothing of the settling. At the
window's first step it also reads the yard there: the step's sleep counts (of the last settling
step: bodies in asleep islands, islands, asked pairs), the largest container speed, the kinetic
energy (MuJoCo's mj_energyVel) and, with the crane, the load's clearance above its stack; the
largest kinetic energy of the settling is sampled every 10 steps before the window.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from testbed.engines.mujoco_learned import loop
from testbed.errors import TestbedError

PEAK_EVERY = 10  # [steps] the settling's kinetic energy sampled this often (untimed)


@dataclasses.dataclass
class Watch:
    """What one run's Watched saw: start (the window's first step index), steps (its length),
    crane (load, top container names, or None); filled in: at_start (the yard's figures at
    the window's first step), stamps {'start', 'end': (wall [s], cpu [s], loop costs (6,),
    step costs (10,))}, peak_kinetic_J (the settling's largest sampled kinetic energy)."""

    start: int
    steps: int
    crane: tuple | None = None
    at_start: dict = dataclasses.field(default_factory=dict)
    stamps: dict = dataclasses.field(default_factory=dict)
    peak_kinetic_J: float = 0.0


def _watched(base, watch: Watch):
    """A subclass of the loop's LearnedContact `base` that fills `watch` (module doc)."""
    import mujoco

    class Watched(base):
        def __init__(self, prepared, model):
            super().__init__(prepared, model)
            self._model, self._call = model, 0
            self._names = [c.name for c in prepared.learned.containers]

        def _kinetic(self, data) -> float:
            mujoco.mj_energyVel(self._model, data)
            return float(data.energy[1])

        def _at_start(self, data) -> dict:
            counts = self.sleep_counts()  # of the latest step: the settling's last (an idle one's: all asleep)
            _, _, _, v = self.state(data)
            free = int(self.free.sum())
            out = {"asleep_fraction": counts["bodies_asleep"] / free if free else float("nan"),
                   "islands": counts["islands"], "islands_asleep": counts["islands_asleep"], "asked_pairs": counts["asked"],
                   "max_speed_mps": float(np.linalg.norm(v[self.free], axis=1).max(initial=0.0)),
                   "kinetic_J": self._kinetic(data)}
            if watch.crane is not None:
                load, top = (self._names.index(name) for name in watch.crane)
                p, R, _, _ = self.state(data)
                out["load_clearance_m"] = float((p[load, 2] - self.half[load, 2]) - (p[top, 2] + self.half[top, 2]))
            return out

        def _stamp(self) -> tuple:
            return time.perf_counter(), time.process_time(), self.costs.copy(), self.step.cost.copy()

        def apply(self, data) -> None:
            i, self._call = self._call - 1, self._call + 1  # the step's index (-1: the loop's warm-up call)
            if i == watch.start + watch.steps:
                watch.stamps["end"] = self._stamp()
            elif i == watch.start:
                watch.at_start = self._at_start(data)
                watch.stamps["start"] = self._stamp()
            elif 0 <= i < watch.start and i % PEAK_EVERY == 0:
                watch.peak_kinetic_J = max(watch.peak_kinetic_J, self._kinetic(data))
            super().apply(data)

    return Watched


def window_figures(watch: Watch, traj, n_free: int, h: float) -> dict:
    """The timed window's figures from a filled `watch` (run_cell's keys): 'wall_s', 'cpu_s'
    (this process's CPU time over the window), 'steps', 'split_us' (engine_step: MuJoCo, the
    crane's ropes and the loop; learned_system: the state, candidates and force law; predictor),
    'pairs_per_step' (asked), 'reused_pairs_per_step' (asleep islands' reused answers),
    'asleep_fraction' (free bodies in asleep islands, the window's mean), 'start_*' (the yard at
    the window's first step). Raises TestbedError when the run did not reach the window's end
    (it diverged first: traj.error says where) or the loop was not watched."""
    if set(watch.stamps) != {"start", "end"}:
        if traj.error:
            raise _Diverged(traj.error)
        raise TestbedError("the scale study's window clock saw no window: the MuJoCo-hosted loop no longer calls its "
                           "contact's apply once a step (testbed/studies/scale/window.py)")
    (w0, c0, l0, s0), (w1, c1, l1, s1) = watch.stamps["start"], watch.stamps["end"]
    steps, wall, loop_costs, step_costs = watch.steps, w1 - w0, l1 - l0, s1 - s0
    broad, predict, law = (float(x) for x in loop_costs[:3])
    split = {"engine_step": 1e6 * max(0.0, wall - broad - predict - law) / steps,
             "learned_system": 1e6 * (broad + law) / steps, "predictor": 1e6 * predict / steps}
    start = watch.at_start
    return {"wall_s": wall, "cpu_s": c1 - c0, "steps": steps, "simulated_s": steps * h, "split_us": split,
            "pairs_per_step": float(step_costs[5]) / steps, "reused_pairs_per_step": float(step_costs[6]) / steps,
            "asleep_fraction": float(step_costs[9]) / steps / n_free if n_free else float("nan"),
            "start_asleep_fraction": start["asleep_fraction"], "start_islands_asleep": start["islands_asleep"],
            "start_islands": start["islands"], "start_asked_pairs": start["asked_pairs"],
            "start_max_speed_mps": start["max_speed_mps"], "start_kinetic_J": start["kinetic_J"],
            "settle_peak_kinetic_J": max(watch.peak_kinetic_J, start["kinetic_J"]),
            **({"start_load_clearance_m": start["load_clearance_m"]} if "load_clearance_m" in start else {})}


class _Diverged(TestbedError):
    """The continued run stopped before its window ended (the loop's own words)."""


def continued_run(scenario, settle_steps: int, window_steps: int, config, crane: tuple | None):
    """One continued run of `scenario` with the MuJoCo-hosted loop (settle_steps + window_steps +
    1 steps from rest, the config's predictor, its start and end recorded) watched: (the loop's
    LearnedRun, window_figures), or (it, None) when it diverged before the window's end or the
    loop refused its step (UnstableStepError: a trajectory of that error)."""
    watch = Watch(settle_steps, window_steps, crane)
    steps = settle_steps + window_steps + 1
    try:
        result = loop.simulate(scenario, duration=steps * config.time_step, predictor=config.predictor,
                               record_every=steps, contact=_watched(loop.LearnedContact, watch))
    except loop.UnstableStepError as e:
        return loop.LearnedRun(loop.refused_run(scenario, str(e)), {}, {}, ""), None
    try:
        return result, window_figures(watch, result.trajectory, len(result.trajectory.names), config.time_step)
    except _Diverged:
        return result, None

