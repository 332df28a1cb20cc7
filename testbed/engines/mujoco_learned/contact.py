"""The learned contact of the containers of one MuJoCo model (loop.py's step 2-4): the one contact step
(testbed/effects/learned_dynamics/step.py) on MuJoCo's arrays, on every container or, with the host's
trees asleep, on the awake ones and their near neighbours alone (subset.py)."""

from __future__ import annotations

import time

import numpy as np

from learned_contact.predictors.external import FORCE_MODULUS
from testbed.effects.learned_dynamics.step import NEAR, ContactStep, bodies_from_mujoco, wrench_to_mujoco
from testbed.engines.mujoco_learned.subset import Subset
from testbed.geometry.boxes import box_box_signed_distance

SMALL = 16  # containers: a smaller scene runs the whole step (the subset's bookkeeping costs more than it saves)
MU_SDF = 0.4  # [-] the models' mu_dynamic, the Drake-hosted loop's default friction (effect.MU_SDF)


class LearnedContact:
    """The learned contact of the containers of one MuJoCo model (see the module docstring):
    the one contact step (step.ContactStep) on MuJoCo's arrays.

    Arrays over the scene's containers (m, scene order): body (m,) MuJoCo body ids, free (m,),
    half (m, 3) [m] half extents, mass (m,) [kg] (inf if fixed), I_Bo (m, 3, 3) [kg m^2]
    about the body origin C in the body frame.

    subset (class attribute, the flag): with the host's trees asleep (attach: HostSleep's awake mask)
    the step runs on the awake containers and their near neighbours alone (subset.py); False: on
    every container at every step it runs, as before."""

    subset = True

    def __init__(self, prepared, model):
        s, effect = prepared.learned, prepared.effect
        specs = s.containers
        self.cfg, self.predictor = effect.config, effect.predictor
        self.h = s.plant.time_step
        self.n = len(specs)
        self.body = np.array([model.body(c.name).id for c in specs], dtype=np.int64)
        self.free = np.array([not c.fixed for c in specs])
        self.free_idx = np.flatnonzero(self.free)
        self.dof = np.array([model.jnt_dofadr[model.body_jntadr[b]] if f else -1 for b, f in zip(self.body, self.free)],
                            dtype=np.int64)  # (m,) each free joint's first dof: v_WC (3), w_C (3)
        self.size = np.array([c.container_type().size for c in specs], dtype=float).reshape(-1, 3)
        self.half = 0.5 * self.size
        self.mass = np.array([np.inf if c.fixed else c.total_mass() for c in specs])
        self.I_Bo = np.tile(np.eye(3), (self.n, 1, 1))
        for i in self.free_idx:
            c = np.asarray(specs[i].com_offset, dtype=float)
            I_com = np.diag(model.body_inertia[self.body[i]])  # principal moments, axes along C's (box inertia)
            self.I_Bo[i] = I_com + self.mass[i] * (c @ c * np.eye(3) - np.outer(c, c))
        self.type_index = np.asarray(effect.type_index, dtype=np.int64)
        self.kappa_tt = np.asarray(effect.kappa_by_type, dtype=float)
        friction = s.effects.friction
        self.mu = 0.0 if friction is None else float(
            self.cfg.mu if self.cfg.mu is not None else (friction.mu if friction.mu is not None else MU_SDF))
        # the one contact step of both hosts; it keeps the held state between steps
        self.force_scale = effect.modulus / FORCE_MODULUS
        self.step = ContactStep(self.size, self.free, self.mass, self.I_Bo, self.type_index, self.kappa_tt, self.cfg,
                                self.mu, self.h, self.predictor, NEAR, force_scale=self.force_scale)
        self.part = None  # the subset step (attach), None: the whole step always
        self.whole = 0  # steps the whole step ran
        self._last = None  # the latest step's candidate pairs once read (see last)
        self.idle = False  # set by the loop for a step with every container asleep in MuJoCo (sleep.py): apply skips
        self._idle = None  # an idle step's row of the step's counters (steps, calls, asked, reused, islands, ...)
        self.costs = np.zeros(6)  # broad_s, predict_s, law_s [s]; steps, predict_calls, predict_pairs

    def attach(self, awake) -> None:
        """Runs the step over the awake part alone from now on (with subset set); awake(data) -> (m,) bool."""
        if self.subset and self.n >= SMALL:
            self.part = Subset(self, awake)

    def reset(self) -> None:
        """Forgets the held state (no pair held, no body's last step) and the latest pairs."""
        self.step.forget()
        if self.part is not None:
            self.part.forget()
        self._last = None
        self.whole = 0

    def _apart(self) -> bool:
        """Whether the running step is the subset's."""
        return self.part is not None and self.part.idx is not None

    def candidates(self) -> tuple:
        """(ia, ib, fn) of the latest step's candidate pairs, scene indices (HostSleep's islands)."""
        return self.part.touching() if self._apart() else self.step.touching()

    def _counts(self) -> dict:
        return self.part.sleep_counts() if self._apart() else self.step.sleep_counts()

    def subset_summary(self) -> dict:
        """The subset step's figures (Subset.summary); {} without it."""
        return {} if self.part is None else self.part.summary(self.whole)

    @property
    def last(self):
        """The latest step's candidate pairs (step.StepPairs), None when there were none; read
        from the step on first use (apply does not read them: most steps need none of them)."""
        if self._last is None and self._apart():
            self._last = self.part.pairs()
            if not len(self._last):
                self._last = None
        elif self._last is None and self.step.k:
            self._last = self.step.pairs()
        return self._last

    def _idle_row(self) -> np.ndarray:
        """What an idle step adds to step.cost[3:]: one step, nothing asked, every candidate pair
        reused, every island and every free body with a candidate pair asleep (the latest step's)."""
        if self._idle is None:
            ia, ib, _ = self.candidates()
            both = np.concatenate([ia, ib])
            islands = self._counts()["islands"]
            self._idle = np.array([1, 0, 0, len(ia), islands, islands, len(np.unique(both[self.free[both]]))], float)
        return self._idle

    def sleep_counts(self) -> dict:
        """The latest step's sleeping figures (ContactStep.sleep_counts), those of _idle_row on an idle step."""
        if not self.idle:
            return self._counts()
        row = self._idle_row()
        return dict(zip(("asked", "reused", "islands", "islands_asleep", "bodies_asleep"), (int(x) for x in row[2:])))

    def state(self, data) -> tuple:
        """(p (m, 3) [m], R (m, 3, 3), w (m, 3) [rad/s], v (m, 3) [m/s]) of the body origins in
        W from MuJoCo's data after mj_step1 (xpos, xmat at the step's state; qvel: v_W, w_C)."""
        return bodies_from_mujoco(data, self.body, self.dof, self.free)

    def touching(self, container: int) -> bool:
        """Whether container (scene index) was in learned contact at the latest step."""
        if not self._apart() and not self.step.k:
            return False
        ia, ib, fn = self.candidates() if self._last is None else (self._last.ia, self._last.ib, self._last.fn)
        return bool(np.any(((ia == container) | (ib == container)) & (fn > 0)))

    def apply(self, data) -> None:
        """Writes this step's learned wrenches to data.xfrc_applied (zeroed first), at the COMs;
        with idle set (every container asleep in MuJoCo, no load) counts the step and writes nothing."""
        if self.idle:
            self.costs[3] += 1
            self.step.cost[3:] += self._idle_row()
            return
        self._idle = None
        t0 = time.perf_counter()
        part = self.part
        if part is not None:
            idx, awake = part.choose(data)
            part.switch(idx, awake)
        if self._apart():
            sub = part.sub
            p, R, w, v = bodies_from_mujoco(data, part.body, part.dof, part.free)
            t1 = time.perf_counter()
            before = sub.cost.copy()
            wrench = part.step(p, R, w, v, awake)
            wrench_to_mujoco(data, wrench, part.body, part.free)
            spent = sub.cost - before
            self.step.cost += spent
            self.step.cost[5:] += part.outside()
        else:
            self.whole += 1
            p, R, w, v = self.state(data)
            t1 = time.perf_counter()
            before = self.step.cost.copy()
            wrench, _ = self.step.step(p, R, w, v, read=False)
            wrench_to_mujoco(data, wrench, self.body, self.free)
            spent = self.step.cost - before
        self._last = None
        t2 = time.perf_counter()
        # broad_s: the state and the candidates; predict_s: the predictor; law_s: the rest (law, xfrc); the
        # pairs' records are read only when asked for (last, touching, rows: recording is timed apart)
        self.costs[:3] += (t1 - t0 + spent[0], spent[1], t2 - t1 - spent[0] - spent[1])
        self.costs[3] += 1
        self.costs[4:] += spent[4:6]  # predict_calls, predict_pairs (step.costs(): the sleeping counts after)

    def rows(self, step: int, t: float, offset: int) -> dict | None:
        """The contact rows of the latest step's touching container pairs (a, b = container
        index + offset: body_names indices), phi = minus the separating-axis depth [m]."""
        if self.last is None:
            return None
        last = self.last
        ia, ib, fn, p_W, n_W, f_W, p_AB, R_AB = last.ia, last.ib, last.fn, last.p_W, last.n_W, last.f_W, last.p_AB, last.R_AB
        touch = np.flatnonzero(fn > 0)
        if not len(touch):
            return None
        phi = np.empty(len(touch))
        sA, sB = self.half[ia[touch]], self.half[ib[touch]]
        for r, k in enumerate(touch):
            phi[r] = box_box_signed_distance(p_AB[k][None], R_AB[k][None], sA[r], sB[r])[0]
        k = len(touch)
        return {"step": np.full(k, step), "time": np.full(k, t), "a": ia[touch] + offset, "b": ib[touch] + offset,
                "p_W_cop": p_W[touch], "n_W": n_W[touch], "f_W": f_W[touch], "fn": fn[touch], "phi": phi,
                "n_points": np.ones(k, dtype=int)}
