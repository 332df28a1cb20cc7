"""Finds the SDF models and loads them into a MultibodyPlant with scene parameters.

The SDF files in sdf/ hold geometry and contact parameters; a scene supplies mass,
centre-of-mass offset and name. Those are written into the SDF text (ElementTree)
before Drake parses it, so the plant's *default* context already has the scene's
mass: any context made later is right, not only the simulator's.
"""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from testbed.bodies.boxes import BOX_TYPE
from testbed.bodies.containers import CONTAINER_TYPES, HYDROELASTIC_MODULUS, ContainerType
from testbed.errors import ModelError

SDF_DIR = Path(__file__).resolve().parents[2] / "sdf"  # the repo's sdf/ folder
PACKAGE_NAME = "testbed"
GROUND_NAME = "quay_ground"  # the ground's body and model name in every scene (body_names[0] when a scene has one)
GROUND_URL = "package://testbed/ground/quay_ground.sdf"
_DRAKE_NS = "http://drake.mit.edu"


def resolve_url(url: str) -> Path:
    """Maps 'package://testbed/<rel>' (or a plain path) to a file, or raises ModelError."""
    prefix = f"package://{PACKAGE_NAME}/"
    path = SDF_DIR / url[len(prefix):] if url.startswith(prefix) else Path(url)
    if not path.is_file():
        raise ModelError(f"model file {url!r} not found (looked for {path})")
    return path


@functools.lru_cache(maxsize=None)
def _read_model(url: str) -> str:
    return resolve_url(url).read_text()


def solid_box_inertia(mass: float, size) -> np.ndarray:
    """(3,) principal moments [kg m^2] of a uniform solid box of full extents `size` [m]."""
    lx, ly, lz = size
    return mass / 12.0 * np.array([ly**2 + lz**2, lx**2 + lz**2, lx**2 + ly**2])


def container_sdf(
    ctype: ContainerType,
    *,
    name: str,
    mass: float,
    p_CoCcm_C=(0.0, 0.0, 0.0),
    collision: bool = True,
    properties: dict[str, float] | None = None,
) -> str:
    """SDF text of one container with the scene's parameters applied.

    mass [kg]: total (tare + payload), modelled as a uniform solid box about its COM.
    p_CoCcm_C (3,): COM offset from the geometric centre, in the container frame [m].
    collision False removes the collision element (no `contact` effect);
    properties: drake:proximity_properties values to replace, e.g.
      {'mu_dynamic': 0.0, 'mu_static': 0.0} for frictionless contact.
    """
    root = ET.fromstring(_read_model(ctype.model_url))
    model = root.find("model")
    model.set("name", name)
    link = model.find("link")
    for element in link.iter("box"):  # the catalogue's size (a generic box's replaces its template's)
        element.find("size").text = " ".join(repr(float(v)) for v in ctype.size)
    inertial = link.find("inertial")
    inertial.find("mass").text = repr(float(mass))
    inertial.find("pose").text = " ".join(repr(float(x)) for x in p_CoCcm_C) + " 0 0 0"
    moments = solid_box_inertia(mass, ctype.size)
    inertia = inertial.find("inertia")
    for tag, value in zip(("ixx", "iyy", "izz"), moments):
        inertia.find(tag).text = repr(float(value))
    _apply_contact_switches(link, collision=collision, properties=properties)
    return ET.tostring(root, encoding="unicode")


# --- generic boxes and grounds: SDF text written here, same proximity tags as sdf/ ---

# Proximity values of a generic box or ground when the scene gives none: the containers'
# (sdf/README.md says why each value).
BOX_DEFAULT_PROPERTIES: dict[str, float] = {
    "hydroelastic_modulus": HYDROELASTIC_MODULUS, "hydroelastic_margin": 0.0, "hunt_crossley_dissipation": 5.0,
    "relaxation_time": 1.0e-3, "point_contact_stiffness": 2.0e9, "mu_dynamic": 0.4, "mu_static": 0.5,
}
PROXIMITY_TAGS = tuple(BOX_DEFAULT_PROPERTIES)


