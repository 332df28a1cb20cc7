"""`crane`: a trolley and hoist carrying one container on four ropes, with twistlocks.

Model (chosen for a ship-to-shore or gantry crane at container-handling scale):
- The trolley is kinematic: its position x_T(t) along world x and the hoisted rope
  length L(t) follow the prescribed `moves` (trapezoidal speed profiles and pauses).
- Four ropes run from sheaves on the trolley, at height `trolley_height`, straight
  down to the four top corner castings of the container; the spreader's mass is
  neglected (the container is the pendulum). The sheaves lie along the crane's axes
  (world x, y), turned by the quarter turn nearest the container's initial yaw: a box
  yawed 90 degrees (long side across the trolley's travel, as a gantry crane carries it
  over a yard's rows) hangs from sheaves turned with it; one yawed a little off those
  axes (crane_misaligned's 2 degrees) hangs slightly twisted, the ropes pulling it back.
  A scene whose ropes would start more than MAX_INITIAL_TILT_RAD off vertical is refused. Each rope is a tension-only
  spring-damper: T = max(0, k (l - L) + c dl/dt), k = rope_EA / L, with damping c
  from `rope_damping_ratio` of the vertical mode of the hanging container. Sway comes
  only from the trolley's acceleration.
- The twistlocks release (rope forces vanish for good) when the container is seated
  (in contact and descending slower than `seated_speed`) or at `release_time`.
At t = 0 the container hangs at rest where the scene puts it: the initial rope
length is the static-equilibrium length for that pose. Adds one system, `crane`.
"""

import dataclasses
import math
import typing

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ContactResults, ExternallyAppliedSpatialForce
from pydrake.systems.framework import LeafSystem

from testbed.effects import register
from testbed.effects.base import Effect, Role
from testbed.errors import one_of
from testbed.physics import GRAVITY

MAX_INITIAL_TILT_RAD = 0.1  # [rad] a rope more than this off vertical at t = 0 is refused


@dataclasses.dataclass
class CraneMove:
    kind: str = "pause"  # trolley (to world x = target [m]) | hoist (rope length change = target [m], + pays out) | pause
    target: float = 0.0
    speed: float = 0.5  # [m/s] cruise speed
    acceleration: float = 0.5  # [m/s^2]
    duration: float = 0.0  # [s] for pauses


@dataclasses.dataclass
class CraneConfig:
    container: str = ""  # name of the carried container
    trolley_height: float = 30.0  # [m] height of the rope sheaves above the quay
    rope_EA: float = 7.0e7  # [N] axial stiffness of one rope (steel wire rope ~30 mm: E ~ 1e11 Pa x A ~ 7e-4 m^2)
    rope_damping_ratio: float = 0.05  # [-] of the vertical bounce mode
    moves: typing.List[CraneMove] = dataclasses.field(default_factory=list)
    seated_speed: float = 0.02  # [m/s] descent speed below which a container in contact is seated
    release_time: typing.Optional[float] = None  # [s] scheduled twistlock release (None: when seated)


class Profile:
    """Piecewise trolley position x_T(t) [m] and rope length change dL(t) [m]."""

    def __init__(self, moves: list[CraneMove], x0: float):
        self.segments = []  # (t0, t1, channel, start, delta, speed, acceleration)
        t, x, dl = 0.0, x0, 0.0
        for move in moves:
            if move.kind == "pause":
                t += move.duration
                continue
            start = x if move.kind == "trolley" else dl
            delta = (move.target - x) if move.kind == "trolley" else move.target
            duration = _trapezoid_duration(abs(delta), move.speed, move.acceleration)
            self.segments.append((t, t + duration, move.kind, start, delta, move.speed, move.acceleration))
            t += duration
            if move.kind == "trolley":
                x = move.target
            else:
                dl += move.target
        self.x0, self.end_time = x0, t

    def __call__(self, t: float) -> tuple[float, float, float, float]:
        """(x_T, v_T, dL, dL_dot) at time t."""
        x, v, dl, dl_dot = self.x0, 0.0, 0.0, 0.0
        for t0, t1, kind, start, delta, speed, accel in self.segments:
            if t < t0:
                break
            s, s_dot = _trapezoid(min(t, t1) - t0, abs(delta), speed, accel)
            sign = math.copysign(1.0, delta) if delta else 0.0
            if t >= t1:
                s_dot = 0.0
            if kind == "trolley":
                x, v = start + sign * s, sign * s_dot
            else:
                dl, dl_dot = start + sign * s, sign * s_dot
        return x, v, dl, dl_dot


