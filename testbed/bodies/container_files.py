"""The SDF files of sdf/containers/, written from the container catalogue (containers.py).

One file per ISO type, so that a scene, Drake's parser and a user's own tools read the same
geometry. The files are generated, not edited: `python -m testbed.bodies.container_files`
rewrites them, and tests/foundation/test_container_files.py fails when a file and the
catalogue disagree. The inertial block is the tare mass as a uniform solid box; scenes replace
mass, centre-of-mass offset and inertia when they load a model (models.container_sdf).
Contact parameters and their reasons: sdf/README.md.
"""

from __future__ import annotations

from pathlib import Path

from testbed.bodies.containers import CONTAINER_TYPES, HYDROELASTIC_MODULUS, ContainerType

CONTAINER_DIR = Path(__file__).resolve().parents[2] / "sdf" / "containers"

# The collision element's drake:proximity_properties, in the files' order (sdf/README.md says why).
PROXIMITY = (("hydroelastic_modulus", f"{HYDROELASTIC_MODULUS:.1e}".replace("e+0", "e")), ("hydroelastic_margin", "0.0"),
             ("hunt_crossley_dissipation", "5.0"), ("relaxation_time", "1.0e-3"),
             ("point_contact_stiffness", "2.0e9"), ("mu_dynamic", "0.4"), ("mu_static", "0.5"))


def _length(x: float) -> str:
    return f"{x:.3f}"


def sdf_text(ctype: ContainerType) -> str:
    """The SDF file of one container type (body frame C at the geometric centre, x along the
    length, z up; sizes [m], tare [kg], moments [kg m^2] to 0.1)."""
    lx, ly, lz = ctype.size
    m = ctype.tare_mass
    moments = (m / 12.0 * (ly**2 + lz**2), m / 12.0 * (lx**2 + lz**2), m / 12.0 * (lx**2 + ly**2))
    size = " ".join(_length(v) for v in ctype.size)
    rgba = " ".join(f"{c:.2f}" for c in ctype.rgba[:3]) + f" {ctype.rgba[3]:g}"
    props = "\n".join(f"          <drake:{k}>{v}</drake:{k}>" for k, v in PROXIMITY)
    return f"""<?xml version="1.0"?>
<!-- ISO {ctype.code} ({ctype.description}), {size.replace(' ', ' x ')} m external. Written by
     testbed/bodies/container_files.py from the catalogue (testbed/bodies/containers.py); do not edit.
     Body frame C: origin at the geometric centre, x along the length, z up. The inertial block
     holds the tare mass as a uniform solid box; scenes replace mass, COM offset and inertia
     (testbed/bodies/models.py). Contact parameters and their reasons: sdf/README.md. -->
<sdf version="1.9" xmlns:drake="http://drake.mit.edu">
  <model name="container_{ctype.code}">
    <link name="body">
      <inertial>
        <pose>0 0 0 0 0 0</pose>
        <mass>{m:g}</mass>
        <inertia>
          <ixx>{moments[0]:.1f}</ixx><iyy>{moments[1]:.1f}</iyy><izz>{moments[2]:.1f}</izz>
          <ixy>0</ixy><ixz>0</ixz><iyz>0</iyz>
        </inertia>
      </inertial>
      <visual name="visual">
        <geometry><box><size>{size}</size></box></geometry>
        <material><diffuse>{rgba}</diffuse></material>
      </visual>
      <collision name="collision">
        <geometry><box><size>{size}</size></box></geometry>
        <drake:proximity_properties>
          <drake:compliant_hydroelastic/>
{props}
        </drake:proximity_properties>
      </collision>
    </link>
  </model>
</sdf>
"""


def file_path(ctype: ContainerType) -> Path:
    """sdf/containers/container_<code>.sdf."""
    return CONTAINER_DIR / f"container_{ctype.code}.sdf"


def write_all() -> list[Path]:
    """Writes every catalogue type's file; returns their paths."""
    paths = []
    for ctype in CONTAINER_TYPES.values():
        path = file_path(ctype)
        path.write_text(sdf_text(ctype))
        paths.append(path)
    return paths


if __name__ == "__main__":
    for p in write_all():
        print(p)