def _proximity_xml(properties: dict[str, float], *, hydroelastic: str | None) -> str:
    """hydroelastic: 'compliant', 'rigid' or None (point contact only)."""
    values = dict(BOX_DEFAULT_PROPERTIES, **(properties or {}))
    if hydroelastic != "compliant":  # only a compliant geometry has a modulus and a margin
        values.pop("hydroelastic_modulus")
        values.pop("hydroelastic_margin")
    tags = "".join(f"<drake:{k}>{float(v)!r}</drake:{k}>" for k, v in values.items())
    kind = f"<drake:{hydroelastic}_hydroelastic/>" if hydroelastic else ""
    return f"<drake:proximity_properties>{kind}{tags}</drake:proximity_properties>"


def box_sdf(
    *,
    name: str,
    size,
    mass: float,
    inertia=None,
    p_BoBcm_B=(0.0, 0.0, 0.0),
    properties: dict[str, float] | None = None,
    rgba=(0.6, 0.6, 0.6, 1.0),
    corner_spheres: float = 0.0,
    box_collision: bool = True,
) -> str:
    """SDF text of a generic rigid box, link 'body', body frame B at the geometric centre.

    size (3,): full extents [m]; mass [kg]; inertia (3,): principal moments about the COM
    along B's axes [kg m^2], None = uniform solid box; p_BoBcm_B (3,): COM offset in B [m];
    properties: drake:proximity_properties values (PROXIMITY_TAGS) replacing
    BOX_DEFAULT_PROPERTIES; the box is compliant_hydroelastic.
    corner_spheres > 0 adds 8 spheres of that radius [m] inside the corners (their
    surfaces touch the box's faces) as extra point-contact geometry: point contact
    between a box and a plane reports only the deepest corner, spheres give one contact
    per touching corner (DESIGN.md section 3). The spheres have no hydroelastic
    representation: use them with point contact. box_collision False leaves the spheres
    as the only collision geometry (a box with rounded corners, for contact with a plane).
    """
    size = [float(v) for v in size]
    moments = solid_box_inertia(mass, size) if inertia is None else np.asarray(inertia, dtype=float)
    proximity = _proximity_xml(properties or {}, hydroelastic="compliant")
    box = f"<geometry><box><size>{' '.join(repr(v) for v in size)}</size></box></geometry>"
    collisions = [f'<collision name="collision">{box}{proximity}</collision>'] if box_collision else []
    if corner_spheres > 0:
        r = float(corner_spheres)
        sphere_props = _proximity_xml(properties or {}, hydroelastic=None)
        for i, corner in enumerate(np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3)):
            c = [float(v) for v in corner * (0.5 * np.asarray(size) - r)]
            collisions.append(
                f'<collision name="corner_{i}"><pose>{c[0]!r} {c[1]!r} {c[2]!r} 0 0 0</pose>'
                f"<geometry><sphere><radius>{r!r}</radius></sphere></geometry>{sphere_props}</collision>")
    return (
        '<?xml version="1.0"?><sdf version="1.9" xmlns:drake="http://drake.mit.edu">'
        f'<model name="{name}"><link name="body"><inertial>'
        f"<pose>{' '.join(repr(float(x)) for x in p_BoBcm_B)} 0 0 0</pose><mass>{float(mass)!r}</mass>"
        f"<inertia><ixx>{float(moments[0])!r}</ixx><iyy>{float(moments[1])!r}</iyy><izz>{float(moments[2])!r}</izz>"
        "<ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial>"
        f'<visual name="visual">{box}<material><diffuse>{" ".join(str(float(c)) for c in rgba)}</diffuse></material></visual>'
        f"{''.join(collisions)}</link></model></sdf>"
    )


