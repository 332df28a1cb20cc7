"""sdf/containers/ holds one file per catalogue type, each the text testbed/bodies/container_files.py
writes from the catalogue, so a file and the catalogue cannot disagree on a size, a tare or a
contact parameter (tests/learned/test_quadrature.py loads every one in Drake and checks its mesh)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from testbed.bodies.container_files import CONTAINER_DIR, file_path, sdf_text
from testbed.bodies.containers import CONTAINER_TYPES, HYDROELASTIC_MODULUS


def test_every_type_has_its_generated_file_and_no_other_file_is_there():
    assert {p.name for p in CONTAINER_DIR.glob("*.sdf")} == {file_path(t).name for t in CONTAINER_TYPES.values()}
    stale = [code for code, t in CONTAINER_TYPES.items() if file_path(t).read_text() != sdf_text(t)]
    assert not stale, f"rewrite with python -m testbed.bodies.container_files: {stale}"


@pytest.mark.parametrize("code", sorted(CONTAINER_TYPES))
def test_the_file_holds_the_catalogues_box_tare_and_modulus(code):
    ctype = CONTAINER_TYPES[code]
    link = ET.fromstring(file_path(ctype).read_text()).find("model/link")
    for element in link.iter("box"):
        assert tuple(float(v) for v in element.find("size").text.split()) == ctype.size
    assert float(link.find("inertial/mass").text) == ctype.tare_mass
    ixx = float(link.find("inertial/inertia/ixx").text)
    assert ixx == pytest.approx(ctype.tare_mass / 12 * (ctype.size[1] ** 2 + ctype.size[2] ** 2), abs=0.06)
    modulus = link.find("collision/{http://drake.mit.edu}proximity_properties/{http://drake.mit.edu}hydroelastic_modulus")
    assert float(modulus.text) == HYDROELASTIC_MODULUS
