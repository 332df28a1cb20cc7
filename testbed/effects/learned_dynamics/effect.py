"""`learned_dynamics`: a learned predictor drives the container-container contact.

Drake's own contact between containers is filtered off; contact with the quay stays Drake's.
One system reads the bodies' poses and velocities, asks the predictor once per step for every
nearby container pair (one batched call) and applies the wrenches as
ExternallyAppliedSpatialForce: the normal force linearly implicit (backward Euler at the next
step's penetration, the touching pairs solved together by a few projected Gauss-Seidel sweeps
warm-started from the last step), friction explicit (step n's force from step n's state).

The step itself (candidate pairs, the predictor's call, the force law, the wrenches) is the
one both hosts call: step.ContactStep, the native core's contact step (native/src/step.c).
Nearby pairs, per step: a sort-and-sweep broad phase on the containers' world boxes (about
N log N plus the boxes sharing the sweep axis's interval), then the narrow tests (bounding
spheres, face axes) on its candidates only; the stick anchors are kept for the pairs in
contact only (an abstract state keyed by pair), so the per-step work grows with the
containers and the pairs touching, not with N(N-1)/2.

Per pair (A = lower body index, B = higher; n from A into B): line of action = the predicted
point and normal; normal force = a Winkler foundation kappa [Pa/m] over the face overlap
(force_law.py; kappa fitted to Drake's static hydroelastic curve), Hunt-Crossley dissipation
d [s/m]; Coulomb friction as an anchored stick (k_t, damping ratio) capped at mu F_n, and
regularised torsional friction.

Assumptions: flat faces (depth linear across the overlap); the overlap is the bounding
rectangle of B's face on A's face (+15 % force at 0.2 rad of yaw); edge-on-edge contact is
treated as face contact; the containers run at the law's modulus (KAPPA_MODULUS, 1e8 Pa)
unless the scene sets effects.contact.hydroelastic_modulus; the build refuses a pair whose
explicit part, the tilt stiffness, would be unstable (Jury criterion, ScenarioError naming the pair); the tilt
mode assumes the predictor moves its point with tilt as Drake's centre of pressure does.

README.md beside this file derives the law, its fit, the stability check, the records
(the `closed_loop` table, sampled shadow truth) and the cost accounting, with the measured
figures.
"""


import dataclasses
import math
import time
import typing

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import CollisionFilterDeclaration, GeometrySet
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import LeafSystem

from learned_contact import WeightsError, load_predictor, sources
from learned_contact.interface import SIZE_TOLERANCE, in_size_range
from learned_contact.predictors.external import FORCE_MODULUS
from testbed.bodies.containers import CONTAINER_TYPES
from testbed.effects import register
from testbed.effects.base import Effect, Role
from testbed.effects.learned_dynamics.force_law import law_modulus, pressure_stiffness, stability_numbers
from testbed.effects.learned_dynamics.step import NEAR, ContactStep, SleepingConfig, bodies_from_drake
from testbed.effects.learned_dynamics.truth import ClosedLoopRecords, ShadowTruth, summarize_truth
from testbed.errors import ScenarioError

MU_SDF = 0.4  # the models' mu_dynamic (sdf/README.md), what Drake's discrete solvers use


@dataclasses.dataclass
class LearnedDynamicsConfig:
    predictor: str = sources.DEFAULT  # any learned_contact.sources spec: improved | paper | .npz | .onnx | module:attribute
    pressure_stiffness: typing.Optional[float] = None  # [Pa/m] kappa; None = fitted per size pair
    dissipation: float = 5.0  # [s/m] Hunt-Crossley d, the models' hunt_crossley_dissipation (sdf/README.md)
    mu: typing.Optional[float] = None  # None: the friction effect's mu (SDF 0.4), 0 without it
    # stick: anchored tangential spring-damper, k_t = stick_hw^2 m_red / h^2 (h w_t = stick_hw),
    # damping ratio stick_damping; 0 = regularised Coulomb (slip_speed, stiction) instead
    stick_hw: float = 0.3
    stick_damping: float = 0.5
    slip_speed: float = 1e-4  # [m/s] Coulomb regularisation speed (regularised law, torsion)
    stiction: float = 0.5  # [-] cap of h c / m_red of the viscous friction (stable below 1)
    torsional_friction: bool = True
    # the elastic force: 0 = the exact field contact at any pose (static.py, native/src/step_field.c:
    # Drake's force to 1e-9, its stiffness in closed form) with Hunt-Crossley's torque from the pressure
    # spread over the surface; N >= 1 = the Winkler foundation on the face overlap with N midpoints
    # (right only where faces lie level and aligned: a corner gets 0 N), its damping at the point only
    grid: int = 0
    normal_sweeps: int = 4  # projected Gauss-Seidel sweeps of the linearly implicit normal force per step
    shadow_truth: bool = True  # with contact_log: Drake's static answer at the same pose
    truth_every_steps: int = 20  # the shadow truth on steps 0, N, 2N, ... (1 = every step)
    # settled islands reuse their last predictor answers (step.SleepingConfig: thresholds and why)
    sleeping: SleepingConfig = dataclasses.field(default_factory=SleepingConfig)