def _trapezoid_duration(distance, speed, accel) -> float:
    if distance <= 0:
        return 0.0
    if speed**2 / accel >= distance:  # triangular profile
        return 2.0 * math.sqrt(distance / accel)
    return distance / speed + speed / accel


def _trapezoid(t, distance, speed, accel) -> tuple[float, float]:
    """Distance covered and speed at time t of a rest-to-rest trapezoidal profile."""
    if distance <= 0:
        return 0.0, 0.0
    total = _trapezoid_duration(distance, speed, accel)
    peak = min(speed, math.sqrt(distance * accel))
    t_ramp = peak / accel
    if t <= t_ramp:
        return 0.5 * accel * t * t, accel * t
    if t >= total - t_ramp:
        r = max(0.0, total - t)
        return distance - 0.5 * accel * r * r, accel * r
    return 0.5 * accel * t_ramp**2 + peak * (t - t_ramp), peak


class RopeModel:
    """The four ropes on one carried container, independent of any simulator (this
    effect's CraneSystem and the MuJoCo translator both use it).

    Rope i runs from the sheave (x_T(t), y_T, trolley_height) + R_q (sx, sy, 0) to the top
    corner casting (sx, sy, h/2) of the container (in its frame B), sx = +-L/2, sy = +-W/2,
    R_q the turn about +z by the multiple of 90 degrees nearest the container's initial
    yaw (so the ropes hang vertically at t = 0 for a box at 0, 90, 180 or 270 degrees;
    x_T(0), y_T: the container's initial x, y); its tension is
    T = max(0, (EA / L_r) (l - L_r) + c (dl/dt - dL/dt)), L_r = L0 + dL(t), with L0 set so
    the ropes carry the weight at t = 0 and c for `rope_damping_ratio` of the four ropes.
    """

    def __init__(self, config: CraneConfig, spec):
        half = spec.container_type().half_size
        self.p_BoC_B = np.array([[sx * half[0], sy * half[1], half[2]] for sx in (-1, 1) for sy in (-1, 1)])  # (4, 3)
        X_WC0 = spec.pose()
        p_WC0 = X_WC0.rotation().matrix() @ self.p_BoC_B.T + X_WC0.translation()[:, None]  # (3, 4) corners
        R_WC0 = X_WC0.rotation().matrix()
        quarter = round(math.atan2(R_WC0[1, 0], R_WC0[0, 0]) / (0.5 * math.pi)) * 0.5 * math.pi  # [rad]
        c, s = math.cos(quarter), math.sin(quarter)
        # (4, 2) [m] sheave x, y offsets from the trolley in W: the corners' (sx, sy) turned by R_q
        self._sheave_offsets = self.p_BoC_B[:, :2] @ np.array([[c, s], [-s, c]])
        self._corners0_W = p_WC0.T  # (4, 3) [m] the top corners at t = 0
        self._y_T = X_WC0.translation()[1]
        self._height = config.trolley_height
        length0 = self._height - p_WC0[2].mean()  # mean rope length at t = 0 [m]
        if length0 <= 0.5:
            raise ValueError("trolley_height must be well above the carried container")
        mass = spec.total_mass()
        self._EA = config.rope_EA
        stretch = mass * GRAVITY / 4.0 / (self._EA / length0)  # static stretch per rope [m]
        self._L0 = length0 - stretch  # unstretched rope length at t = 0 [m]
        k_total = 4.0 * self._EA / length0
        self._c = 2.0 * config.rope_damping_ratio * math.sqrt(k_total * mass) / 4.0  # per rope [N s/m]
        self.profile = Profile(config.moves, X_WC0.translation()[0])

    def initial_tilt_rad(self) -> float:
        """[rad] the largest angle from vertical of a rope at t = 0."""
        rope = self.sheaves_W(0.0) - self._corners0_W  # (4, 3) corner -> sheave
        return float(np.max(np.arctan2(np.linalg.norm(rope[:, :2], axis=1), rope[:, 2])))

    def sheaves_W(self, t: float) -> np.ndarray:
        """(4, 3) sheave positions [m] at time t."""
        x_T = self.profile(t)[0]
        return np.column_stack([x_T + self._sheave_offsets[:, 0], self._y_T + self._sheave_offsets[:, 1],
                                np.full(4, self._height)])

    def corner_forces(self, t: float, R_WB, p_WBo, v_WBo, w_WB) -> tuple[np.ndarray, np.ndarray]:
        """(f (4, 3) [N] rope forces on the corners in W, p_BoC_W (4, 3) [m] the corners
        from the body origin in W) for pose R_WB, p_WBo and velocity v_WBo, w_WB (in W)."""
        _, v_T, dl, dl_dot = self.profile(t)
        p_BoC_W = self.p_BoC_B @ np.asarray(R_WB).T  # (4, 3)
        v_WC = np.asarray(v_WBo) + np.cross(w_WB, p_BoC_W)  # (4, 3)
        rope = self.sheaves_W(t) - (np.asarray(p_WBo) + p_BoC_W)  # (4, 3) corner -> sheave
        length = np.linalg.norm(rope, axis=1)
        u = rope / length[:, None]
        length_dot = np.einsum("ij,ij->i", np.array([v_T, 0.0, 0.0]) - v_WC, u)
        rest = self._L0 + dl
        tension = np.maximum(0.0, self._EA / rest * (length - rest) + self._c * (length_dot - dl_dot))  # (4,) [N]
        return tension[:, None] * u, p_BoC_W

    def power_W(self, t: float, R_WB, p_WBo, v_WBo, w_WB) -> float:
        """[W] the ropes' power on the locked container at time t [s] (arguments as
        corner_forces): sum over the ropes of the corner force . the corner's velocity, in W."""
        f, p_BoC_W = self.corner_forces(t, R_WB, p_WBo, v_WBo, w_WB)
        return float(np.einsum("ij,ij->", f, np.asarray(v_WBo) + np.cross(w_WB, p_BoC_W)))


