"""A scene in MuJoCo: Scenario -> MJCF text -> MjModel, with two contact-parameter sets.

Each container is a free body (welded when `fixed`) with one box geom, body frame C at the
geometric centre, the SDF's mass and solid-box inertia; the quay is a plane at z = 0 (a
scene's ground_surface a plane at its height); contact: one explicit `<pair>` per
ground-container pair and per container pair that can meet (contact_pairs: within NEIGHBOUR_REACH
at the start, in one column, or with a container that starts moving), every other container pair
found by MuJoCo's own broad phase (contype = conaffinity = 1) with each container geom's own
parameters mixed (geom_parameters); elliptic cones and the scene's mu_dynamic;
wind and the crane are applied forces (run.py, crane.py). Effects whose role is not PHYSICS
are ignored; a PHYSICS effect MuJoCo cannot translate (learned_dynamics) raises
UnsupportedSceneError.

Parameter sets (`params`): "default" (MuJoCo's own solref/solimp) and "matched": per pair,
solref/solimp chosen so that MuJoCo's static penetration under load and its one-step map
of the contact mode equal Drake's discrete hydroelastic contact (see README.md).

Assumptions: Drake's compliant box has foundation depth half its smallest side; box-plane
and face-on-face box-box contacts give 4 MuJoCo contacts (impedance floored at
MATCHED_IMPEDANCE = 0.1 because some steps give 6 or 8); the pair areas are the initial
footprint overlaps; not translated: hydroelastic_margin and mu_static (Drake's discrete
solvers ignore mu_static too); Newton with jacobian="auto" (dense below nv = 60, sparse above:
measured, README.md "Solver path": the sparse path solves the shipped scenes as the dense one
does, on 4.0.0 and 3.17.0 alike, and is 3.7x faster on the 96-container yard).

README.md beside this file holds the translation rules in full, the derivation of the
matched parameters with worked numbers, and the measurements behind each choice.
"""

from __future__ import annotations

import dataclasses
import functools
import xml.etree.ElementTree as ET

import numpy as np

from testbed.bodies.boxes import BOX_TYPE
from testbed.bodies.models import BOX_DEFAULT_PROPERTIES, GROUND_NAME, GROUND_URL, resolve_url, solid_box_inertia
from testbed.effects import Role, registry
from testbed.effects.contact import drake_approximation
from testbed.engines.base import UnsupportedSceneError
from testbed.engines.mujoco import PARAM_SETS
from testbed.errors import OptionalDependencyError, UnknownChoiceError
from testbed.physics import GRAVITY
from testbed.scenario import Scenario

NEIGHBOUR_REACH = 0.5  # [m] container pairs whose initial world boxes are this close get an explicit <pair>
CONTACTS_PER_FACE = 4  # MuJoCo's contacts for a face-on-face box pair (measured, tests)
MATCHED_IMPEDANCE = 0.1  # smallest d0 of the matched set (see the module docstring)
MATCHED_IMPRATIO = 100.0
JACOBIAN = "auto"  # dense below nv = 60, sparse above (README.md, "Solver path": measured)
SOLVER = "Newton"  # CG and PGS measured slower and less converged on the 96-container yard (README.md)
DEFAULT_SOLREF = (0.02, 1.0)  # MuJoCo's defaults, written out for the record
DEFAULT_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)
ENGINE_NAME = "mujoco"  # what an effect's `translated_by` names when this engine reproduces it


def mujoco_module():
    """The `mujoco` package, or OptionalDependencyError with the install command."""
    try:
        import mujoco
    except ImportError:
        raise OptionalDependencyError("mujoco", "The MuJoCo engine (testbed/engines/mujoco/)", "study") from None
    return mujoco


@dataclasses.dataclass(frozen=True)
class PairParams:
    """Contact parameters of one body pair, named by body_names indices a < b."""

    a: int
    b: int
    friction: float  # [-] Coulomb coefficient (0 = frictionless, condim 1)
    solref: tuple  # MuJoCo solref (2,)
    solimp: tuple  # MuJoCo solimp (5,)
    stiffness: float = float("nan")  # [N/m] Drake's hydroelastic pair stiffness k (matched only)
    damping: float = float("nan")  # [N s/m] Drake's pair damping c (matched only)
    mass_factor: float = float("nan")  # MuJoCo's added mass: the pair mode's mass / m_eff (matched only)
    explicit: bool = True  # an MJCF <pair>; False: a geom's own parameters (geom_parameters)


