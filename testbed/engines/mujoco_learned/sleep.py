"""Resting islands asleep in MuJoCo itself (mjENBL_SLEEP), for the MuJoCo-hosted learned loop.

MuJoCo (4.0) puts a tree to sleep when its xfrc_applied and qfrc_applied rows are zero bytes (even
-0.0 keeps it awake) and its speed stays under opt.sleep_tolerance for mjMINAWAKE steps; a
sleeping tree is not integrated (its qpos stays, its qvel is zeroed) and costs MuJoCo next to
nothing. The host writes the learned wrenches into xfrc_applied every step, so left alone nothing
would sleep; and a container above the bottom tier is held by the learned force alone (its
container pairs are out of MuJoCo's contact), so a zero force for MuJoCo's ten-step wait would
drop it (10 steps of g: 0.5 mm, 0.1 m/s). HostSleep decides instead, on the learned contact's
islands:

- a free container is at rest below the learned step's own thresholds (SleepingConfig: |v| <
  v_sleep, |w| < w_sleep); an island (the connected candidate pairs of the learned step over the
  free containers; a fixed one joins none) whose containers have all been at rest for t_sleep,
  with no external load (wind, deck, a crane's ropes: a non-zero row beside the learned one) on
  any, is put to sleep at once: its trees' policy set to mjSLEEP_ALLOWED, their countdown skipped
  (tree_asleep = -1: MuJoCo's own mj_sleep then sleeps them in this step's mj_step2), their rows
  written +0.0;
- how an asleep island is held without an applied force: it is not integrated at all, so it
  needs none: its poses stay where they fell asleep (within the rest speed x one step of where
  the awake run would creep), MuJoCo's quay contact is not solved for it, and the learned step
  still sees it at those poses;
- every tree MuJoCo holds asleep gets exact +0.0 rows (np.zeros: never -0.0, no residue);
- an island wakes when a load acts on any of its containers, when a candidate pair links it to
  an awake container (a landing load, a sliding neighbour), or when MuJoCo wakes one of its
  trees: its trees' policy goes back to mjSLEEP_NEVER, which MuJoCo's mj_wake reads at the next
  mj_step1 (one step late: the island stays still for that step; the awake body meeting it is
  stepped against it as a resting body); their rest time restarts;
- the contact log: MuJoCo solves no contact of a sleeping tree, so its quay rows are held from the
  latest recorded step (add): the log keeps the always-awake run's rows, pair for pair;
- every other tree keeps mjSLEEP_NEVER, so MuJoCo never sleeps a tree on its own count (a box
  at the top of its free fall has a zero row and no speed for a moment).

When every free container is asleep and no load acts, the learned step is not called at all
(skip_learned): its answers cannot change while no body moves; this is what makes a settled
yard cheap (the native step on 1,000 resting boxes still costs several ms with its own
sleeping, native/examples/yard_sleep.c).
"""

from __future__ import annotations

import numpy as np

TOLERANCE = 1.0  # [m/s, rad/s x dof_length] MuJoCo's own rest test: wide open, the host's test decides



def component_labels(a, b, n: int) -> np.ndarray:
    """(n,) connected-component labels (each the smallest member's index) of n bodies joined by the pairs
    (a, b) ((k,) indices each): min-label propagation along the pairs, then pointer jumping (a stack's
    height in sweeps)."""
    labels = np.arange(n)
    while True:
        low = np.minimum(labels[a], labels[b])
        new = labels.copy()
        np.minimum.at(new, a, low)
        np.minimum.at(new, b, low)
        new = new[new]
        if np.array_equal(new, labels):
            return labels
        labels = new

