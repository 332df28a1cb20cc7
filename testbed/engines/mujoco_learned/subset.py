"""The learned step on the awake part of a yard alone (the MuJoCo host with its trees asleep, sleep.py).

While one load lands on a yard whose other islands sleep in MuJoCo, the whole step (candidates,
the force law on every pair, the held state's commit) would still run on every container: 9.6 ms a
step at 1,000 containers. The native step has no pair mask (its scene is fixed when it is made),
so Subset runs a second ContactStep over a body subset S instead:

- S: the free containers awake in MuJoCo (W) and every container whose world box comes within the
  step's candidate margin (NEAR, + SLACK) of an awake one's: the asleep neighbours an awake body may
  push or touch (HostSleep wakes their islands one step later, as before). A body outside S is asleep
  and no awake body is near it: it does not move and its pairs cannot change. Above MOST of the
  containers in S, or with none awake, the whole step runs as before (the settling, a busy yard).
- the held state of the step over S is the whole step's, remapped: each pair's anchors, stuck flag and
  last normal force (keys ia * m + ib, ascending either way: S keeps the scene order) and each body's
  history (its last velocities and normal wrench). The pairs outside S keep theirs untouched in a
  store (the host's copy of the held state, ContactStep.held's form) and resume exactly when their
  bodies next join a step. Within S, an asleep body's history normal wrench and the rows of pairs
  between two asleep bodies are the store's again after every step: the step over S lacks their pairs
  with bodies outside S, so its own answer for them would be a partial sum (an asleep body is not moved
  by its wrench anyway); a body that joins S after sleeping starts with zero last velocities (MuJoCo
  zeroes a sleeping tree's qvel: the whole step would have recorded 0).
- the learned step's own sleeping state (each body's rest time, each island's sleeping poses and kept
  answers) lives in the native core with no way out or in (container_contact_step.h: cc_step_sleep_*
  can only reset or wake): a new S starts awake in that sense (its pairs asked until they rest for
  t_sleep), which never reuses an answer older than the poses it is asked at; when the whole step
  runs again it wakes the islands of every body stepped apart meanwhile (ContactStep.wake).
- the candidate pairs outside S (HostSleep's islands need every pair; the contact log, their rows)
  are held from the last step that computed them, as sleep.py holds a sleeping tree's quay rows; the
  step's counters count them as reused pairs in asleep islands (an idle step's convention).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from testbed.effects.learned_dynamics.step import NEAR, ContactStep, StepPairs
from testbed.engines.mujoco_learned.sleep import component_labels

SLACK = 0.01  # [m] beyond the candidate margin in the neighbour test: rounding, and a step's motion (< 1 cm)
BIG = 0.5  # [m] the potential neighbours' margin: found again once an awake box has moved BIG - NEAR - SLACK
MOST = 0.5  # the largest share of the containers the subset step runs on; above it the whole step runs


def _empty() -> StepPairs:
    z = np.zeros
    return StepPairs(ia=z(0, np.int64), ib=z(0, np.int64), fn=z(0), p_W=z((0, 3)), n_W=z((0, 3)), f_W=z((0, 3)),
                     area=z(0), p_AB=z((0, 3)), R_AB=z((0, 3, 3)), point_A=z((0, 3)), normal_A=z((0, 3)))


def _take(pairs: StepPairs, rows) -> StepPairs:
    return StepPairs(*(getattr(pairs, f.name)[rows] for f in dataclasses.fields(StepPairs)))


def _cat(a: StepPairs, b: StepPairs) -> StepPairs:
    return StepPairs(*(np.concatenate([getattr(a, f.name), getattr(b, f.name)]) for f in dataclasses.fields(StepPairs)))


class Subset:
    """The subset step of one LearnedContact `law` (module docstring); awake(data) -> (m,) bool: the
    scene's free containers awake in MuJoCo (HostSleep.awake_scene)."""

    def __init__(self, law, awake):
        self.law, self.awake = law, awake
        self.forget()

    def forget(self) -> None:
        """The state before any step: the whole step runs, nothing held."""
        n = self.law.n
        self.idx = None  # S (scene indices, ascending) the step over S runs on; None: the whole step
        self.sub = None
        self.keys, self.rows, self.history = self.law.step.no_history()  # the store (valid outside S)
        self.out = _empty()  # the candidate pairs not inside S (scene indices), held records
        self.out_counts = (0, 0)  # islands, free bodies with a pair, among them
        self.cover = np.ones(n, bool)  # the bodies the running step covers
        self.apart = np.zeros(n, bool)  # stepped over a subset since the whole step last ran
        self._box = None  # (lo, hi) (m, 3) world boxes, and the awake mask at their refresh
        self._near = None
        self._touching = None
        self.counts = np.zeros(4)  # subset steps, bodies stepped (summed), most bodies in a step, switches

    # ------------------------------------------------------------------ choosing S
    def _boxes(self, data, w) -> tuple:
        law = self.law
        rows = slice(None) if self._box is None or not np.array_equal(self._box[2], w) else w
        body = law.body[rows]
        R = data.xmat[body].reshape(-1, 3, 3)
        ext = np.abs(R) @ law.half[rows][:, :, None]
        if rows is w:
            self._box[0][w], self._box[1][w] = data.xpos[body] - ext[:, :, 0], data.xpos[body] + ext[:, :, 0]
        else:
            self._box = (data.xpos[body] - ext[:, :, 0], data.xpos[body] + ext[:, :, 0], w.copy())
        return self._box[0], self._box[1]

    def choose(self, data) -> tuple:
        """(S or None for the whole step, the awake mask (m,)) at this step's poses (after mj_step1)."""
        n = self.law.n
        w = self.awake(data)
        n_awake = int(w.sum())
        if n_awake == 0 or n_awake > MOST * n:
            return None, w
        lo, hi = self._boxes(data, w)
        lw, hw = lo[w], hi[w]
        near = self._near  # (awake mask, their boxes then, the containers within BIG of them then)
        if near is None or not np.array_equal(near[0], w) or max(np.abs(lw - near[1]).max(),
                                                                  np.abs(hw - near[2]).max()) > BIG - NEAR - SLACK:
            # a container beyond BIG of every awake box then is beyond NEAR + SLACK of each now: it stays put
            near = self._near = (w.copy(), lw, hw, self._within(lw, hw, lo, hi, BIG))
        idx = near[3][self._within(lw, hw, lo[near[3]], hi[near[3]], NEAR + SLACK)]
        return (None if len(idx) > MOST * n else idx), w

    @staticmethod
    def _within(lw, hw, lo, hi, grow: float) -> np.ndarray:
        """The rows of the boxes (lo, hi) within `grow` of any of (lw, hw) on every axis (indices)."""
        near = np.zeros(len(lo), bool)
        for c in range(0, len(lw), 64):
            rows = slice(c, c + 64)
            near |= ((lw[rows, None] - grow <= hi[None]) & (hw[rows, None] + grow >= lo[None])).all(axis=2).any(axis=0)
        return np.flatnonzero(near)

    # ------------------------------------------------------------------ switching
    def switch(self, idx, w) -> None:
        """Makes S = idx (None: the whole step) the running step, moving the held state across."""
        if (idx is None and self.idx is None) or (idx is not None and self.idx is not None and len(idx) == len(self.idx)
                                                  and np.array_equal(idx, self.idx)):
            return
        self._pull()
        self.counts[3] += 1
        step, n = self.law.step, self.law.n
        if idx is None:
            step.set_held((self.keys, self.rows, self.history))
            if self.apart.any():
                step.wake(np.flatnonzero(self.apart))
            self.apart[:] = False
            self.cover[:] = True
            self.idx = self.sub = None
            return
        law, ns = self.law, len(idx)
        loc = np.full(n, -1, dtype=np.int64)
        loc[idx] = np.arange(ns)
        la, lb = loc[self.keys // n], loc[self.keys % n]
        inside = (la >= 0) & (lb >= 0)
        self.inside = (la[inside] * ns + lb[inside], self.rows[inside])  # the store's pairs in S, local keys
        history = self.history[idx].copy()
        joined = ~self.cover[idx]  # asleep outside the last step: its last velocities were 0
        history[joined, :6] = np.where(np.isnan(history[joined, :6]), np.nan, 0.0)
        self.sub = ContactStep(law.size[idx], law.free[idx], law.mass[idx], law.I_Bo[idx], law.type_index[idx],
                               law.kappa_tt, law.cfg, law.mu, law.h, law.predictor, NEAR, force_scale=law.force_scale)
        self.sub.set_held((self.inside[0], self.inside[1], history))
        every = self.out_all
        a_in, b_in = loc[every.ia] >= 0, loc[every.ib] >= 0
        stale = (w[every.ia] & ~b_in) | (w[every.ib] & ~a_in)  # an awake body's pair with one beyond the margin
        self.out = _take(every, ~(a_in & b_in) & ~stale)
        free = law.free
        a, b = self.out.ia, self.out.ib
        both = free[a] & free[b] & ~(loc[a] >= 0) & ~(loc[b] >= 0)
        labels = component_labels(a[both], b[both], n)
        members = np.unique(np.concatenate([a[free[a] & (loc[a] < 0)], b[free[b] & (loc[b] < 0)]]))
        self.out_counts = (len(np.unique(labels[members])), len(members))
        self.idx, self.loc = idx, loc
        self.body, self.dof, self.free = law.body[idx], law.dof[idx], np.ascontiguousarray(law.free[idx])
        self.cover[:] = False
        self.cover[idx] = True
        self.apart[idx] = True

    def _pull(self) -> None:
        """The store and the held records from the running step (its latest step)."""
        step, n = self.law.step, self.law.n
        if self.idx is None:
            self.keys, self.rows, self.history = step.held()
            self.out_all = step.pairs() if step.k else _empty()
            return
        idx, ns = self.idx, len(self.idx)
        keys, rows, history = self.sub.held()
        inside = (self.loc[self.keys // n] >= 0) & (self.loc[self.keys % n] >= 0)
        merged = np.concatenate([self.keys[~inside], idx[keys // ns] * n + idx[keys % ns]])
        order = np.argsort(merged, kind="stable")
        self.keys, self.rows = merged[order], np.concatenate([self.rows[~inside], rows])[order]
        self.history[idx] = history
        self.out_all = _cat(self.out, self._mapped(self.sub.pairs())) if self.sub.k else self.out

    def _mapped(self, pairs: StepPairs) -> StepPairs:
        pairs.ia, pairs.ib = self.idx[pairs.ia], self.idx[pairs.ib]
        return pairs

    # ------------------------------------------------------------------ the step over S
    def step(self, p, R, w, v, awake) -> np.ndarray:
        """The step over S at its bodies' state (bodies_from_mujoco of self.body, ...); returns its
        wrench (|S|, 6); an asleep body's normal history and the pairs of two asleep bodies held."""
        sub, idx = self.sub, self.idx
        wrench, _ = sub.step(p, R, w, v, read=False)
        asleep = ~awake[idx]
        if asleep.any():
            ns = len(idx)
            keys, rows, history = sub.held()
            history[asleep, 6:] = self.history[idx[asleep], 6:]
            lk, lr = self.inside
            keep = ~(asleep[keys // ns] & asleep[keys % ns])
            held = asleep[lk // ns] & asleep[lk % ns]
            keys, rows = np.concatenate([keys[keep], lk[held]]), np.concatenate([rows[keep], lr[held]])
            order = np.argsort(keys, kind="stable")
            sub.set_held((keys[order], rows[order], history))
        self.counts[:3] += (1, len(idx), 0)
        self.counts[2] = max(self.counts[2], len(idx))
        return wrench

    # ------------------------------------------------------------------ what the host reads
    def touching(self) -> tuple:
        """(ia, ib, fn) of every candidate pair, scene indices: those outside S held, S's of its latest step."""
        ia, ib, fn = self.sub.touching()
        kept = self._touching  # the same (ia, ib) arrays while S's pairs stay: HostSleep's islands keep theirs
        if kept is None or kept[0] is not self.out or not (np.array_equal(kept[1], ia) and np.array_equal(kept[2], ib)):
            kept = self._touching = (self.out, ia, ib, np.concatenate([self.out.ia, self.idx[ia]]),
                                     np.concatenate([self.out.ib, self.idx[ib]]))
        return kept[3], kept[4], np.concatenate([self.out.fn, fn])

    def pairs(self) -> StepPairs:
        """Every candidate pair's records (scene indices): those outside S held."""
        return _cat(self.out, self._mapped(self.sub.pairs())) if self.sub.k else self.out

    def outside(self) -> np.ndarray:
        """What the pairs outside S add to a step's counters (step.cost[5:]): asked 0, reused, islands,
        islands asleep, bodies asleep."""
        islands, bodies = self.out_counts
        return np.array([0, len(self.out), islands, islands, bodies], float)

    def sleep_counts(self) -> dict:
        """The latest step's sleeping figures, the pairs outside S counted asleep."""
        counts = np.array(list(self.sub.sleep_counts().values()), float) + self.outside()
        return dict(zip(("asked", "reused", "islands", "islands_asleep", "bodies_asleep"), (int(x) for x in counts)))

    def summary(self, whole: int) -> dict:
        """subset_steps (steps run over a subset), learned_bodies_max (most bodies in one step),
        learned_bodies_per_step (bodies the learned step ran on, the mean over the steps it ran; `whole`:
        those it ran on every container), subset_switches."""
        n_sub, bodies, most, switches = self.counts
        steps = int(n_sub) + whole
        return {"subset_steps": int(n_sub), "learned_bodies_max": int(self.law.n if whole else most),
                "learned_bodies_per_step": float(bodies + whole * self.law.n) / steps if steps else 0.0,
                "subset_switches": int(switches)}