@dataclasses.dataclass
class Translation:
    """A translated scene: the MJCF text and what it was made from.

    body_names: ground first (if any), then containers in scene order (Drake's plant order);
    free_names: the containers that move; pairs: the explicit contact pairs and their
    parameters; geoms: per container (scene order) the parameters its geom carries into the
    pairs MuJoCo's broad phase finds (a, b = its body index, itself), None without contact.
    """

    scenario: Scenario
    mjcf: str
    params: str
    time_step: float  # [s]
    body_names: list
    free_names: list
    pairs: list
    geoms: list = dataclasses.field(default_factory=list)


def check_supported(scenario: Scenario) -> None:
    """Raises UnsupportedSceneError if the scene declares an effect MuJoCo cannot reproduce."""
    for i, spec in enumerate(scenario.containers):
        if spec.type == BOX_TYPE and spec.box is not None and spec.box.corner_spheres > 0:
            raise UnsupportedSceneError(
                scenario.name, f"containers[{i}].box.corner_spheres", "is not supported by the MuJoCo engine (extra "
                "point-contact spheres; MuJoCo's box collision already returns the corners)")
    for name in scenario.declared_effects():
        cls = registry()[name]
        if cls.role is Role.PHYSICS and ENGINE_NAME not in cls.translated_by:  # the others have no dynamics
            reason = cls.untranslated_reason or "no MuJoCo translation of this effect exists yet"
            raise UnsupportedSceneError(scenario.name, f"effects.{name}", f"is not supported by the MuJoCo engine: {reason}")


@functools.lru_cache(maxsize=None)
def proximity(url: str) -> dict:
    """drake:proximity_properties of an SDF model's collision, {tag: float} (flags omitted)."""
    root = ET.parse(resolve_url(url)).getroot()
    props = root.find(".//collision/{http://drake.mit.edu}proximity_properties")
    out = {}
    for node in props:
        tag = node.tag.split("}")[-1]
        if node.text and node.text.strip():
            out[tag] = float(node.text)
    return out


def properties(spec, ground=None) -> dict:
    """Drake proximity values of a container (its SDF) or a generic box (its `box.contact`
    over testbed.bodies.models.BOX_DEFAULT_PROPERTIES); spec None = the ground (`ground`: the
    scene's ground_surface, None = the quay slab's SDF)."""
    if spec is None:
        return proximity(GROUND_URL) if ground is None else dict(BOX_DEFAULT_PROPERTIES, **ground.contact.given())
    if spec.type == BOX_TYPE:
        return dict(BOX_DEFAULT_PROPERTIES, **spec.box.contact.given()) if spec.box else dict(BOX_DEFAULT_PROPERTIES)
    return proximity(spec.container_type().model_url)


CONTACT_OVERRIDES = ("hydroelastic_modulus", "hydroelastic_margin")  # contact effect fields set on every geometry


def scene_properties(scenario: Scenario, spec) -> dict:
    """properties() of a body (spec None = the ground) with the scene's `effects.contact`
    overrides applied: hydroelastic_modulus [Pa] and hydroelastic_margin [m] replace the
    SDF's values on every geometry when set, as ContactEffect.plan does for Drake."""
    values = dict(properties(spec, scenario.ground_surface) if spec is None else properties(spec))
    contact = scenario.effects.contact
    for name in CONTACT_OVERRIDES:
        value = None if contact is None else getattr(contact, name)
        if value is not None:
            values[name] = float(value)
    return values


def pair_friction(scenario: Scenario, spec_a, spec_b) -> float:
    """The pair's Coulomb coefficient: 0 without `friction`, friction.mu when set, else Drake's
    combination 2 a b / (a + b) of the two mu_dynamic values (discrete solvers use mu_dynamic)."""
    friction = scenario.effects.friction
    if friction is None:
        return 0.0
    if friction.mu is not None:
        return float(friction.mu)
    mu_a, mu_b = properties(spec_a, scenario.ground_surface)["mu_dynamic"], properties(spec_b)["mu_dynamic"]
    return 0.0 if mu_a + mu_b == 0 else 2.0 * mu_a * mu_b / (mu_a + mu_b)


def _footprint_extent(spec) -> np.ndarray:
    """(2, 2) [[xmin, xmax], [ymin, ymax]] of a container's rotated footprint's bounding box [m]."""
    X = spec.pose()
    R = X.rotation().matrix()
    half = spec.container_type().half_size
    reach = np.abs(R[:2, :]) @ half  # (2,) half extents of the world AABB in x, y
    p = X.translation()[:2]
    return np.column_stack([p - reach, p + reach])