class HostSleep:
    """Sleeping of the free containers' trees of one MuJoCo model (module docstring).

    body_ids (f,) MuJoCo body ids of the free containers (the run's order); scene_index (f,)
    each one's index in the learned step (scene order); sleeping: the SleepingConfig whose
    v_sleep, w_sleep, t_sleep it uses; h [s] the step; reducer: the run's MuJoCo contact rows
    (run._ContactReducer) and row_index (f,) each free container's index in its body names, for add."""

    def __init__(self, mj, model, body_ids, scene_index, n_scene: int, sleeping, h: float, reducer=None, row_index=()):
        self.mj = mj
        model.opt.enableflags |= int(mj.mjtEnableBit.mjENBL_SLEEP)
        model.opt.sleep_tolerance = TOLERANCE
        self.never, self.allowed = int(mj.mjtSleepPolicy.mjSLEEP_NEVER), int(mj.mjtSleepPolicy.mjSLEEP_ALLOWED)
        model.tree_sleep_policy[:] = self.never
        self.model = model
        self.body = np.asarray(body_ids, dtype=int)
        self.tree = model.body_treeid[self.body].astype(int)
        dof = model.jnt_dofadr[model.body_jntadr[self.body]]
        self.vidx = dof[:, None] + np.arange(6)
        self.free_of = np.full(n_scene, -1, dtype=int)  # scene index -> free index (-1: fixed)
        self.scene = np.asarray(scene_index, dtype=int)  # free index -> scene index
        self.free_of[self.scene] = np.arange(len(self.body))
        self.v_sleep, self.w_sleep, self.t_sleep = float(sleeping.v_sleep), float(sleeping.w_sleep), float(sleeping.t_sleep)
        self.h = float(h)
        self.rest = np.zeros(len(self.body))  # [s] each free container's time at rest
        self.labels = np.arange(len(self.body))  # the latest islands (free index -> island)
        self._pairs = None  # the free pairs the labels were made from
        self._source = None  # the candidate arrays given last (the same objects: the same labels)
        self._latest = (np.zeros(0, int), np.zeros(0, int))  # the latest candidate pairs (ia, ib), scene indices
        self.counts = np.zeros(3)  # steps, tree-steps asleep, steps with the learned step skipped
        self.every_tree = len(set(self.tree.tolist())) == model.ntree  # the containers are all of MuJoCo's trees
        self.no_rows = np.zeros((len(self.body), 6))  # the learned rows of a skipped step (read only)
        self.reducer, self.row_index = reducer, np.asarray(row_index, dtype=int)
        self.held: dict = {}  # body-pair key -> (a recorded chunk of rows, its row): each pair's latest row

    def asleep(self, data) -> np.ndarray:
        """(f,) bool: the free containers' trees MuJoCo holds asleep now."""
        return data.tree_asleep[self.tree] >= 0

    def awake_scene(self, data) -> np.ndarray:
        """(n_scene,) bool: the free containers (scene order) whose trees MuJoCo holds awake now."""
        awake = np.zeros(len(self.free_of), bool)
        awake[self.scene] = ~self.asleep(data)
        return awake

    def skip_learned(self, data) -> bool:
        """Whether this step can go without the learned step: every free container asleep."""
        skip = data.ntree_awake == 0 if self.every_tree else bool(self.asleep(data).all())
        self.counts[2] += skip
        return skip

    def islands(self, ia, ib) -> np.ndarray:
        """(f,) island labels (each island's smallest free index) over the candidate pairs (ia, ib
        scene indices) between free containers; the latest labels again for the same pairs."""
        if self._source is not None and ia is self._source[0] and ib is self._source[1]:
            return self.labels  # the very arrays of the latest labels (the subset step's held pairs)
        self._source = (ia, ib)
        a, b = self.free_of[np.asarray(ia, dtype=int)], self.free_of[np.asarray(ib, dtype=int)]
        keep = (a >= 0) & (b >= 0)
        a, b = a[keep], b[keep]
        if self._pairs is not None and len(a) == len(self._pairs[0]) and np.array_equal(a, self._pairs[0]) \
                and np.array_equal(b, self._pairs[1]):
            return self.labels
        self._pairs = (a, b)
        return component_labels(a, b, len(self.body))

    def settle(self, data, learned, pairs) -> None:
        """After the learned wrenches (learned (f, 6), the rows written by the learned step alone)
        and the loads are in data.xfrc_applied: wakes, sleeps and zeroes (module docstring).
        pairs: a function giving this step's candidates (ia, ib, ...), read only when a decision
        needs the islands; None when the learned step was skipped (no body moved: the last ones hold)."""
        if pairs is None and self.every_tree and not data.xfrc_applied.view(np.uint64).any():
            self.counts[:2] += (1, len(self.body))  # all asleep, no load: nothing changes
            return
        asleep = self.asleep(data)
        qvel = data.qvel[self.vidx]
        q2 = qvel * qvel
        still = (q2[:, :3].sum(axis=1) < self.v_sleep ** 2) & (q2[:, 3:].sum(axis=1) < self.w_sleep ** 2)
        self.rest = np.where(~asleep & still, self.rest + self.h, np.where(asleep, self.rest, 0.0))
        self.counts[:2] += (1, int(asleep.sum()))
        if not asleep.any() and not (self.rest >= self.t_sleep).any():
            return  # nothing to wake, nothing rested long enough to sleep
        if pairs is not None:
            self._latest = pairs()[:2]
        rows = data.xfrc_applied[self.body]
        loaded = np.any(rows != learned, axis=1)  # a load beside the learned row (wind, deck, ropes)
        labels = self.labels = self.islands(*self._latest)
        n = int(labels.max()) + 1 if len(labels) else 0
        any_asleep = np.bincount(labels, asleep, n) > 0
        any_awake = np.bincount(labels, ~asleep, n) > 0
        any_loaded = np.bincount(labels, loaded, n) > 0
        rested = np.bincount(labels, self.rest < self.t_sleep, n) == 0
        wake = any_asleep & (any_awake | any_loaded)  # an awake neighbour or a load: the whole island wakes
        fall = ~any_asleep & ~any_loaded & rested
        waking, falling = wake[labels], fall[labels]
        policy = self.model.tree_sleep_policy
        if waking.any():
            policy[self.tree[waking]] = self.never  # MuJoCo's mj_wake wakes them at the next mj_step1
            self.rest[waking] = 0.0
        if falling.any():
            policy[self.tree[falling]] = self.allowed
            data.tree_asleep[self.tree[falling]] = -1  # ready: this step's mj_sleep sleeps them
        zero = asleep | falling
        if zero.any():
            data.xfrc_applied[self.body[zero]] = 0.0  # +0.0 bytes: a sleeping tree's row

    def add(self, step: int, t: float, data) -> None:
        """The reducer's contact rows of this step, and for each pair with a sleeping container that
        MuJoCo no longer solves (a quay contact) its latest recorded row again, at this step."""
        reducer, before = self.reducer, len(self.reducer.rows)
        reducer.add(step, t, data)
        nb, present = reducer.nb, set()
        if len(reducer.rows) > before:
            chunk = reducer.rows[-1]
            keys = (chunk["a"] * nb + chunk["b"]).tolist()
            present = set(keys)
            self.held.update((key, (chunk, j)) for j, key in enumerate(keys))
        asleep = self.asleep(data)
        if not asleep.any():
            return
        sleeping = set(self.row_index[asleep].tolist())
        missing = [(key, ref) for key, ref in self.held.items()
                   if key not in present and (key // nb in sleeping or key % nb in sleeping)]
        if missing:
            rows = {name: np.array([ref[0][name][ref[1]] for _, ref in missing]) for name in missing[0][1][0]}
            rows["step"], rows["time"] = np.full(len(missing), step), np.full(len(missing), t)
            reducer.rows.append(rows)

    def summary(self) -> dict:
        """steps, tree_steps_asleep (summed), learned_steps_skipped."""
        return {"steps": int(self.counts[0]), "tree_steps_asleep": int(self.counts[1]),
                "learned_steps_skipped": int(self.counts[2])}
