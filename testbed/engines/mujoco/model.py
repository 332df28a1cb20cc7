"""A scene in MuJoCo: Scenario -> MJCF text -> MjModel, with two contact-parameter sets.

What is translated (Drake side in brackets):
- each container is a body with a free joint (a `fixed` one: no joint, welded), body frame C
  at the geometric centre placed at X_WC, one box geom of the type's full size
  [testbed/containers.py], `<inertial pos=com_offset mass diaginertia>` with the uniform
  solid-box moments about the COM [model_loading.solid_box_inertia, as written into the SDF];
- the quay [sdf/ground/quay_ground.sdf, a 400 m slab, top face z = 0] is a plane at z = 0
  (infinite: no shipped scene leaves the slab); a scene's ground_surface is a plane at its
  height; generic `type: box` entries keep their size, inertia and contact values;
- the initial state is the keyframe "initial": qpos = (p_WC, quaternion wxyz) and
  qvel = (v_WC, R_WC^T w_WC). MuJoCo's free-joint velocity is the linear velocity of the BODY
  FRAME ORIGIN in world and the angular velocity in the BODY frame (checked by finite
  differences, tests/test_mujoco_engine.py); Drake's V_WC = [w_W, v_W] is of the same origin
  C, so no COM shift is needed (`<compiler alignfree="false">` keeps the frame at C);
- contact: one explicit `<pair>` per ground-container and container-container pair (every
  geom has contype = conaffinity = 0), elliptic friction cones, friction = the scene's
  mu_dynamic (Drake's discrete solvers use mu_dynamic only; friction.mu overrides it; no
  `friction` effect: condim 1, frictionless); no `contact` effect: no pairs;
- wind: the force of testbed/effects/wind.py, applied each step through xfrc_applied at C
  (run.py); gravity -GRAVITY z.
- the crane: the same ropes, trolley profile and twistlock release as testbed/effects/crane.py,
  as applied forces (crane.py). Effects whose role is not PHYSICS (recorders,
  observers, viewers: no dynamics) are ignored; a PHYSICS effect whose `translated_by` does
  not name "mujoco" (learned_dynamics) raises UnsupportedSceneError with its
  `untranslated_reason`;
- not translated: contact.hydroelastic_margin (it widens Drake's contact detection only: a
  20 t box rests 16.19 um deep with margin 0, 1e-4 and 1e-3 m alike; MuJoCo's contacts start
  at distance 0), friction's mu_static (Drake's discrete solvers do not use it either).

Contact parameters (`params`):
"default": MuJoCo's defaults, solref (0.02, 1), solimp (0.9, 0.95, 0.001, 0.5, 2), impratio 1.
"matched": per pair, chosen so that MuJoCo's static penetration under load and its one-step
  map of the contact mode equal those of Drake's discrete hydroelastic contact (the scene's
  SDFs with effects.contact's modulus override). Derivation:
  Drake. A compliant box's pressure rises from 0 at its surface to E at the medial axis, so
  an overlap x gives p = E x / D_f with foundation depth D_f = half the smallest side
  (DESIGN.md s.3). Over a footprint overlap A the pair is a spring k = E A / D_f against the
  rigid quay and k = E A / (D_a + D_b) between two boxes (equal pressures, depths in
  series). Dissipation: SAP is linear Kelvin-Voigt, c = tau k, tau = tau_a + tau_b (Drake
  sums the relaxation times); TAMSI/similar/lagged (so 'auto' for hydroelastic) use
  Hunt-Crossley, f = k x (1 + d xdot), i.e. c = d k x = d W at the static load W of the
  upper body. Drake's discrete solvers are implicit Euler in the contact force (x and v at
  the step's end), so a mode of mass m steps with determinant 1/D and trace (2 + h c/m)/D,
  D = 1 + h^2 k/m + h c/m (drake_step_factor; measured on the 20 t box below: AR(2) fits
  of Drake's settling give det 0.601 at 1e9 Pa/'similar' where 1/D = 0.604, and 1/D to 4
  digits with SAP). At 1e9 Pa that numerical damping dominates: Hunt-Crossley's own
  zeta = c/(2 sqrt(k m)) is 0.03 for a 20 t box, the step's det 0.60 (amplitude x0.78 a step).
  MuJoCo. Measured on 4.0.0 (tests check it): with solref = (-S, -B) and a constant
  impedance solimp = (d0, d0, ...), a contact row has R = (1 - d0)/d0 * A_mj with
  A_mj = 1/m_a + 1/m_b (body_invweight0; 0 for the world or a welded body), reference
  acceleration aref = -(B/d0) v - (S/d0) r and force f = (aref - J a)/R. MuJoCo's box-plane
  and face-on-face box-box collisions return n = 4 contacts. For the pair's mode that is a
  semi-implicit Euler step of stiffness k/lam and damping b per unit mass, with an added
  mass lam = 1 + n d0/(1 - d0): det = 1 - h b, trace = 2 - h b - h^2 k/(m lam). Hence
      S = (k / n) (1 - d0) A_mj               (static penetration W/k, whatever d0),
      lam = D, i.e. d0/(1 - d0) = (D - 1)/n   (the trace too),
      B = (1 - 1/D) (1 - d0) lam / (n h)      (det = 1/D; = d0/h when lam = D),
  which is row by row Drake's implicit step: R = 1/(h (h k + c)) per unit of the n rows and
  aref = -v/h - R k r, SAP's regularisation. It is stable at any h (lam >= 1 + (h w)^2).
  d0 is kept >= MATCHED_IMPEDANCE = 0.1 (lam >= 1.44): MuJoCo's box-box routine returns 6 or
  8 contacts instead of 4 for some steps on aligned, equal footprints (two_stack, bridge),
  and with d0 = 0.01 each such step kicked the stack (ground force off by 5% at t = 1-2 s);
  a floored pair keeps det = 1/D but its mode runs slow by sqrt(lam/D).
  PairParams.mass_factor records lam; the run summary its maximum.
  Worked numbers (E = 1e9 Pa, d = 5 s/m, 'similar', h = 1 ms): a 20 t 1CC on the quay:
  A = 14.77 m^2, D_f = 1.219 m, k = 1.21e10 N/m, static penetration W/k = 0.0162 mm,
  w = sqrt(k/m) = 778 rad/s, c = d W = 9.8e5 N s/m, D = 1 + 0.605 + 0.049 = 1.654:
  d0 = 0.141, S = 1.30e5 1/s^2, B = 141 1/s. A 10 t 1CC on a 20 t one: k = E A/(2 D_f) =
  6.06e9 N/m (0.0162 mm under its weight). At the earlier 1e8 Pa with SAP (tau = 2 ms):
  k = 1.21e9 N/m, 0.162 mm, h w = 0.246, D = 1.18 (floored: d0 = 0.1, mode 11% slow).
  impratio = 100 (frictional rows' R 1/100 of the normal rows': near-rigid sticking, where
  SAP also regularises friction); the settling of two_stack (payload 0.8 m off centre) moves
  its top box 4.6 um sideways in MuJoCo, 17.6 um in Drake (an earlier translation that
  kept Hunt-Crossley's continuous zeta, without the step's damping, let the stack rock and
  ratchet it 108 um). The areas are the initial footprint overlaps (the smaller footprint
  for pairs not stacked at t = 0); the matched set always follows Drake's hydroelastic
  parameters, also in a scene whose own contact model is point contact.

Solver path (issue 21): MuJoCo 4.0.0, the newest release the registry serves here (4.0.1 is
not there), factors the Newton solver's Hessian wrongly on its SPARSE path (MuJoCo issue
3767, fixed in 4.0.1); the sparse path is taken under the default jacobian="auto" from
nv >= 60, i.e. 10 free containers. Every engine-comparison scene (the default and full
suites: at most 9 free containers, nv <= 54) ran the dense path: auto and dense gave
bitwise-equal trajectories, Newton took at most 10 iterations a step (cap 100), and no
MuJoCo warning was raised; forcing the sparse path moved sliding scenes by up to 27 mm
(stack_slide_off, matched) and resting ones by < 1e-11 m. So the MJCF sets
jacobian="dense": no shipped figure changes, and a larger scene cannot reach the bug.
"""