def overlap_area(spec_a, spec_b) -> float:
    """Footprint overlap [m^2] of two containers at their initial poses; the smaller
    footprint when they do not overlap (a pair that meets later, e.g. a drop)."""
    ea, eb = _footprint_extent(spec_a), _footprint_extent(spec_b)
    sides = np.minimum(ea[:, 1], eb[:, 1]) - np.maximum(ea[:, 0], eb[:, 0])
    if np.all(sides > 0):
        return float(sides[0] * sides[1])
    return min(s.container_type().footprint_area for s in (spec_a, spec_b))


def _foundation_depth(spec) -> float:
    """[m] half the smallest side (Drake's medial-axis pressure field, DESIGN.md s.3)."""
    return 0.5 * min(spec.container_type().size)


def matched_pair(scenario: Scenario, spec_a, spec_b, h: float) -> tuple[float, float, tuple, tuple, float]:
    """(k [N/m], c [N s/m], solref, solimp, mass factor) of a pair at time step h [s];
    spec_a None = the rigid quay."""
    sdf_a, sdf_b = scene_properties(scenario, spec_a), scene_properties(scenario, spec_b)
    if spec_a is None:  # the quay is rigid
        k = sdf_b["hydroelastic_modulus"] * spec_b.container_type().footprint_area / _foundation_depth(spec_b)
    else:  # equal pressures: the two foundations in series
        k = overlap_area(spec_a, spec_b) / (_foundation_depth(spec_a) / sdf_a["hydroelastic_modulus"]
                                            + _foundation_depth(spec_b) / sdf_b["hydroelastic_modulus"])
    approximation = drake_approximation(scenario.effects.contact.approximation, scenario.effects.contact.model)
    if approximation == "sap":
        c = (sdf_a["relaxation_time"] + sdf_b["relaxation_time"]) * k
    else:  # Hunt-Crossley at the static load of the upper body (the heavier side's weight is ignored)
        upper = spec_b if spec_a is None or spec_b.pose().translation()[2] >= spec_a.pose().translation()[2] else spec_a
        d_hc = sdf_b["hunt_crossley_dissipation"]  # the compliant side's (the quay's is the same, sdf/README.md)
        c = d_hc * upper.total_mass() * GRAVITY
    masses = [s.total_mass() for s in (spec_a, spec_b) if s is not None and not s.fixed]
    inv_mass = sum(1.0 / m for m in masses)  # A_mj [1/kg]
    m_eff = 1.0 / inv_mass  # [kg] the pair's reduced mass (the body's mass against the quay)
    D = drake_step_factor(k, c, m_eff, h)
    x = max((D - 1.0) / CONTACTS_PER_FACE, MATCHED_IMPEDANCE / (1.0 - MATCHED_IMPEDANCE))  # d0 / (1 - d0)
    d0 = x / (1.0 + x)
    mass_factor = 1.0 + CONTACTS_PER_FACE * x  # lam: the pair mode's mass over m_eff (= D unless floored)
    S = k / CONTACTS_PER_FACE * (1.0 - d0) * inv_mass  # static penetration W/k
    # per-step decay of the mode, det = 1 - h b_mj, equal to Drake's 1/D; b_mj = n B / ((1 - d0) lam)
    B = (1.0 - 1.0 / D) * (1.0 - d0) * mass_factor / (CONTACTS_PER_FACE * h)
    return k, c, (-S, -B), (d0, d0, 0.001, 0.5, 2.0), mass_factor


def drake_step_factor(k: float, c: float, m: float, h: float) -> float:
    """D = 1 + h^2 k/m + h c/m [-]: Drake's discrete contact (SAP and its convex
    approximations) is implicit Euler for a contact spring k [N/m] and damper c [N s/m] on a
    mass m [kg] at step h [s], whose one-step map has determinant 1/D and trace (2 + h c/m)/D."""
    return 1.0 + h * h * k / m + h * c / m


def _params(scenario: Scenario, params: str, spec_a, spec_b, a: int, b: int, h: float, explicit: bool = True) -> PairParams:
    """One pair's PairParams (spec_a None = the ground; a, b their body_names indices)."""
    mu = pair_friction(scenario, spec_a, spec_b)
    if params == "default":
        return PairParams(a, b, mu, DEFAULT_SOLREF, DEFAULT_SOLIMP, explicit=explicit)
    k, c, solref, solimp, mass_factor = matched_pair(scenario, spec_a, spec_b, h)
    return PairParams(a, b, mu, solref, solimp, k, c, mass_factor, explicit)


