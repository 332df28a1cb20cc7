"""The learned contact step, one for both hosts: the Drake-hosted loop
(effect.LearnedDynamics) and the MuJoCo-hosted one (testbed/engines/mujoco_learned/loop.py)
both call ContactStep.step, which runs the native core's step (native/src/step.c, declared by
native/include/container_contact_step.h; built into learned_contact._native):

  body poses and velocities -> candidate pairs (sort-and-sweep broad phase on the containers'
  world boxes, then bounding spheres and face axes within NEAR) -> the predictor on every
  candidate (one batched call) -> the force law (README.md beside this file) -> wrenches
  (m, 6) [torque about each body origin, force; N m, N; in W] and the pair records.

Sleeping (config.sleeping, a SleepingConfig; container_contact_step.h says the rules): the
candidates of an island of free bodies that has been at rest for t_sleep are not asked again;
they reuse their last answers (point_A, normal_A in A's frame) while the force law runs on the
current poses and velocities, until a body leaves rest or its sleeping pose (eps_p, eps_R), a
new candidate pair joins the island, or the host wakes it (ContactStep.wake).

The predictor: a compiled predictor whose native model (a learned_contact._native.Model) is
at hand runs inside the native step (one call, cc_contact_step); any other (the numpy
reference, an ONNX file, a user's Python model) is called from here on the candidates' poses
(cc_step_candidates, then predictor.predict, then cc_step_force_law). Both give the same
wrenches for the same predictor answers.

Held state (the stick anchors, stuck flags and last normal forces of the pairs in contact,
and each body's last velocities and normal wrench: container_contact_step.h) lives in the
native step between calls; a host that keeps it itself (Drake's abstract state) passes it in
and reads the next one out (held=..., then ContactStep.held()).

There is no pure-Python path: without the compiled core the step raises NativeCoreMissing,
one line naming it and how to build it.
"""

import dataclasses
import time

import numpy as np

from learned_contact.compiled.kernels import STALE
from learned_contact.interface import raise_for_status
from testbed.errors import TestbedError

ROW = 8  # a held pair's row: stick anchors in A and B [m] (6), stuck flag (1), last normal force [N] (1)
BODY = 12  # a body's history row: v_W [m/s] (3), w_W [rad/s] (3), the normal wrench applied [N m, N] (6)
NEAR = 0.05  # [m] pairs no face axis separates by this much are candidates (predicted)

try:  # the compiled core (setup.py builds it); its absence is reported when a step is made
    from learned_contact import _native
    if not hasattr(_native, "step_new"):
        raise ImportError("learned_contact._native has no contact step (an old build)")
    if STALE is not None:  # built from other sources: its ABI is not the one these calls were written for
        raise ImportError(STALE)
    _WHY = ""
except ImportError as error:  # pragma: no cover - exercised only without a build
    _native, _WHY = None, str(error)


class NativeCoreMissing(TestbedError, ImportError):
    """The learned contact step needs the compiled core learned_contact._native."""


def require_native():
    """learned_contact._native, or NativeCoreMissing (one line: what is missing, how to build it)."""
    if _native is None:
        raise NativeCoreMissing(
            f"the learned closed loop needs the native contact core learned_contact._native ({_WHY}); build it with "
            "`pip install -e .` or `python setup.py build_ext --inplace` (a C11 compiler is required)")
    return _native


def native_model(predictor):
    """The predictor's learned_contact._native.Model when it answers on the native core (its
    `native_model`: the shipped predictors loaded with compiled=True), else None: then the step
    calls predictor.predict itself on the candidate pairs."""
    if _native is None:
        return None
    model = getattr(predictor, "native_model", None)
    return model if isinstance(model, _native.model_type()) else None