class RopePower:
    """The ropes' power [W] on container i of a record, power(t, p, R, v, w) (CraneEffect.external_power),
    while the twistlocks hold; until(events) [s]: when the ropes stop pulling in a run whose
    Trajectory.events are `events`. Every engine decides the release at a step's start, from its
    state and the previous step's contacts, and applies it from the next step (CraneSystem's
    unrestricted update, engines/mujoco/crane.py, engines/bullet/loads.py), so the ropes pull
    through the step that starts at the recorded crane_release_time_s: until = it + the plant's
    step h (inf: held throughout); unrecorded, the scheduled release_time + h, else None (a release
    on seating the records do not hold: the work is not known)."""

    EVENT = "crane_release_time_s"

    def __init__(self, ropes: RopeModel, i: int, scheduled: float | None, step: float):
        self.ropes, self.i, self.scheduled, self.step = ropes, i, scheduled, step

    def __call__(self, t, p, R, v, w) -> float:
        return self.ropes.power_W(t, R[self.i], p[self.i], v[self.i], w[self.i])

    def until(self, events: dict) -> float | None:
        released = events[self.EVENT] if self.EVENT in events else self.scheduled
        if self.EVENT in events and released is None:
            return math.inf
        return None if released is None else float(released) + self.step


class CraneSystem(LeafSystem):
    def __init__(self, assembly, config: CraneConfig):
        super().__init__()
        self.set_name("crane")
        plant = assembly.plant
        spec = next(c for c in assembly.scenario.containers if c.name == config.container)
        self._body = assembly.bodies[spec.name]
        self._body_index = int(self._body.index())
        self._geometries = set(plant.GetCollisionGeometriesForBody(self._body))
        learned = assembly.effects.get("learned_dynamics")  # container pairs are off Drake's contact then
        self._learned = (learned.system, assembly.scenario.containers.index(spec)) if learned else None
        self._ropes = RopeModel(config, spec)
        self._seated_speed = config.seated_speed
        self._release_time = config.release_time
        self._poses = self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
        self._velocities = self.DeclareAbstractInputPort(
            "body_spatial_velocities", plant.get_body_spatial_velocities_output_port().Allocate())
        self._contacts = self.DeclareAbstractInputPort("contact_results", AbstractValue.Make(ContactResults()))
        self._released = self.DeclareAbstractState(AbstractValue.Make(-1.0))  # release time, -1 = locked
        self.DeclarePeriodicUnrestrictedUpdateEvent(plant.time_step(), 0.0, self._update_locks)
        self.DeclareAbstractOutputPort(
            "spatial_forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]), self._calc_forces)
        builder = assembly.builder
        builder.AddSystem(self)
        builder.Connect(plant.get_body_poses_output_port(), self._poses)
        builder.Connect(plant.get_body_spatial_velocities_output_port(), self._velocities)
        builder.Connect(plant.get_contact_results_output_port(), self._contacts)
        assembly.add_spatial_forces(self.get_output_port())
        self.release_log: list[float] = []

    def sheaves_W(self, t: float) -> np.ndarray:
        """(4, 3) sheave positions [m] at time t."""
        return self._ropes.sheaves_W(t)

    def release_time_s(self, root_context) -> float | None:
        """[s] when the twistlocks released in the run of `root_context` (the diagram's), None: locked."""
        released = self.GetMyContextFromRoot(root_context).get_abstract_state(0).get_value()
        return None if released < 0 else float(released)

    @property
    def profile_end_s(self) -> float:
        """[s] when the trolley and hoist profile ends."""
        return self._ropes.profile.end_time

    def _in_contact(self, results) -> bool:
        """Whether any contact involving the carried container is reported."""
        if self._learned is not None and self._learned[0].touching(self._learned[1]):
            return True
        for i in range(results.num_hydroelastic_contacts()):
            surface = results.hydroelastic_contact_info(i).contact_surface()
            if surface.id_M() in self._geometries or surface.id_N() in self._geometries:
                return True
        index = self._body.index()
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            if index in (info.bodyA_index(), info.bodyB_index()):
                return True
        return False

    def _update_locks(self, context, state) -> None:
        released = context.get_abstract_state(0).get_value()
        if released >= 0:
            return
        t = context.get_time()
        release = self._release_time is not None and t >= self._release_time
        if not release and self._release_time is None:
            v = self._velocities.Eval(context)[self._body_index].translational()
            if abs(v[2]) < self._seated_speed and self._in_contact(self._contacts.Eval(context)) and t > 0:
                release = True
        if release:
            state.get_mutable_abstract_state(0).set_value(t)
            self.release_log.append(t)

    def _calc_forces(self, context, output) -> None:
        t = context.get_time()
        released = context.get_abstract_state(0).get_value() >= 0
        force = ExternallyAppliedSpatialForce()
        force.body_index = self._body.index()
        force.p_BoBq_B = np.zeros(3)
        if released:
            force.F_Bq_W = SpatialForce(tau=np.zeros(3), f=np.zeros(3))
            output.set_value([force])
            return
        X_WB = self._poses.Eval(context)[self._body_index]
        V_WB = self._velocities.Eval(context)[self._body_index]
        f, p_BoC_W = self._ropes.corner_forces(t, X_WB.rotation().matrix(), X_WB.translation(),
                                               V_WB.translational(), V_WB.rotational())  # (4, 3) each
        tau = np.cross(p_BoC_W, f).sum(axis=0)
        force.F_Bq_W = SpatialForce(tau=tau, f=f.sum(axis=0))
        output.set_value([force])


@register
class CraneEffect(Effect):
    name = "crane"
    Config = CraneConfig
    role = Role.PHYSICS
    translated_by = ("mujoco", "bullet")
    measured_alone = False  # its defaults carry no container
    order = 25
    requires = ("contact",)

    def check(self, effects) -> None:
        super().check(effects)
        if "deck_motion" in effects:  # the ropes hang from sheaves fixed in W; under deck_motion W is the deck's frame
            raise self.fail("", "cannot run with effects.deck_motion: the crane's sheaves would ride the rolling deck's "
                            "frame (a ship's own crane), and a quay crane's rope anchor fixed in the world over a "
                            "rolling bay is not modelled; drop one of the two effects")
        names = {c.name: c for c in self.scenario.containers}
        if self.config.container not in names:
            raise self.fail("container", f"{self.config.container!r} is not a container in this scene; "
                            f"{one_of(self.config.container, names)}")
        if names[self.config.container].fixed:
            raise self.fail("container", "the carried container must not be fixed")
        for field in ("trolley_height", "rope_EA"):
            if not getattr(self.config, field) > 0:
                raise self.fail(field, f"expected a positive number, got {getattr(self.config, field)}")
        if not 0 <= self.config.rope_damping_ratio < 2:
            raise self.fail("rope_damping_ratio", "expected a damping ratio in [0, 2)")
        for i, move in enumerate(self.config.moves):
            if move.kind not in ("trolley", "hoist", "pause"):
                raise self.fail(f"moves[{i}].kind", f"unknown move {move.kind!r}; expected one of: trolley, hoist, pause")
            if move.kind != "pause" and not (move.speed > 0 and move.acceleration > 0):
                raise self.fail(f"moves[{i}]", "expected positive speed and acceleration")
            if move.kind == "pause" and not move.duration >= 0:
                raise self.fail(f"moves[{i}].duration", "expected a non-negative pause [s]")
        spec = names[self.config.container]
        top = spec.pose().translation()[2] + spec.container_type().half_size[2]
        if self.config.trolley_height < top + 1.0:
            raise self.fail("trolley_height", f"expected at least 1 m above the carried container's top ({top:.2f} m)")
        tilt = RopeModel(self.config, spec).initial_tilt_rad()
        if tilt > MAX_INITIAL_TILT_RAD:
            raise self.fail("container", f"the ropes would start {math.degrees(tilt):.1f} deg off vertical (at most "
                            f"{math.degrees(MAX_INITIAL_TILT_RAD):.1f}): yaw {self.config.container!r} within a few "
                            "degrees of a multiple of 90")

    def external_power(self):
        """The ropes' power [W] on the carried container as a function of a record (RopePower: t [s],
        p_WB (m, 3) [m], R_WB (m, 3, 3), v_WB (m, 3) [m/s] body-origin velocities, w_WB (m, 3) [rad/s]
        of the free containers in scene order, in W), counted up to the run's own release (its
        `until`: after the step at the run's recorded crane_release_time_s, else the scheduled one's)."""
        free = [c for c in self.scenario.containers if not c.fixed]
        i = [c.name for c in free].index(self.config.container)
        return RopePower(RopeModel(self.config, free[i]), i, self.config.release_time, self.scenario.plant.time_step)

    def run_events(self, root_context) -> dict:
        """The run's events for its Trajectory (testbed.simulation.RUN_EVENTS): when the twistlocks
        released [s] (None: held), read from the CraneSystem's state in the diagram's `root_context`."""
        return {"crane_release_time_s": self.crane.release_time_s(root_context)}

    def add_systems(self, assembly) -> list:
        self.crane = CraneSystem(assembly, self.config)
        return [self.crane]

    def summarize(self, tables) -> dict:
        released = self.crane.release_log
        return {"crane_profile_end_s": self.crane.profile_end_s,
                "crane_release_time_s": released[0] if released else None}
