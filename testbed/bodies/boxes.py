"""Generic rigid boxes and flat grounds in a scene: their typed specs and checks.

A scene's container list may hold `type: box` entries with a `box:` block, and the scene may
replace the quay slab by `ground_surface:` (a slab or a half-space at a given height):

    containers:
    - name: cube
      type: box
      mass: 0.37                      # or box.density [kg/m^3]
      X_WC: {translation: [0, 0, 0.06]}
      box:
        size: [0.1048, 0.1048, 0.1048]   # full extents [m]
        inertia: [8.1e-4, 8.1e-4, 8.1e-4]  # principal moments [kg m^2]; omitted = uniform
        contact: {mu_dynamic: 0.19, point_contact_stiffness: 1.0e6}
    ground_surface: {shape: halfspace, height: -0.0011, contact: {mu_dynamic: 0.19}}

The SDF text is written by testbed.bodies.models.box_sdf / flat_ground_sdf with the same
drake:proximity_properties tags as sdf/; missing contact values are the containers'.
"""


import dataclasses
import math
import typing

from testbed.errors import ScenarioError

BOX_TYPE = "box"


@dataclasses.dataclass
class ContactProperties:
    """drake:proximity_properties of a generic box or ground (Drake's tag names and units);
    None = the containers' value (testbed.bodies.models.BOX_DEFAULT_PROPERTIES). Drake
    combines the two geometries' values of a pair (friction 2ab/(a+b), stiffness in series)."""

    mu_dynamic: typing.Optional[float] = None
    mu_static: typing.Optional[float] = None
    point_contact_stiffness: typing.Optional[float] = None  # [N/m]
    hydroelastic_modulus: typing.Optional[float] = None  # [Pa] (compliant boxes only)
    hydroelastic_margin: typing.Optional[float] = None  # [m] (compliant boxes only)
    hunt_crossley_dissipation: typing.Optional[float] = None  # [s/m]
    relaxation_time: typing.Optional[float] = None  # [s] (SAP)

    def given(self) -> dict[str, float]:
        """The values that are set, by tag name."""
        return {k: float(v) for k, v in dataclasses.asdict(self).items() if v is not None}


@dataclasses.dataclass
class BoxSpec:
    """A generic rigid box (`type: box`): body frame B at the geometric centre."""

    size: typing.List[float] = dataclasses.field(default_factory=lambda: [1.0, 1.0, 1.0])  # (3,) full extents [m]
    density: typing.Optional[float] = None  # [kg/m^3] uniform; used when the entry's mass is None
    # (3,) principal moments about the COM along B [kg m^2]; [] = a uniform solid box
    inertia: typing.List[float] = dataclasses.field(default_factory=list)
    # [m] > 0: the collision geometry is 8 spheres of this radius inside the corners instead
    # of the box (a box with rounded corners: exact against a flat ground, where one contact
    # per touching corner replaces point contact's single deepest corner; other bodies touch
    # it only at its corners; no hydroelastic geometry). 0 = the box itself.
    corner_spheres: float = 0.0
    rgba: typing.List[float] = dataclasses.field(default_factory=lambda: [0.6, 0.6, 0.6, 1.0])
    contact: ContactProperties = dataclasses.field(default_factory=ContactProperties)


@dataclasses.dataclass
class GroundSpec:
    """A flat ground whose top face is at z = height (replaces the shipped quay slab)."""

    shape: str = "slab"  # 'slab' (a static box) or 'halfspace'
    height: float = 0.0  # [m] z of the top face in W
    size: typing.List[float] = dataclasses.field(default_factory=lambda: [400.0, 400.0, 2.0])  # slab extents [m]
    contact: ContactProperties = dataclasses.field(default_factory=ContactProperties)



def _positive_vector(values, n: int, source, field: str, unit: str) -> None:
    if values is None or len(values) != n or not all(math.isfinite(v) and v > 0 for v in values):
        raise ScenarioError(source, field, f"expected {n} positive finite numbers [{unit}], got {values}")


def _validate_contact(contact: ContactProperties, source, where: str) -> None:
    for key, value in contact.given().items():
        positive = key in ("point_contact_stiffness", "hydroelastic_modulus")
        if not math.isfinite(value) or value < 0 or (positive and value == 0):
            what = "a positive" if positive else "a non-negative"
            raise ScenarioError(source, f"{where}.contact.{key}", f"expected {what} finite number, got {value}")


def validate_box(c: object, where: str, source) -> None:
    """Checks a `type: box` entry's `box:` block (and that other types have none)."""
    if c.type != BOX_TYPE:
        if c.box is not None:
            raise ScenarioError(source, f"{where}.box", f"only a 'type: {BOX_TYPE}' entry takes a box block (this one is {c.type!r})")
        return
    if c.box is None:
        raise ScenarioError(source, f"{where}.box", "a 'type: box' entry needs a box block: {size: [x, y, z], density or mass, ...}")
    box = c.box
    _positive_vector(box.size, 3, source, f"{where}.box.size", "m")
    if c.mass is None and box.density is None:
        raise ScenarioError(source, f"{where}.mass", "a box needs its mass [kg] or box.density [kg/m^3]")
    if c.mass is not None and box.density is not None:
        raise ScenarioError(source, f"{where}.box.density", "give either mass or box.density, not both")
    if box.density is not None and not (math.isfinite(box.density) and box.density > 0):
        raise ScenarioError(source, f"{where}.box.density", f"expected a positive density [kg/m^3], got {box.density}")
    if box.inertia:
        _positive_vector(box.inertia, 3, source, f"{where}.box.inertia", "kg m^2")
        a, b, cc = sorted(box.inertia)
        if a + b < cc * (1 - 1e-9):  # a rigid body's principal moments obey the triangle inequality
            raise ScenarioError(source, f"{where}.box.inertia", f"principal moments {box.inertia} violate the triangle inequality (no rigid body has them)")
    if not (math.isfinite(box.corner_spheres) and 0 <= box.corner_spheres < 0.5 * min(box.size)):
        raise ScenarioError(source, f"{where}.box.corner_spheres", f"expected a radius [m] in [0, half the smallest side), got {box.corner_spheres}")
    if len(box.rgba) != 4 or not all(0 <= v <= 1 for v in box.rgba):
        raise ScenarioError(source, f"{where}.box.rgba", f"expected 4 numbers in [0, 1], got {box.rgba}")
    _validate_contact(box.contact, source, f"{where}.box")


def validate_ground(ground: GroundSpec, source) -> None:
    if ground.shape not in ("slab", "halfspace"):
        raise ScenarioError(source, "ground_surface.shape", f"unknown ground shape {ground.shape!r}; expected one of: slab, halfspace")
    if not math.isfinite(ground.height):
        raise ScenarioError(source, "ground_surface.height", f"expected a finite height [m], got {ground.height}")
    _positive_vector(ground.size, 3, source, "ground_surface.size", "m")
    _validate_contact(ground.contact, source, "ground_surface")
    if ground.contact.hydroelastic_modulus is not None or ground.contact.hydroelastic_margin is not None:
        raise ScenarioError(source, "ground_surface.contact", "the ground is rigid: hydroelastic_modulus and hydroelastic_margin do not apply")