@dataclasses.dataclass
class StepPairs:
    """One step's candidate pairs (k of them, A = ia < B = ib, ascending by (ia, ib)): ia, ib
    (k,) body indices; fn (k,) [N] normal force (0: not touching); p_W, n_W (k, 3) the
    contact point [m] and unit normal A -> B in W (0 where not touching); f_W (k, 3) [N] the
    force on B (minus it on A) at p_W; area (k,) [m^2] the face overlap; p_AB (k, 3) [m],
    R_AB (k, 3, 3) B's pose in A; point_A, normal_A (k, 3) the predictor's answers in A."""

    ia: np.ndarray
    ib: np.ndarray
    fn: np.ndarray
    p_W: np.ndarray
    n_W: np.ndarray
    f_W: np.ndarray
    area: np.ndarray
    p_AB: np.ndarray
    R_AB: np.ndarray
    point_A: np.ndarray
    normal_A: np.ndarray

    def __len__(self) -> int:
        return len(self.ia)


@dataclasses.dataclass
class SleepingConfig:
    """Sleeping islands of the learned step (container_contact_step.h, cc_step_set_sleep): a
    settled stack's pairs reuse their last predictor answer (point_A, normal_A) while the force
    law still runs on the current poses and velocities. On by default: with it on, two_stack,
    five_stack, crane_hard_landing and yard_wind (testbed compare, Drake host) keep their
    verdicts and every closed-loop gate figure well inside its limit (the largest change:
    five_stack's resting drift, 5.7e-7 to 2.9e-5 m/min of the 1e-3 limit), and the MuJoCo host's
    nine_mixed_stack, yard_block and yard_block_landing end within 1 % of the gates' limits of
    their runs without it (tests/closed_loop/test_sleeping.py). Defaults and why:

    v_sleep [m/s], w_sleep [rad/s]: a body is at rest below both. 1e-3: ten times the force
      law's slip_speed (1e-4 m/s, where the regularised Coulomb law turns viscous), so a stack
      creeping under stiction counts as at rest (settled stacks measure 1e-6 m/s and less),
      while a container on the crane's rope (0.1-1 m/s) or falling for one step
      (g h = 10 mm/s at h = 1 ms) never does.
    t_sleep [s]: 0.3: a stack settles by an exponential creep (five_stack: |v| from 1.6e-2 to
      1e-3 m/s between 0.2 and 0.6 s, a time constant of about 0.15 s), so 0.3 s at rest is
      two time constants: what creep is left is below v_sleep x 0.15 s = 0.15 mm, about one
      eps_p (at most one wake), and the wait costs 0.3 s of asked steps per settling.
    eps_p [m]: 1e-4 (0.1 mm): an island wakes when any point of a body's box has moved this far
      from where the island fell asleep, so a reused answer was made at a relative pose within
      2 eps_p (any point) of the current one: the reused normal and a translation-made shift
      of the point are that close to a fresh answer.
    eps_R [rad]: 1e-6: the rotation's bound, far below eps_p / (a box's half diagonal), because
      the contact point of a flat face pair is the pressure centroid, which a relative tilt t
      moves by t L^2 / (12 d) (face length L, penetration d: 2e4 m/rad for a settled 20 ft
      stack, L = 6.06 m, d = 0.16 mm): 2 eps_R keeps that under 4 cm there, and the tilt an
      asleep island may take without the centroid's restoring moment to 2e-6 rad.
    pair_reuse: off by default. On, an awake pair also reuses its kept answer while B's pose in A
      stays within eps_p (any point) and eps_R of the pose that answer was asked at (half what an
      asleep island allows), at any speed (container_contact_step.h). A still-settling yard
      (the scale study's 1,000-container window, 1e-2 m/s) would reuse 98 % of its asks; it is
      off because it changes when pairs are asked (the island counts the sleeping tests pin).
    mujoco_trees: the MuJoCo host (testbed/engines/mujoco_learned/sleep.py) also puts an asleep
      island's trees to sleep in MuJoCo (mjENBL_SLEEP: not integrated, +0.0 applied rows) and skips
      the learned step while every container sleeps; on with enabled (the fidelity it keeps: that
      module's tests)."""

    enabled: bool = True
    v_sleep: float = 1e-3
    w_sleep: float = 1e-3
    t_sleep: float = 0.3
    eps_p: float = 1e-4
    eps_R: float = 1e-6
    pair_reuse: bool = False
    mujoco_trees: bool = True

    def as_tuple(self) -> tuple:
        """(enabled, v_sleep, w_sleep, t_sleep, eps_p, eps_R[, 1.0 with pair_reuse]) for the native step."""
        figures = (float(bool(self.enabled)), float(self.v_sleep), float(self.w_sleep), float(self.t_sleep),
                   float(self.eps_p), float(self.eps_R))
        return figures + (1.0,) if self.pair_reuse else figures


