"""A scene in Bullet (pybullet, DIRECT mode): Scenario -> a Bullet world, two contact-parameter sets.

Each container is a Bullet rigid body (maximal coordinates: the btRigidBody a game engine steps)
with one box shape of the type's full size, body frame C at the geometric centre placed at X_WC,
its inertial frame at com_offset (frame C's axes: the principal axes) with the SDF's mass and
solid-box moments about the COM; a `fixed` container is static (mass 0). The quay is a static
box, top face at z = 0 (a scene's ground_surface: at its height), 400 m square like the SDF's
slab. Gravity -GRAVITY z; one Bullet step per plant step h (fixedTimeStep = h, numSubSteps 0).

Engine parameters (setPhysicsEngineParameter, both sets): numSolverIterations 50 (Bullet's
default), enableConeFriction 1 (the two friction impulses clamped to a circle, not a square),
deterministicOverlappingPairs 1 (a run repeats bitwise). Every body: restitution 0 (Drake's
discrete contact is inelastic), rolling and spinning friction 0 (Drake has none), linear and
angular damping 0 (pybullet's default is 0.04: an air drag Drake does not have), sleeping ON
with Bullet's own thresholds (ACTIVATION_STATE_ENABLE_SLEEPING), except for the bodies that
loads.py drives (every free body on a moving deck, the crane's load): a sleeping body ignores
applied forces, and a container at rest on a slowly rolling deck would fall asleep before it
slides.

Friction: Bullet multiplies the two bodies' coefficients, so every body carries sqrt(mu) of its
own mu (the scene's friction.mu, else its mu_dynamic; no `friction` effect: 0): a pair of equal
coefficients gets exactly Drake's mu, unequal ones the geometric mean sqrt(mu_a mu_b) where
Drake takes 2 mu_a mu_b / (mu_a + mu_b). No `contact` effect: every body leaves the collision
filter (no contact at all).

Parameter sets (`params`): "default" = Bullet's rigid contact (ERP/CFM and split impulse as
Bullet sets them); "matched" = each container's contactStiffness k_i [N/m] and contactDamping
c_i [N s/m] per contact point, from Drake's hydroelastic foundation against the rigid quay:
k_i = E_i A_i / (n D_i) (modulus E_i, footprint A_i, foundation depth D_i = half the smallest
side, n = CONTACTS_PER_FACE manifold points), c_i = c / n with Drake's pair damping c (SAP:
(tau_quay + tau_i) k; Hunt-Crossley, the 'similar'/'lagged'/TAMSI approximations: d m_i g, the
container's own weight, as testbed/engines/mujoco/model.py's matched_pair). Bullet turns k, c
into CFM = 1/(h (h k + c)) and ERP = h k / (h k + c) per point, which is the same implicit
Euler spring-damper Drake's discrete solvers step (D = 1 + h^2 k/m + h c/m). Bullet combines
two bodies in series for stiffness (1/(1/k_a + 1/k_b)) and by sum for damping (c_a + c_b): two
equal containers face on face get exactly Drake's E A / (D_a + D_b); unequal footprints (a 20 ft
box on a 40 ft one) a series of the two whole footprints (stiffer than Drake's overlap area);
the damping sum is an approximation (it is the small part of D at 1e9 Pa). The quay keeps
Bullet's default stiffness (effectively rigid in series: a box rests W / (n k_i) deep, tests).
See README.md for what cannot be matched.
"""

from __future__ import annotations

import dataclasses
import json
from importlib import metadata

import numpy as np

from testbed.bodies.boxes import BOX_TYPE
from testbed.bodies.models import GROUND_NAME, solid_box_inertia
from testbed.effects import Role, registry
from testbed.effects.contact import drake_approximation
from testbed.engines.base import UnsupportedSceneError
from testbed.engines.bullet import PARAM_SETS
from testbed.engines.mujoco.model import scene_properties  # Drake's values: the SDF's and effects.contact's
from testbed.errors import OptionalDependencyError, UnknownChoiceError
from testbed.physics import GRAVITY
from testbed.scenario import Scenario

ENGINE_NAME = "bullet"  # what an effect's `translated_by` names when this engine reproduces it
INSTALL = "pip install pybullet==3.2.7"
# PHYSICS effects every engine reproduces in its own contact (contact: the boxes' contact;
# friction: the coefficients above); the others name "bullet" in their `translated_by` (wind,
# crane, deck_motion: their laws applied as external loads, loads.py)
NATIVE_EFFECTS = ("contact", "friction")
CONTACTS_PER_FACE = 4  # Bullet's persistent manifold keeps at most 4 points per body pair
QUAY_HALF_SIZE = (200.0, 200.0, 0.5)  # [m] the static quay box (top face at the ground height)
ENGINE_PARAMETERS = {"numSolverIterations": 50, "enableConeFriction": 1, "deterministicOverlappingPairs": 1,
                     "numSubSteps": 0}