def load_named_predictor(name: str):
    """`learned_contact.load_predictor(name)`: any learned_contact.sources string. Raises
    learned_contact's WeightsError naming the file or module and what was expected."""
    return load_predictor(name)


class LearnedDynamics(LeafSystem):
    """Contact wrenches between container pairs from a predictor (see the module docstring)."""

    def __init__(self, assembly, config: LearnedDynamicsConfig, predictor, kappa_by_type: np.ndarray, mu: float,
                 type_index: np.ndarray, modulus: float):
        super().__init__()
        self.set_name("learned_dynamics")
        plant = assembly.plant
        self._cfg, self._pred, self._mu = config, predictor, float(mu)
        self._h = plant.time_step()
        specs = assembly.scenario.containers
        bodies = [assembly.bodies[c.name] for c in specs]
        self._rows = np.array([assembly.body_names.index(c.name) for c in specs])  # container -> body_names index
        self._free = np.array([not c.fixed for c in specs])
        nq = plant.num_positions()
        self._q_start = np.array([b.floating_positions_start() if f else -1 for b, f in zip(bodies, self._free)], dtype=np.int64)
        self._v_start = np.array([nq + b.floating_velocities_start_in_v() if f else -1 for b, f in zip(bodies, self._free)],
                                 dtype=np.int64)
        self._fixed_p = np.array([c.pose().translation() for c in specs]).reshape(-1, 3)  # (m, 3) [m]
        self._fixed_R = np.array([c.pose().rotation().matrix() for c in specs]).reshape(-1, 3, 3)
        self._size = np.array([CONTAINER_TYPES[c.type].size for c in specs], dtype=float).reshape(-1, 3)  # (m, 3) [m]
        self._mass = np.array([np.inf if c.fixed else c.total_mass() for c in specs])  # [kg]
        self._I_Bo = np.array([b.default_rotational_inertia().CopyToFullMatrix3() for b in bodies]).reshape(-1, 3, 3)
        self._type = np.asarray(type_index, dtype=np.int64)  # (m,) container -> row of kappa_by_type
        self._kappa_tt = np.asarray(kappa_by_type, dtype=float)  # (T, T) [Pa/m] per size pair
        self._n = len(specs)
        self._modulus = modulus  # [Pa] the containers' (shadow truth's) hydroelastic modulus
        # the one contact step of both hosts (raises NativeCoreMissing without the compiled core)
        self._step = ContactStep(self._size, self._free, self._mass, self._I_Bo, self._type, self._kappa_tt, config,
                                 self._mu, self._h, predictor, NEAR, force_scale=modulus / FORCE_MODULUS)
        self._last = None  # the latest step's touching pairs (records, the crane's seating test)
        self.reset_costs()  # (again after the constructor's warm-up call below)
        truth = ShadowTruth([c.type for c in specs], modulus, config.truth_every_steps) if config.shadow_truth else None
        self.records = ClosedLoopRecords(self._rows, truth)  # the closed_loop table (with contact_log)
        self._x = self.DeclareVectorInputPort("plant_state", plant.num_multibody_states())
        # the held rows of the pairs in contact: (keys (s,) int64 = ia * m + ib, ascending;
        # rows (s, step.ROW): the stick's material points in A and B [m] (6), stuck flag (1),
        # last normal force [N] (1); absent = not stuck, no force), and each body's history
        # (m, step.BODY): velocities and the normal wrench of the last step (NaN: none yet)
        self._anchor_state = self.DeclareAbstractState(AbstractValue.Make(self._no_history()))
        self._next_anchors = self._no_history()
        # an unrestricted update, like the plant's step (sampled ports): both read the same
        # pre-step state, so the anchors come from the wrenches the plant just evaluated
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._h, 0.0, self._update_anchors)
        self._forces = [ExternallyAppliedSpatialForce() for _ in specs]
        for f, body in zip(self._forces, bodies):
            f.body_index = body.index()
            f.p_BoBq_B = np.zeros(3)
        self._out = self.DeclareAbstractOutputPort(
            "spatial_forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]), self._calc)
        builder = assembly.builder
        builder.AddSystem(self)
        builder.Connect(plant.get_state_output_port(), self._x)
        assembly.add_spatial_forces(self._out)
        # the predictor's first call (a Python model's imports, caches) now, not inside the first timed step
        x0 = plant.GetPositionsAndVelocities(plant.CreateDefaultContext())
        self.wrenches(*self._bodies(x0))
        self._last, self._next_anchors = None, self._no_history()
        self.reset_costs()
        self._recording = "contact_log" in assembly.effects
        if self._recording:
            self.DeclarePeriodicPublishEvent(self._h, 0.0, self._record)

    def _no_history(self) -> tuple:
        """The held state before the first step: no pair held, every body's history NaN."""
        return self._step.no_history()

    def _bodies(self, x) -> tuple:
        """(p, R, w, v) of the containers' body origins in W from the plant state x."""
        return bodies_from_drake(x, self._q_start, self._v_start, self._fixed_p, self._fixed_R, self._free)

    def reset_costs(self) -> None:
        """Zeroes the cost counters (see costs())."""
        self._cost = np.zeros(6)  # calc_s, predict_s, record_s [s]; calc_calls, predict_calls, predict_pairs
        self._step.reset_costs()

    def costs(self) -> dict:
        """Wall time [s, perf_counter] spent since reset_costs(): calc_s in the output's calc
        (the predictor's call included) and the anchors' update, predict_s in the predictor's
        call, record_s in the records (shadow truth included); calc_calls, predict_calls: how
        many of each; predict_pairs: the container pairs the predictor was asked about, summed
        over its calls (pair-steps: 0 when the model made no contact decision); reused_pairs,
        bodies_asleep: pair-steps answered from an asleep island's last answers, body-steps
        asleep (config.sleeping)."""
        c, s = self._cost, self._step.costs()
        return {"calc_s": float(c[0]), "predict_s": s["predict_s"], "record_s": float(c[2]),
                "calc_calls": int(c[3]), "predict_calls": s["predict_calls"], "predict_pairs": s["predict_pairs"],
                "reused_pairs": s["reused_pairs"], "bodies_asleep": s["bodies_asleep"]}

    def touching(self, container: int) -> bool:
        """Whether container (scene index) was in learned contact at the latest computed step."""
        last = self.last()
        return last is not None and bool(np.any(last["pairs"] == container))

    def last(self) -> dict | None:
        """The latest computed step's touching pairs: pairs (k, 2) container indices, p_W,
        n_W, f_W (k, 3), fn, area (k,), p_AB (k, 3), R_AB (k, 3, 3), p_WA, R_WA (A's pose)."""
        if self._last is None or isinstance(self._last, dict):
            return self._last
        pairs, p, R = self._last
        touch = pairs.fn > 0
        ia, ib = pairs.ia[touch], pairs.ib[touch]
        self._last = {"pairs": np.stack([ia, ib], axis=1), "p_W": pairs.p_W[touch], "n_W": pairs.n_W[touch],
                      "fn": pairs.fn[touch], "f_W": pairs.f_W[touch], "area": pairs.area[touch],
                      "p_AB": pairs.p_AB[touch], "R_AB": pairs.R_AB[touch], "p_WA": p[ia], "R_WA": R[ia]}
        return self._last

    def _update_anchors(self, context, state) -> None:
        self._out.Eval(context)  # cached: its calc left the next anchors for this very state
        start = time.perf_counter()
        state.get_mutable_abstract_state(self._anchor_state).set_value(self._next_anchors)
        self._cost[0] += time.perf_counter() - start

    def _calc(self, context, output) -> None:
        start = time.perf_counter()
        x = self._x.Eval(context)
        anchors = context.get_abstract_state(self._anchor_state).get_value()
        wrench = self.wrenches(*self._bodies(x), anchors=anchors)
        out = []
        for k in np.flatnonzero(self._free):
            f = self._forces[k]
            f.F_Bq_W = SpatialForce(tau=wrench[k, :3], f=wrench[k, 3:])
            out.append(f)
        output.set_value(out)
        self._cost[0] += time.perf_counter() - start
        self._cost[3] += 1

    def wrenches(self, p, R, w, v, anchors=None) -> np.ndarray:
        """(m, 6) [N m, N] torque about each body origin and force, in W, on each container,
        from body-origin positions p (m, 3) [m], rotations R_WB (m, 3, 3) and velocities
        w, v (m, 3) [rad/s, m/s] in W and the held state (keys, rows, history) of the pairs in
        contact and the bodies (see _anchor_state; None = none): one step of step.ContactStep
        (one predictor call for all candidate pairs). Leaves the next held state in _next_anchors."""
        wrench, pairs = self._step.step(p, R, w, v, held=self._no_history() if anchors is None else anchors)
        self._next_anchors = self._step.held()
        self._last = (pairs, p, R)  # last() builds the dict on demand
        return wrench

    def _record(self, context) -> None:
        self._out.Eval(context)  # the cached wrenches of this state
        start = time.perf_counter()
        step, raw = int(round(context.get_time() / self._h)), self._last
        truth = self.records.truth
        if truth is not None and truth.due(step):
            last = self.last()  # the touching rows, as the truth needs them
            pairs = (last["pairs"][:, 0], last["pairs"][:, 1], last["fn"], last["p_W"], last["n_W"], last["f_W"], last["area"])
            self.records.add(step, context.get_time(), pairs, truth.answer(last) if len(last["pairs"]) else None)
        elif isinstance(raw, dict):  # last() already ran on this state: its touching rows
            self.records.add(step, context.get_time(), (raw["pairs"][:, 0], raw["pairs"][:, 1], raw["fn"], raw["p_W"],
                                                        raw["n_W"], raw["f_W"], raw["area"]))
        elif raw is not None:  # (StepPairs, p, R): the candidate pairs
            pairs = raw[0]
            self.records.add(step, context.get_time(), (pairs.ia, pairs.ib, pairs.fn, pairs.p_W, pairs.n_W, pairs.f_W,
                                                        pairs.area))
        self._cost[2] += time.perf_counter() - start



@register
class LearnedDynamicsEffect(Effect):
    name = "learned_dynamics"
    Config = LearnedDynamicsConfig
    role = Role.PHYSICS
    untranslated_reason = "the learned contact force law drives Drake's plant only"
    measured_alone = False  # it replaces Drake's container contact (the closed-loop cases time it)
    order = 22  # before crane (25), which asks it whether its container is seated
    requires = ("contact",)
    STABLE_BELOW = 4.0  # (h w)^2 of the explicit part (the tilt stiffness) in the symplectic Euler step

    def check(self, effects) -> None:
        super().check(effects)
        c = self.config
        for field in ("dissipation", "slip_speed", "stiction", "stick_hw", "stick_damping"):
            value = getattr(c, field)
            if not (math.isfinite(value) and value >= 0) or (field == "slip_speed" and value == 0):
                raise self.fail(field, f"expected a finite {'positive' if field == 'slip_speed' else 'non-negative'} number, got {value}")
        if not 0 <= c.stiction <= 1:
            raise self.fail("stiction", f"expected a fraction in [0, 1], got {c.stiction}")
        if 2 * (c.stick_hw**2 + 4 * c.stick_damping * c.stick_hw) >= self.STABLE_BELOW:
            raise self.fail("stick_hw", f"the stick spring-damper is unstable with two contacts per body: "
                            f"2 (stick_hw^2 + 4 stick_damping stick_hw) = "
                            f"{2 * (c.stick_hw**2 + 4 * c.stick_damping * c.stick_hw):.2f}, expected below 4")
        if c.pressure_stiffness is not None and not c.pressure_stiffness > 0:
            raise self.fail("pressure_stiffness", f"expected a positive stiffness [Pa/m], got {c.pressure_stiffness}")
        if not (isinstance(c.truth_every_steps, int) and c.truth_every_steps >= 1):
            raise self.fail("truth_every_steps", f"expected a whole number of steps >= 1, got {c.truth_every_steps}")
        if not (isinstance(c.normal_sweeps, int) and c.normal_sweeps >= 1):
            raise self.fail("normal_sweeps", f"expected a whole number >= 1, got {c.normal_sweeps}")
        if not (isinstance(c.grid, int) and not isinstance(c.grid, bool) and c.grid >= 0):
            raise self.fail("grid", f"expected 0 (the exact field contact) or a whole number of foundation points >= 1, got {c.grid}")
        for field in ("v_sleep", "w_sleep", "t_sleep", "eps_p", "eps_R"):
            value = getattr(c.sleeping, field)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise self.fail(f"sleeping.{field}", f"expected a finite non-negative number, got {value!r}")
        if c.mu is not None and not c.mu >= 0:
            raise self.fail("mu", f"expected a non-negative friction coefficient, got {c.mu}")
        if self.scenario.plant.time_step <= 0:
            raise self.fail("", "needs a discrete plant (plant.time_step > 0)")
        for i, spec in enumerate(self.scenario.containers):
            if spec.type not in CONTAINER_TYPES:  # the law is fitted, the predictors trained, per container size pair
                raise ScenarioError(self.source, f"containers[{i}].type",
                                    f"'{spec.name}' is a generic {spec.type!r}; the learned closed loop "
                                    f"(effects.learned_dynamics) expects container types only: {', '.join(CONTAINER_TYPES)}")
        self._prepare()

    def plan(self, plan) -> None:
        super().plan(plan)
        # the containers at the law's modulus unless the scene chose one (the contact effect writes that)
        plan.proximity_overrides.setdefault("hydroelastic_modulus", law_modulus(self.scenario))

    def _prepare(self) -> None:
        """Loads the predictor, lists the pairs, checks the explicit step's stability."""
        c = self.config
        try:
            self.predictor = load_named_predictor(c.predictor)
        except WeightsError as e:
            raise self.fail("predictor", f"{e} (learned_contact.sources lists what a predictor can be)") from None
        specs = self.scenario.containers
        supported = np.asarray(self.predictor.supported_sizes, dtype=float).reshape(-1, 3)
        for i, spec in enumerate(specs):  # at build time, naming the scene and the container, not mid-run
            size = np.asarray(CONTAINER_TYPES[spec.type].size, dtype=float)
            ranged = in_size_range(size[None], getattr(self.predictor, "size_range", None))[0]
            if np.abs(supported - size).max(axis=1).min() > SIZE_TOLERANCE and not ranged:
                choices = "; ".join(str(tuple(round(float(v), 3) for v in s)) for s in supported)
                raise ScenarioError(self.source, f"containers[{i}]",
                                    f"'{spec.name}' (type {spec.type}, size {tuple(round(float(v), 3) for v in size)} m) is not "
                                    f"a size the predictor {c.predictor} declares (full extents [m]: {choices}); the learned "
                                    "closed loop asks it about every pair of containers")
        self.pairs = [(i, j) for i in range(len(specs)) for j in range(i + 1, len(specs))
                      if not (specs[i].fixed and specs[j].fixed)]
        self.modulus = law_modulus(self.scenario)
        types = sorted({s.type for s in specs})
        self.type_index = np.array([types.index(s.type) for s in specs], dtype=np.int64)  # container -> kappa_by_type row
        self.kappa_by_type = np.array([[c.pressure_stiffness or pressure_stiffness(a, b, self.modulus) for b in types]
                                       for a in types]).reshape(len(types), len(types))  # [Pa/m]
        self.kappa = np.array([self.kappa_by_type[self.type_index[i], self.type_index[j]] for i, j in self.pairs])
        self.stability = stability_numbers(self.scenario, self.pairs, self.kappa, c.dissipation)
        for row in self.stability:  # the normal force is linearly implicit: the tilt stiffness stays explicit
            if row["explicit"] >= self.STABLE_BELOW:
                h = self.scenario.plant.time_step
                raise self.fail(
                    "", f"pair '{row['pair'][0]}'-'{row['pair'][1]}': the explicit contact force is unstable at "
                    f"plant.time_step = {h:g} s: tilt mode (h w)^2 = {row['explicit']:.2f} "
                    f"(h w = {row['h_w_tilt']:.2f}), expected below {self.STABLE_BELOW:g}; "
                    f"use a time step below about {h * math.sqrt(self.STABLE_BELOW / row['explicit']):.2g} s")

    def add_systems(self, assembly) -> list:
        if not hasattr(self, "predictor"):
            self._prepare()
        plant, specs = assembly.plant, self.scenario.containers
        ids = [gid for c in specs for gid in plant.GetCollisionGeometriesForBody(assembly.bodies[c.name])]
        if ids:
            assembly.scene_graph.collision_filter_manager().Apply(
                CollisionFilterDeclaration().ExcludeWithin(GeometrySet(ids)))
        mu = 0.0
        friction = self.scenario.effects.friction
        if friction is not None:
            mu = self.config.mu if self.config.mu is not None else (friction.mu if friction.mu is not None else MU_SDF)
        self.system = LearnedDynamics(assembly, self.config, self.predictor, self.kappa_by_type, mu, self.type_index, self.modulus)
        return [self.system]

    def collect(self, tables: dict) -> None:
        if self.system._recording:
            tables["closed_loop"] = self.system.records.build()

    def summarize(self, tables: dict) -> dict:
        out = {"learned_dynamics_predictor": self.config.predictor,
               "learned_dynamics_stability_max": max((r["explicit"] for r in self.stability), default=0.0)}
        table = tables.get("closed_loop")
        if table is not None and "has_truth" in table:
            out.update(summarize_truth(table, self.config.truth_every_steps))
        return out