class ContactStep:
    """The learned contact of m bodies (containers), for either host.

    size (m, 3) [m] full extents; free (m,) bool; mass (m,) [kg] (inf for a fixed body);
    I_Bo (m, 3, 3) [kg m^2] rotational inertia about the body origin in the body frame;
    type_index (m,) each body's row of kappa_by_type (T, T) [Pa/m]; config: the effect's
    LearnedDynamicsConfig (dissipation, stick, slip, stiction, torsion, grid, sweeps, and
    sleeping: a SleepingConfig, absent = its defaults); mu [-] the friction coefficient in force; h [s]
    the host's time step; predictor: any learned_contact predictor. Raises NativeCoreMissing
    without the compiled core."""

    def __init__(self, size, free, mass, I_Bo, type_index, kappa_by_type, config, mu: float, h: float, predictor,
                 margin: float = NEAR, force_scale: float = 1.0):
        native = require_native()
        self.n = len(free)
        self.size = np.ascontiguousarray(size, dtype=float).reshape(-1, 3)
        self.free = np.ascontiguousarray(free, dtype=bool)
        self.h = float(h)
        self.predictor = predictor
        self.params = (float(margin), self.h, float(config.dissipation), float(mu), float(config.stick_hw),
                       float(config.stick_damping), float(config.slip_speed), float(config.stiction),
                       float(bool(config.torsional_friction)), int(config.grid), int(config.normal_sweeps))
        self._core = native.step_new(self.size, self.free, np.ascontiguousarray(mass, dtype=float),
                                     np.ascontiguousarray(I_Bo, dtype=float).reshape(-1, 3, 3),
                                     np.ascontiguousarray(type_index, dtype=np.int64),
                                     np.ascontiguousarray(kappa_by_type, dtype=float), self.params)
        self.model = native_model(predictor)  # None: predictor.predict is called on the candidates
        # a model that answers its own force (ExternalPredictor.contact_force, at its FORCE_MODULUS) drives the
        # law's elastic part in place of the exact field contact, scaled to the scene's modulus by force_scale
        self.own_force = bool(getattr(predictor, "has_force", False))
        self.force_scale = float(force_scale)
        self.sleeping = getattr(config, "sleeping", None) or SleepingConfig()
        native.step_set_sleep(self._core, self.sleeping.as_tuple())
        self._seconds = np.zeros(3)
        self.k = 0  # the latest step's candidate pairs
        self.reset_costs()

    # ------------------------------------------------------------------ costs
    def reset_costs(self) -> None:
        """Zeroes the cost counters (see costs)."""
        # candidates_s, predict_s, law_s [s]; steps, predict_calls, predict_pairs, reused_pairs,
        # island_steps, asleep_island_steps, asleep_body_steps
        self.cost = np.zeros(10)

    def costs(self) -> dict:
        """Wall time [s] since reset_costs of the candidates (broad phase, pair poses, islands),
        the predictor's call and the force law (records included); steps; predict_calls (steps
        that asked the predictor); predict_pairs (pairs asked, summed over the steps);
        reused_pairs (pairs in asleep islands that reused their last answer, summed);
        islands, islands_asleep (islands with a candidate pair, and of those asleep, summed
        over the steps); bodies_asleep (free bodies in asleep islands, summed)."""
        c = self.cost
        return {"candidates_s": float(c[0]), "predict_s": float(c[1]), "law_s": float(c[2]), "steps": int(c[3]),
                "predict_calls": int(c[4]), "predict_pairs": int(c[5]), "reused_pairs": int(c[6]),
                "islands": int(c[7]), "islands_asleep": int(c[8]), "bodies_asleep": int(c[9])}

    def sleep_counts(self) -> dict:
        """The latest step's asked, reused (pairs), islands, islands_asleep, bodies_asleep."""
        names = ("asked", "reused", "islands", "islands_asleep", "bodies_asleep")
        return dict(zip(names, _native.step_sleep_counts(self._core)))

    def wake(self, bodies) -> None:
        """Wakes the islands of bodies (indices): the host's external force on them changed
        (a rope attached or released, a wind ramp); they are asked at the next step."""
        _native.step_sleep_wake(self._core, np.ascontiguousarray(bodies, dtype=np.int64).reshape(-1))

    # ------------------------------------------------------------------ held state
    def forget(self) -> None:
        """No pair held, no body's last step, every body awake (as before the first step)."""
        _native.step_forget(self._core)
        self.k = 0

    def no_history(self) -> tuple:
        """The held state before the first step: (keys (0,), rows (0, ROW), history (m, BODY) NaN)."""
        return np.zeros(0, np.int64), np.zeros((0, ROW)), np.full((self.n, BODY), np.nan)

    def held(self) -> tuple:
        """The held state after the latest step: (keys (s,) int64 = ia * m + ib ascending,
        rows (s, ROW), history (m, BODY)), copies."""
        s = _native.step_held_count(self._core)
        keys, rows, history = np.empty(s, np.int64), np.empty((s, ROW)), np.empty((self.n, BODY))
        _native.step_held_get(self._core, keys, rows, history)
        return keys, rows, history

    def set_held(self, held: tuple | None) -> None:
        """Replaces the held state with (keys, rows, history) (None: forget). A history with no
        last step (all NaN: a host's first step, a restart) also wakes every body."""
        if held is None:
            self.forget()
            return
        keys, rows, history = held
        if np.isnan(history).all():
            _native.step_sleep_reset(self._core)
        _native.step_held_set(self._core, np.ascontiguousarray(keys, dtype=np.int64),
                              np.ascontiguousarray(rows, dtype=float), np.ascontiguousarray(history, dtype=float))

    # ------------------------------------------------------------------ the step
    def step(self, p, R, w, v, held: tuple | None = None, read: bool = True) -> tuple[np.ndarray, StepPairs | None]:
        """One step at body-origin positions p (m, 3) [m], rotations R_WB (m, 3, 3) and
        velocities w, v (m, 3) [rad/s, m/s] in W (float64, C-contiguous). held: the held state
        to start from (None: the step's own, left by its last call). Returns (wrench (m, 6)
        [N m, N]: torque about each body origin and force, in W; the StepPairs of the
        candidates, or None with read=False: a host that needs them only on some steps reads
        them with pairs() before the next step). Raises the predictor's error for a pose it refuses."""
        core = self._core
        if held is not None:
            self.set_held(held)
        wrench = np.empty((self.n, 6))
        t0 = time.perf_counter()
        if self.model is not None:
            k = _native.step_contact(core, self.model, p, R, w, v, wrench, self._seconds)
            if isinstance(k, tuple):
                self._refused(*k)
            self.k = k
            pairs = self._read(k) if read else None
            t3 = time.perf_counter()
            # the core's split of its own time; the reading of the records joins the law's share
            self.cost[:3] += (self._seconds[0], self._seconds[1], t3 - t0 - self._seconds[0] - self._seconds[1])
        else:
            k = self.k = _native.step_candidates(core, p, R)
            pairs = self._read(k, law=False)
            ask = np.ones(k, np.uint8)
            n_ask = _native.step_sleep_plan(core, w, v, ask)  # asleep rows: their last answers in the step
            if n_ask < k:
                _native.step_read(core, None, None, None, None, None, None, pairs.point_A, pairs.normal_A, None, None,
                                  None, None, None)
            t1 = time.perf_counter()
            if n_ask:
                rows = slice(None) if n_ask == k else ask.astype(bool)
                point_A, normal_A = self.predictor.predict(pairs.p_AB[rows], pairs.R_AB[rows],
                                                           size_A=self.size[pairs.ia[rows]],
                                                           size_B=self.size[pairs.ib[rows]])
                pairs.point_A[rows] = np.asarray(point_A, dtype=float).reshape(n_ask, 3)
                pairs.normal_A[rows] = np.asarray(normal_A, dtype=float).reshape(n_ask, 3)
            if self.own_force and k:
                elastic = self.predictor.contact_force(pairs.p_AB, pairs.R_AB, size_A=self.size[pairs.ia],
                                                       size_B=self.size[pairs.ib])
                elastic[:, :2] *= self.force_scale  # F and dF/dd are linear in the modulus; the area is not
            t2 = time.perf_counter()
            if self.own_force and k:
                _native.step_force_law(core, w, v, pairs.point_A, pairs.normal_A, wrench, np.ascontiguousarray(elastic))
            else:
                _native.step_force_law(core, w, v, pairs.point_A, pairs.normal_A, wrench)
            _native.step_read(core, None, None, None, None, None, None, None, None, pairs.fn, pairs.f_W, pairs.p_W,
                              pairs.n_W, pairs.area)
            t3 = time.perf_counter()
            self.cost[:3] += (t1 - t0, t2 - t1, t3 - t2)
        asked, reused, islands, islands_asleep, bodies_asleep = _native.step_sleep_counts(core)
        self.cost[3] += 1
        if asked:
            self.cost[4] += 1
        self.cost[5:] += (asked, reused, islands, islands_asleep, bodies_asleep)
        return wrench, pairs

    def pairs(self) -> StepPairs:
        """The latest step's candidate pairs (valid until the next step; see step(read=False))."""
        return self._read(self.k)

    def touching(self) -> tuple:
        """(ia, ib, fn) of the latest step's candidate pairs (valid until the next step)."""
        k = self.k
        ia, ib, fn = np.empty(k, np.int64), np.empty(k, np.int64), np.empty(k)
        _native.step_read(self._core, ia, ib, None, None, None, None, None, None, fn, None, None, None, None)
        return ia, ib, fn

    def _read(self, k: int, law: bool = True) -> StepPairs:
        """The latest step's k pairs as fresh arrays (the records keep references to them)."""
        pairs = StepPairs(ia=np.empty(k, np.int64), ib=np.empty(k, np.int64), fn=np.empty(k), p_W=np.empty((k, 3)),
                          n_W=np.empty((k, 3)), f_W=np.empty((k, 3)), area=np.empty(k), p_AB=np.empty((k, 3)),
                          R_AB=np.empty((k, 3, 3)), point_A=np.empty((k, 3)), normal_A=np.empty((k, 3)))
        if law:
            _native.step_read(self._core, pairs.ia, pairs.ib, pairs.p_AB, pairs.R_AB, None, None, pairs.point_A,
                              pairs.normal_A, pairs.fn, pairs.f_W, pairs.p_W, pairs.n_W, pairs.area)
        else:
            _native.step_read(self._core, pairs.ia, pairs.ib, pairs.p_AB, pairs.R_AB, None, None, None, None, None,
                              None, None, None, None)
        return pairs

    def _refused(self, status: int, row: int, k: int) -> None:
        """Raises the predictor's own error for the candidates the native predictor refused
        (its predict on the same poses raises it), else raise_for_status's for `row`."""
        pairs = self._read(k, law=False)
        size_A, size_B = self.size[pairs.ia], self.size[pairs.ib]
        self.predictor.predict(pairs.p_AB, pairs.R_AB, size_A=size_A, size_B=size_B)
        raise_for_status(status, row, pairs.p_AB, size_A, size_B,
                         np.asarray(self.predictor.supported_sizes, float).reshape(-1, 3), pairs.R_AB)
        raise RuntimeError(f"the native predictor refused candidate pair {row} (status {status})")