def _world_boxes(specs) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) (m, 3) [m]: the containers' world axis-aligned boxes at their initial poses."""
    centre, reach = [], []
    for spec in specs:
        X = spec.pose()
        centre.append(X.translation())
        reach.append(np.abs(X.rotation().matrix()) @ spec.container_type().half_size)
    centre, reach = np.array(centre).reshape(-1, 3), np.array(reach).reshape(-1, 3)
    return centre - reach, centre + reach


def can_meet(scenario: Scenario) -> np.ndarray:
    """(m, m) bool: the container pairs that get an explicit <pair> (matched parameters exact):
    one container free, and their initial world boxes within NEIGHBOUR_REACH [m] of each other,
    or their footprints so close (one column: a drop, a stack), or one of them moving at the
    start (a nonzero initial velocity, the crane's load). Every other pair is left to MuJoCo's
    broad phase with the geoms' mixed parameters (geom_parameters)."""
    specs = scenario.containers
    lo, hi = _world_boxes(specs)
    gap = np.maximum(lo[:, None, :] - hi[None, :, :], lo[None, :, :] - hi[:, None, :])  # (m, m, 3) [m]
    near = np.all(gap < NEIGHBOUR_REACH, axis=2) | np.all(gap[..., :2] < NEIGHBOUR_REACH, axis=2)
    crane = scenario.effects.crane
    moving = np.array([np.any(np.asarray(s.V_WC, dtype=float) != 0) or (crane is not None and crane.container == s.name)
                       for s in specs], dtype=bool)
    free = np.array([not s.fixed for s in specs], dtype=bool)
    out = (near | moving[:, None] | moving[None, :]) & (free[:, None] | free[None, :])
    np.fill_diagonal(out, False)
    return out


def contact_pairs(scenario: Scenario, params: str, h: float, container_contact: bool = True) -> list[PairParams]:
    """The explicit pairs with their parameters: every ground-container pair, and the
    container pairs that can meet (can_meet; none when not `container_contact`); see the
    module docstring."""
    if scenario.effects.contact is None:
        return []
    specs = scenario.containers
    offset = 1 if scenario.ground else 0
    out = [_params(scenario, params, None, spec, 0, j + offset, h) for j, spec in enumerate(specs)
           if scenario.ground and not spec.fixed]
    meet = can_meet(scenario) if container_contact else np.zeros((len(specs), len(specs)), dtype=bool)
    for i, j in zip(*np.nonzero(np.triu(meet, 1))):
        out.append(_params(scenario, params, specs[i], specs[j], int(i) + offset, int(j) + offset, h))
    return out


def geom_parameters(scenario: Scenario, params: str, h: float, container_contact: bool = True) -> list:
    """Per container (scene order) the parameters its geom carries for the pairs MuJoCo's broad
    phase finds (those contact_pairs does not list): its matched pair with a copy of itself
    face on face (a, b its body index), so that two equal containers stacked get exactly their
    pair's parameters from MuJoCo's mixing (solref, solimp: the average; friction: the larger);
    unequal ones the average of theirs (an approximation, for pairs that meet only after others
    moved: a toppling stack). A fixed container: MuJoCo's defaults. None without contact or
    `container_contact` (the geoms stay out of the broad phase)."""
    if scenario.effects.contact is None or not container_contact:
        return [None] * len(scenario.containers)
    offset = 1 if scenario.ground else 0
    out = []
    for j, spec in enumerate(scenario.containers):
        if spec.fixed:
            out.append(PairParams(j + offset, j + offset, pair_friction(scenario, spec, spec), DEFAULT_SOLREF,
                                  DEFAULT_SOLIMP, explicit=False))
        else:
            out.append(_params(scenario, params, spec, spec, j + offset, j + offset, h, explicit=False))
    return out