from __future__ import annotations

import dataclasses
import functools
import xml.etree.ElementTree as ET

import numpy as np

from testbed.boxes import BOX_TYPE
from testbed.effects import Role, registry
from testbed.effects.contact import drake_approximation
from testbed.engines.base import UnsupportedSceneError
from testbed.engines.mujoco import PARAM_SETS
from testbed.errors import OptionalDependencyError, UnknownChoiceError
from testbed.model_loading import BOX_DEFAULT_PROPERTIES, GROUND_URL, resolve_url, solid_box_inertia
from testbed.physics import GRAVITY
from testbed.scenario import Scenario

GROUND_NAME = "quay_ground"  # the builder's name for the quay body (body_names[0])
CONTACTS_PER_FACE = 4  # MuJoCo's contacts for a face-on-face box pair (measured, tests)
MATCHED_IMPEDANCE = 0.1  # smallest d0 of the matched set (see the module docstring)
MATCHED_IMPRATIO = 100.0
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


@dataclasses.dataclass
class Translation:
    """A translated scene: the MJCF text and what it was made from.

    body_names: ground first (if any), then containers in scene order (Drake's plant order);
    free_names: the containers that move; pairs: the contact pairs and their parameters.
    """

    scenario: Scenario
    mjcf: str
    params: str
    time_step: float  # [s]
    body_names: list
    free_names: list
    pairs: list


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
    over model_loading.BOX_DEFAULT_PROPERTIES); spec None = the ground (`ground`: the
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


def contact_pairs(scenario: Scenario, params: str, h: float) -> list[PairParams]:
    """Every pair that can touch, with its parameters (see the module docstring)."""
    if scenario.effects.contact is None:
        return []
    specs = scenario.containers
    offset = 1 if scenario.ground else 0
    candidates = [(None, j) for j in range(len(specs))] if scenario.ground else []
    candidates += [(i, j) for i in range(len(specs)) for j in range(i + 1, len(specs))]
    out = []
    for i, j in candidates:
        spec_a = None if i is None else specs[i]
        spec_b = specs[j]
        if (spec_a is None or spec_a.fixed) and spec_b.fixed:
            continue  # nothing moves
        a = 0 if i is None else i + offset
        mu = pair_friction(scenario, spec_a, spec_b)
        if params == "default":
            out.append(PairParams(a, j + offset, mu, DEFAULT_SOLREF, DEFAULT_SOLIMP))
        else:
            k, c, solref, solimp, slowdown = matched_pair(scenario, spec_a, spec_b, h)
            out.append(PairParams(a, j + offset, mu, solref, solimp, k, c, slowdown))
    return out


def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def scenario_to_mjcf(scenario: Scenario, *, params: str = "matched", time_step: float | None = None) -> Translation:
    """The MJCF text of a scene (see the module docstring); raises UnsupportedSceneError,
    UnknownChoiceError for an unknown `params`."""
    if params not in PARAM_SETS:
        raise UnknownChoiceError("MuJoCo contact-parameter set", params, PARAM_SETS)
    check_supported(scenario)
    h = scenario.plant.time_step if time_step is None else float(time_step)
    body_names = ([GROUND_NAME] if scenario.ground else []) + [c.name for c in scenario.containers]
    pairs = contact_pairs(scenario, params, h)
    impratio = MATCHED_IMPRATIO if params == "matched" else 1.0
    bodies, qpos, qvel = [], [], []
    for spec in scenario.containers:
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
            f'      <geom name="{spec.name}" type="box" size="{_fmt(ctype.half_size)}" contype="0" conaffinity="0" '
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
        f'  <option timestep="{h!r}" gravity="0 0 {-GRAVITY!r}" cone="elliptic" impratio="{impratio!r}" jacobian="dense"/>\n'
        f'  <worldbody>\n{ground}' + "\n".join(bodies) + "\n  </worldbody>\n"
        + ("  <contact>\n" + "\n".join(pair_lines) + "\n  </contact>\n" if pair_lines else "")
        + (f"  <keyframe>\n{key}  </keyframe>\n" if key else "")
        + "</mujoco>\n")
    return Translation(scenario=scenario, mjcf=mjcf, params=params, time_step=h, body_names=body_names,
                       free_names=[c.name for c in scenario.containers if not c.fixed], pairs=pairs)


def build_model(scenario: Scenario, *, params: str = "matched", time_step: float | None = None):
    """(MjModel, MjData at the initial state, Translation)."""
    mj = mujoco_module()
    translation = scenario_to_mjcf(scenario, params=params, time_step=time_step)
    model = mj.MjModel.from_xml_string(translation.mjcf)
    data = mj.MjData(model)
    if model.nkey:
        mj.mj_resetDataKeyframe(model, data, 0)
    mj.mj_forward(model, data)
    return model, data, translation