def candidate_pairs(size, free, p, R, margin: float = NEAR) -> tuple:
    """The step's candidate pairs of bodies of full extents size (m, 3) [m], free (m,) at poses
    p (m, 3) [m], R (m, 3, 3) (what ContactStep.step would ask the predictor about):
    (ia, ib (k,), p_AB (k, 3) [m], R_AB (k, 3, 3), n_broad: the broad phase's candidates
    before the narrow tests)."""
    native = require_native()
    m = len(free)
    core = native.step_new(np.ascontiguousarray(size, dtype=float).reshape(-1, 3), np.ascontiguousarray(free, dtype=bool),
                           np.ones(m), np.tile(np.eye(3), (m, 1, 1)), np.zeros(m, np.int64), np.zeros((1, 1)),
                           (float(margin), 1e-3, 0.0, 0.0, 0.0, 0.0, 1e-4, 0.5, 0.0, 1, 1))
    k = native.step_candidates(core, np.ascontiguousarray(p, dtype=float), np.ascontiguousarray(R, dtype=float))
    ia, ib, p_AB, R_AB = np.empty(k, np.int64), np.empty(k, np.int64), np.empty((k, 3)), np.empty((k, 3, 3))
    native.step_read(core, ia, ib, p_AB, R_AB, None, None, None, None, None, None, None, None, None)
    return ia, ib, p_AB, R_AB, native.step_counts(core)[0]


