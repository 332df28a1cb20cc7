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

from testbed.containers import ContainerType
from testbed.errors import ModelError

SDF_DIR = Path(__file__).resolve().parent.parent / "sdf"  # the repo's sdf/ folder
PACKAGE_NAME = "testbed"
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
    inertial = link.find("inertial")
    inertial.find("mass").text = repr(float(mass))
    inertial.find("pose").text = " ".join(repr(float(x)) for x in p_CoCcm_C) + " 0 0 0"
    moments = solid_box_inertia(mass, ctype.size)
    inertia = inertial.find("inertia")
    for tag, value in zip(("ixx", "iyy", "izz"), moments):
        inertia.find(tag).text = repr(float(value))
    _apply_contact_switches(link, collision=collision, properties=properties)
    return ET.tostring(root, encoding="unicode")


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