# the matched set's own: no contact slop (Bullet's default lets a resting contact sink about 10 um
# deeper than its spring, measured; Drake has no slop)
MATCHED_PARAMETERS = {"contactSlop": 0.0}


class PybulletMissingError(OptionalDependencyError):
    """pybullet is not installed (no wheel for every Python: 3.12 may lack it); names the install command."""

    def __init__(self):
        Exception.__init__(self, "The Bullet engine (testbed/engines/bullet/) needs the optional package 'pybullet', "
                                 f"which is not installed; install it with: {INSTALL}")


def pybullet_module():
    """The `pybullet` package, or PybulletMissingError with the install command."""
    try:
        import pybullet
    except ImportError:
        raise PybulletMissingError() from None
    return pybullet


def pybullet_version() -> str:
    """The installed pybullet's version ("3.2.7"; pybullet itself has no __version__)."""
    pybullet_module()
    try:
        return metadata.version("pybullet")
    except metadata.PackageNotFoundError:  # importable but not installed as a distribution
        return "unknown"


@dataclasses.dataclass(frozen=True)
class BodyParams:
    """One Bullet body of the scene (a container, or the quay with name GROUND_NAME).

    mass [kg] (0: static), inertia (3,) [kg m^2] principal moments about the COM in C's axes,
    com_C (3,) [m] the COM from C in C, half_size (3,) [m], friction [-] the body's own factor
    (sqrt of its mu), stiffness [N/m] and damping [N s/m] per contact point (nan: Bullet's own),
    sleeping: whether Bullet may deactivate it."""

    name: str
    mass: float
    inertia: tuple
    com_C: tuple
    half_size: tuple
    friction: float
    stiffness: float = float("nan")
    damping: float = float("nan")
    sleeping: bool = True  # False: never deactivated (under the deck's loads, the crane's load: loads.py)


@dataclasses.dataclass
class Translation:
    """A translated scene: body_names (ground first if any, then containers in scene order:
    Drake's plant order), free_names (the containers that move), bodies (BodyParams by
    body_names), time_step [s], params."""

    scenario: Scenario
    params: str
    time_step: float
    body_names: list
    free_names: list
    bodies: list

    def engine_parameters(self) -> dict:
        """setPhysicsEngineParameter's arguments besides fixedTimeStep."""
        return {**ENGINE_PARAMETERS, **(MATCHED_PARAMETERS if self.params == "matched" else {})}

    def describe(self) -> str:
        """The world as JSON text (the run's `bullet_world.json`)."""
        return json.dumps({"scene": self.scenario.name, "params": self.params, "time_step_s": self.time_step,
                           "engine_parameters": self.engine_parameters(), "contacts_per_face": CONTACTS_PER_FACE,
                           "bodies": [dataclasses.asdict(b) for b in self.bodies]}, indent=1)


def check_supported(scenario: Scenario) -> None:
    """Raises UnsupportedSceneError if the scene declares something Bullet cannot reproduce."""
    for i, spec in enumerate(scenario.containers):
        if spec.type == BOX_TYPE and spec.box is not None and spec.box.corner_spheres > 0:
            raise UnsupportedSceneError(scenario.name, f"containers[{i}].box.corner_spheres",
                                        "is not supported by the Bullet engine (extra point-contact spheres; Bullet's "
                                        "box collision already returns the corners)")
    for name in scenario.declared_effects():
        cls = registry()[name]
        if cls.role is Role.PHYSICS and name not in NATIVE_EFFECTS and ENGINE_NAME not in cls.translated_by:
            reason = cls.untranslated_reason or "no Bullet translation of this effect exists yet"
            raise UnsupportedSceneError(scenario.name, f"effects.{name}", f"is not supported by the Bullet engine: {reason}")


def _mu(scenario: Scenario, props: dict) -> float:
    """[-] a body's Coulomb coefficient: 0 without `friction`, friction.mu when set, else its mu_dynamic."""
    friction = scenario.effects.friction
    if friction is None:
        return 0.0
    return float(friction.mu) if friction.mu is not None else float(props["mu_dynamic"])


def matched_contact(scenario: Scenario, spec) -> tuple[float, float]:
    """(k_i [N/m], c_i [N s/m]) per contact point of a container (module docstring)."""
    own, quay = scene_properties(scenario, spec), scene_properties(scenario, None)
    ctype = spec.container_type()
    k = own["hydroelastic_modulus"] * ctype.footprint_area / (0.5 * min(ctype.size))
    contact = scenario.effects.contact
    if drake_approximation(contact.approximation, contact.model) == "sap":
        c = (quay["relaxation_time"] + own["relaxation_time"]) * k
    else:
        c = own["hunt_crossley_dissipation"] * spec.total_mass() * GRAVITY
    return k / CONTACTS_PER_FACE, c / CONTACTS_PER_FACE