def elastic(p_AB, R_AB, hA, hB, kappa: float, grid: int) -> tuple[float, float, float]:
    """The force law's elastic part for one pose: (F [N] the Winkler foundation force, overlap
    area [m^2], normal stiffness dF/dd [N/m]) of B (half extents hB [m]) at p_AB [m], R_AB in A
    (half extents hA), foundation stiffness kappa [Pa/m], grid quadrature points (cc_step_elastic)."""
    f64 = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    return require_native().step_elastic(f64(p_AB), f64(R_AB), f64(hA), f64(hB), float(kappa), int(grid))


def bodies_from_drake(x, q_start, v_start, fixed_p, fixed_R, free) -> tuple:
    """Drake's plant state x -> (p (m, 3) [m], R (m, 3, 3), w (m, 3) [rad/s], v (m, 3) [m/s])
    of the body origins in W (quaternion floating joints: q = [w x y z, p], v = [w_W, v_W];
    q_start, v_start (m,) int64 each free body's first index in x; fixed bodies at fixed_p,
    fixed_R, at rest)."""
    m = len(free)
    p, R, w, v = np.empty((m, 3)), np.empty((m, 3, 3)), np.empty((m, 3)), np.empty((m, 3))
    _native.bodies_from_drake(np.ascontiguousarray(x, dtype=float), q_start, v_start, fixed_p, fixed_R, free,
                              p, R, w, v)
    return p, R, w, v


def bodies_from_mujoco(data, body, dof, free) -> tuple:
    """MuJoCo's data (after mj_step1) -> (p, R, w, v) of the containers' body origins in W, as
    bodies_from_drake; body (m,) body ids, dof (m,) each free joint's first dof (-1 if fixed)."""
    m = len(free)
    p, R, w, v = np.empty((m, 3)), np.empty((m, 3, 3)), np.empty((m, 3)), np.empty((m, 3))
    _native.bodies_from_mujoco(data.xpos, data.xmat, data.qvel, body, dof, free, p, R, w, v)
    return p, R, w, v


def wrench_to_mujoco(data, wrench, body, free) -> None:
    """data.xfrc_applied [force, torque about the COM, in W] of each free container from wrench
    (m, 6) [torque about the body origin, force, in W]; every other row zeroed."""
    _native.wrench_to_mujoco(wrench, body, free, data.xpos, data.xipos, data.xfrc_applied)