def flat_ground_sdf(*, shape: str, height: float, size=(400.0, 400.0, 2.0), properties: dict[str, float] | None = None) -> str:
    """SDF text of a static ground named GROUND_NAME (link 'slab') whose top face is at z = height [m].

    shape 'slab': a rigid box of full extents `size` [m]; 'halfspace': Drake's half-space
    (infinite, SDF <plane>), drawn as a thin 400 m square. properties as in box_sdf.
    """
    proximity = _proximity_xml(properties or {}, hydroelastic="rigid")
    if shape == "halfspace":
        pose = f"0 0 {float(height)!r} 0 0 0"
        collision_geometry = "<geometry><plane><normal>0 0 1</normal><size>400 400</size></plane></geometry>"
        visual_geometry = "<geometry><box><size>400 400 0.001</size></box></geometry>"
        visual_pose = "<pose>0 0 -0.0005 0 0 0</pose>"
    elif shape == "slab":
        lx, ly, lz = (float(v) for v in size)
        pose = f"0 0 {float(height) - lz / 2!r} 0 0 0"
        collision_geometry = visual_geometry = f"<geometry><box><size>{lx!r} {ly!r} {lz!r}</size></box></geometry>"
        visual_pose = ""
    else:
        raise ModelError(f"ground shape {shape!r}; expected 'slab' or 'halfspace'")
    return (
        '<?xml version="1.0"?><sdf version="1.9" xmlns:drake="http://drake.mit.edu">'
        f'<model name="{GROUND_NAME}"><static>true</static><link name="slab"><pose>{pose}</pose>'
        f'<visual name="visual">{visual_pose}{visual_geometry}<material><diffuse>0.55 0.55 0.52 1</diffuse></material></visual>'
        f'<collision name="collision">{collision_geometry}{proximity}</collision></link></model></sdf>'
    )


def apply_contact_switches(text: str, *, collision: bool = True, properties: dict[str, float] | None = None) -> str:
    """SDF text with every link's collisions removed (collision False) or their proximity values replaced."""
    root = ET.fromstring(text)
    for link in root.iter("link"):
        _apply_contact_switches(link, collision=collision, properties=properties)
    return ET.tostring(root, encoding="unicode")


def scene_body_sdf(spec, *, collision: bool = True, properties: dict[str, float] | None = None) -> str:
    """SDF text of one `containers:` entry of a scene (testbed.scenario.ContainerSpec): a named
    container type, or a generic box (`type: box`) with its own contact values; `properties`
    (the effects' overrides, e.g. no friction) replace values in both cases."""
    if spec.type != BOX_TYPE:
        return container_sdf(CONTAINER_TYPES[spec.type], name=spec.name, mass=spec.total_mass(),
                             p_CoCcm_C=spec.com_offset, collision=collision, properties=properties)
    box = spec.box
    text = box_sdf(name=spec.name, size=box.size, mass=spec.total_mass(), inertia=box.inertia or None,
                   p_BoBcm_B=spec.com_offset, properties=box.contact.given(), rgba=box.rgba,
                   corner_spheres=box.corner_spheres, box_collision=box.corner_spheres == 0.0)
    return apply_contact_switches(text, collision=collision, properties=properties)


def scene_ground_sdf(surface, *, collision: bool = True, properties: dict[str, float] | None = None) -> str:
    """SDF text of a scene's ground: the quay slab when `surface` (testbed.bodies.boxes.GroundSpec) is None."""
    if surface is None:
        return ground_sdf(collision=collision, properties=properties)
    text = flat_ground_sdf(shape=surface.shape, height=surface.height, size=surface.size, properties=surface.contact.given())
    return apply_contact_switches(text, collision=collision, properties=properties)


def ground_sdf(*, collision: bool = True, properties: dict[str, float] | None = None) -> str:
    """SDF text of the quay ground with the same contact switches as containers."""
    root = ET.fromstring(_read_model(GROUND_URL))
    for link in root.iter("link"):
        _apply_contact_switches(link, collision=collision, properties=properties)
    return ET.tostring(root, encoding="unicode")


def _apply_contact_switches(link: ET.Element, *, collision: bool, properties: dict[str, float] | None) -> None:
    for element in list(link.findall("collision")):
        if not collision:
            link.remove(element)
            continue
        props = element.find(f"{{{_DRAKE_NS}}}proximity_properties")
        for tag, value in (properties or {}).items():
            node = props.find(f"{{{_DRAKE_NS}}}{tag}")
            if node is None:  # e.g. a margin on the rigid ground, which has none
                continue
            node.text = repr(float(value))


# ElementTree must write the drake prefix back as 'drake:' for Drake's parser.
ET.register_namespace("drake", _DRAKE_NS)
