"""ISO 668 container types known to the testbed.

One place for the facts about each type: external size, tare and maximum gross
mass, the SDF model that draws and collides it, and its colour in viewers.
Sizes are external dimensions [m]; masses are [kg].
Source for sizes and masses: ISO 668:2020 Table 1 (1CC, 1AA, 1AAA) and typical
tare masses of steel dry containers as given in the foundation issue.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from testbed.errors import UnknownChoiceError

# [Pa] drake:hydroelastic_modulus of every container in sdf/containers/*.sdf (chosen by
# `testbed study defaults`; sdf/README.md says why; tests/physics/test_defaults_sweep.py checks the files)
HYDROELASTIC_MODULUS = 1.0e9


@dataclasses.dataclass(frozen=True)
class ContainerType:
    """An ISO container type.

    size: (3,) full external extents (length x, width y, height z) [m], in the
      container's body frame C, whose origin is the geometric centre.
    """

    code: str
    description: str
    size: tuple[float, float, float]
    tare_mass: float  # [kg]
    max_gross_mass: float  # [kg]
    model_url: str
    rgba: tuple[float, float, float, float]

    @property
    def half_size(self) -> np.ndarray:
        """(3,) half extents [m]."""
        return 0.5 * np.asarray(self.size)

    @property
    def footprint_area(self) -> float:
        """Bottom face area [m^2]."""
        return float(self.size[0] * self.size[1])


CONTAINER_TYPES: dict[str, ContainerType] = {
    t.code: t
    for t in (
        ContainerType(
            code="1CC",
            description="20 ft standard",
            size=(6.058, 2.438, 2.591),
            tare_mass=2200.0,
            max_gross_mass=30480.0,
            model_url="package://testbed/containers/container_1CC.sdf",
            rgba=(0.80, 0.25, 0.15, 1.0),
        ),
        ContainerType(
            code="1AA",
            description="40 ft standard",
            size=(12.192, 2.438, 2.591),
            tare_mass=3750.0,
            max_gross_mass=30480.0,
            model_url="package://testbed/containers/container_1AA.sdf",
            rgba=(0.15, 0.35, 0.75, 1.0),
        ),
        ContainerType(
            code="1AAA",
            description="40 ft high cube",
            size=(12.192, 2.438, 2.896),
            tare_mass=3900.0,
            max_gross_mass=32500.0,
            model_url="package://testbed/containers/container_1AAA.sdf",
            rgba=(0.20, 0.60, 0.30, 1.0),
        ),
    )
}


def container_type(code: str) -> ContainerType:
    """Returns the type named `code`, or raises UnknownChoiceError listing the valid codes."""
    try:
        return CONTAINER_TYPES[code]
    except KeyError:
        raise UnknownChoiceError("container type", code, sorted(CONTAINER_TYPES)) from None