def translate(scenario: Scenario, *, params: str = "matched", time_step: float | None = None) -> Translation:
    """The scene's Bullet bodies (no Bullet call yet); raises UnsupportedSceneError,
    UnknownChoiceError for an unknown `params`."""
    if params not in PARAM_SETS:
        raise UnknownChoiceError("Bullet contact-parameter set", params, PARAM_SETS)
    check_supported(scenario)
    h = scenario.plant.time_step if time_step is None else float(time_step)
    bodies, crane = [], scenario.effects.crane
    if scenario.ground:
        mu = _mu(scenario, scene_properties(scenario, None))
        bodies.append(BodyParams(GROUND_NAME, 0.0, (0.0,) * 3, (0.0,) * 3, QUAY_HALF_SIZE, float(np.sqrt(mu))))
    for spec in scenario.containers:
        ctype = spec.container_type()
        moments = (spec.box.inertia if spec.type == BOX_TYPE and spec.box and spec.box.inertia
                   else solid_box_inertia(spec.total_mass(), ctype.size))
        k, c = matched_contact(scenario, spec) if params == "matched" and scenario.effects.contact else (np.nan,) * 2
        driven = scenario.effects.deck_motion is not None or (crane is not None and crane.container == spec.name)
        bodies.append(BodyParams(spec.name, 0.0 if spec.fixed else float(spec.total_mass()),
                                 tuple(float(x) for x in moments), tuple(float(x) for x in spec.com_offset),
                                 tuple(float(x) for x in ctype.half_size),
                                 float(np.sqrt(_mu(scenario, scene_properties(scenario, spec)))), float(k), float(c),
                                 sleeping=not driven))
    return Translation(scenario=scenario, params=params, time_step=h, body_names=[b.name for b in bodies],
                       free_names=[c.name for c in scenario.containers if not c.fixed], bodies=bodies)


def build_world(scenario: Scenario, *, params: str = "matched", time_step: float | None = None):
    """(pybullet module, client id, body ids (by body_names), Translation): a DIRECT-mode world
    at the scene's initial state (poses X_WC, spatial velocities V_WC). The caller disconnects."""
    pb = pybullet_module()
    tr = translate(scenario, params=params, time_step=time_step)
    cid = pb.connect(pb.DIRECT)
    pb.setGravity(0.0, 0.0, -GRAVITY, physicsClientId=cid)
    pb.setPhysicsEngineParameter(fixedTimeStep=tr.time_step, physicsClientId=cid, **tr.engine_parameters())
    specs = {s.name: s for s in scenario.containers}
    contact = scenario.effects.contact is not None
    ids = []
    for body in tr.bodies:
        shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=list(body.half_size), physicsClientId=cid)
        spec = specs.get(body.name) if body.name != GROUND_NAME else None
        if spec is None:  # the quay: its top face at the ground height
            height = 0.0 if scenario.ground_surface is None else float(scenario.ground_surface.height)
            p_WC, R_WC, wxyz = np.array([0.0, 0.0, height - body.half_size[2]]), np.eye(3), (1.0, 0.0, 0.0, 0.0)
        else:
            X = spec.pose()
            p_WC, R_WC, wxyz = X.translation(), X.rotation().matrix(), X.rotation().ToQuaternion().wxyz()
        bid = pb.createMultiBody(baseMass=body.mass, baseCollisionShapeIndex=shape, basePosition=list(p_WC),
                                 baseOrientation=[*wxyz[1:], wxyz[0]], baseInertialFramePosition=list(body.com_C),
                                 useMaximalCoordinates=True, physicsClientId=cid)
        dynamics = dict(lateralFriction=body.friction, restitution=0.0, rollingFriction=0.0, spinningFriction=0.0,
                        linearDamping=0.0, angularDamping=0.0,
                        activationState=(pb.ACTIVATION_STATE_ENABLE_SLEEPING if body.sleeping
                                         else pb.ACTIVATION_STATE_DISABLE_SLEEPING))
        if body.mass > 0:  # with the mass: pybullet 3.2.7 zeroes a rigid body's mass given the moments alone
            dynamics.update(mass=body.mass, localInertiaDiagonal=list(body.inertia))
        if np.isfinite(body.stiffness):
            dynamics.update(contactStiffness=body.stiffness, contactDamping=body.damping)
        pb.changeDynamics(bid, -1, physicsClientId=cid, **dynamics)
        if not contact:
            pb.setCollisionFilterGroupMask(bid, -1, 0, 0, physicsClientId=cid)
        if spec is not None and not spec.fixed:
            V = np.asarray(spec.V_WC, dtype=float)
            w, v_C = V[:3], V[3:]
            v_com = v_C + np.cross(w, R_WC @ np.asarray(body.com_C))  # Bullet's base velocity is its COM's
            pb.resetBaseVelocity(bid, list(v_com), list(w), physicsClientId=cid)
        ids.append(bid)
    return pb, cid, ids, tr