def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def scenario_to_mjcf(scenario: Scenario, *, params: str = "matched", time_step: float | None = None,
                     container_contact: bool = True) -> Translation:
    """The MJCF text of a scene (see the module docstring); raises UnsupportedSceneError,
    UnknownChoiceError for an unknown `params`. container_contact False: MuJoCo's contact
    for the ground-container pairs only (the learned loop hosted in MuJoCo decides the rest)."""
    if params not in PARAM_SETS:
        raise UnknownChoiceError("MuJoCo contact-parameter set", params, PARAM_SETS)
    check_supported(scenario)
    h = scenario.plant.time_step if time_step is None else float(time_step)
    body_names = ([GROUND_NAME] if scenario.ground else []) + [c.name for c in scenario.containers]
    pairs = contact_pairs(scenario, params, h, container_contact)
    geoms = geom_parameters(scenario, params, h, container_contact)
    impratio = MATCHED_IMPRATIO if params == "matched" else 1.0
    bodies, qpos, qvel = [], [], []
    for spec, own in zip(scenario.containers, geoms):
        ctype = spec.container_type()
        moments = (spec.box.inertia if spec.type == BOX_TYPE and spec.box and spec.box.inertia
                   else solid_box_inertia(spec.total_mass(), ctype.size))
        X = spec.pose()
        p, quat = X.translation(), X.rotation().ToQuaternion().wxyz()
        mass = spec.total_mass()
        joint = "" if spec.fixed else "<freejoint/>"
        bodies.append(
            f'    <body name="{spec.name}" pos="{_fmt(p)}" quat="{_fmt(quat)}">{joint}\n'
            f'      <inertial pos="{_fmt(spec.com_offset)}" mass="{float(mass)!r}" '
            f'diaginertia="{_fmt(moments)}"/>\n'
            f'      <geom name="{spec.name}" type="box" size="{_fmt(ctype.half_size)}" {_geom_contact(own)}'
            f'rgba="{_fmt(ctype.rgba)}"/>\n    </body>')
        if not spec.fixed:
            V = np.asarray(spec.V_WC, dtype=float)
            qpos += [*p, *quat]
            qvel += [*V[3:], *(X.rotation().matrix().T @ V[:3])]  # v of C in W; w in C
    height = 0.0 if scenario.ground_surface is None else float(scenario.ground_surface.height)
    ground = (f'    <geom name="{GROUND_NAME}" type="plane" pos="0 0 {height!r}" size="200 200 1" contype="0" '
              'conaffinity="0"/>\n' if scenario.ground else "")
    pair_lines = []
    for pair in pairs:
        condim = 3 if pair.friction > 0 else 1
        pair_lines.append(
            f'    <pair geom1="{body_names[pair.a]}" geom2="{body_names[pair.b]}" condim="{condim}" '
            f'friction="{pair.friction!r} {pair.friction!r} 0.005 0.0001 0.0001" '
            f'solref="{_fmt(pair.solref)}" solimp="{_fmt(pair.solimp)}"/>')
    key = f'    <key name="initial" qpos="{_fmt(qpos)}" qvel="{_fmt(qvel)}"/>\n' if qpos else ""
    mjcf = (
        f'<mujoco model="{scenario.name}">\n'
        '  <compiler angle="radian" alignfree="false"/>\n'
        f'  <option timestep="{h!r}" gravity="0 0 {-GRAVITY!r}" cone="elliptic" impratio="{impratio!r}" '
        f'jacobian="{JACOBIAN}" solver="{SOLVER}"/>\n'
        f'  <worldbody>\n{ground}' + "\n".join(bodies) + "\n  </worldbody>\n"
        + ("  <contact>\n" + "\n".join(pair_lines) + "\n  </contact>\n" if pair_lines else "")
        + (f"  <keyframe>\n{key}  </keyframe>\n" if key else "")
        + "</mujoco>\n")
    return Translation(scenario=scenario, mjcf=mjcf, params=params, time_step=h, body_names=body_names,
                       free_names=[c.name for c in scenario.containers if not c.fixed], pairs=pairs, geoms=geoms)


def _geom_contact(own: PairParams | None) -> str:
    """A container geom's contact attributes: in MuJoCo's broad phase with its own parameters
    (geom_parameters), or out of it (contype = conaffinity = 0) without a contact effect."""
    if own is None:
        return 'contype="0" conaffinity="0" '
    condim = 3 if own.friction > 0 else 1
    return (f'contype="1" conaffinity="1" condim="{condim}" friction="{own.friction!r} 0.005 0.0001" '
            f'solref="{_fmt(own.solref)}" solimp="{_fmt(own.solimp)}" ')


def build_model(scenario: Scenario, *, params: str = "matched", time_step: float | None = None,
                container_contact: bool = True):
    """(MjModel, MjData at the initial state, Translation); container_contact as scenario_to_mjcf."""
    mj = mujoco_module()
    translation = scenario_to_mjcf(scenario, params=params, time_step=time_step, container_contact=container_contact)
    model = mj.MjModel.from_xml_string(translation.mjcf)
    data = mj.MjData(model)
    if model.nkey:
        mj.mj_resetDataKeyframe(model, data, 0)
    mj.mj_forward(model, data)
    return model, data, translation
