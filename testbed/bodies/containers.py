"""ISO 668 container types known to the testbed.

One place for the facts about each type: external size, tare and maximum gross
mass, the SDF model that draws and collides it, and its colour in viewers.
Sizes are external dimensions [m]; masses are [kg].
Source for sizes and ratings: ISO 668:2020 Table 1 (series 1: lengths 10, 20, 30, 40 and 45 ft;
heights 8 ft 6 in, 9 ft 6 in, 8 ft and below 8 ft, the "X" types). Tare masses are typical figures of
steel dry containers, rounded (a scene gives each container's own mass).
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


# (code, description, length, height, tare [kg], max gross [kg], rgba). Width is 2.438 m for every
# series 1 type. Heights: 2.896 m (9 ft 6 in, high cube), 2.591 m (8 ft 6 in), 2.438 m (8 ft), and the
# "X" types' half height, 1.295 m (4 ft 3 in; ISO 668 gives X only as "below 2 438 mm", 1.295 m is the
# half height that open-top and bulk half heights are built to).
_SERIES_1 = (
    ("1EEE", "45 ft high cube", 13.716, 2.896, 4800.0, 30480.0, (0.55, 0.20, 0.60, 1.0)),
    ("1EE", "45 ft standard", 13.716, 2.591, 4600.0, 30480.0, (0.45, 0.25, 0.65, 1.0)),
    ("1AAA", "40 ft high cube", 12.192, 2.896, 3900.0, 32500.0, (0.20, 0.60, 0.30, 1.0)),
    ("1AA", "40 ft standard", 12.192, 2.591, 3750.0, 30480.0, (0.15, 0.35, 0.75, 1.0)),
    ("1A", "40 ft, 8 ft high", 12.192, 2.438, 3650.0, 30480.0, (0.20, 0.45, 0.80, 1.0)),
    ("1AX", "40 ft half height", 12.192, 1.295, 3000.0, 30480.0, (0.30, 0.55, 0.85, 1.0)),
    ("1BBB", "30 ft high cube", 9.125, 2.896, 3200.0, 30480.0, (0.85, 0.60, 0.10, 1.0)),
    ("1BB", "30 ft standard", 9.125, 2.591, 3000.0, 30480.0, (0.80, 0.55, 0.15, 1.0)),
    ("1B", "30 ft, 8 ft high", 9.125, 2.438, 2900.0, 30480.0, (0.75, 0.50, 0.20, 1.0)),
    ("1BX", "30 ft half height", 9.125, 1.295, 2500.0, 30480.0, (0.90, 0.70, 0.30, 1.0)),
    ("1CC", "20 ft standard", 6.058, 2.591, 2200.0, 30480.0, (0.80, 0.25, 0.15, 1.0)),
    ("1C", "20 ft, 8 ft high", 6.058, 2.438, 2150.0, 30480.0, (0.75, 0.30, 0.20, 1.0)),
    ("1CX", "20 ft half height", 6.058, 1.295, 1900.0, 30480.0, (0.85, 0.40, 0.30, 1.0)),
    ("1D", "10 ft, 8 ft high", 2.991, 2.438, 1300.0, 10160.0, (0.45, 0.45, 0.45, 1.0)),
    ("1DX", "10 ft half height", 2.991, 1.295, 1100.0, 10160.0, (0.60, 0.60, 0.60, 1.0)),
)
SERIES_1_WIDTH = 2.438  # [m]

CONTAINER_TYPES: dict[str, ContainerType] = {
    code: ContainerType(code=code, description=description, size=(length, SERIES_1_WIDTH, height),
                        tare_mass=tare, max_gross_mass=gross,
                        model_url=f"package://testbed/containers/container_{code}.sdf", rgba=rgba)
    for code, description, length, height, tare, gross, rgba in _SERIES_1
}
# The sizes the shipped predictor's network was fitted on (learned_contact/training/config.py); every other
# type is a size it was not fitted on (learned_contact/shipped/report.md: accuracy per size class).
FITTED_TYPES = ("1CC", "1AA", "1AAA")


GENERIC_PREFIX = "box:"  # a generic box's code: "box:<length>,<width>,<height>" full extents [m]
GENERIC_TEMPLATE = "1CC"  # the type whose file a generic box's model is made from (its size replaced)


def generic_code(size) -> str:
    """The code of a generic box of full extents `size` (3,) [m], e.g. "box:7.5,2.5,2.7"."""
    return GENERIC_PREFIX + ",".join(f"{float(v):.6g}" for v in size)


def generic_box(size) -> ContainerType:
    """A box of any full extents `size` (3,) [m] in the catalogue's form: the template type's
    file, contact parameters and colour, its size replaced, a tare of 250 kg per metre of length
    (about a steel dry box's; scenes give their own mass)."""
    size = tuple(float(v) for v in size)
    if len(size) != 3 or not all(0.0 < v < 100.0 for v in size):
        raise UnknownChoiceError("container type", generic_code(size), sorted(CONTAINER_TYPES))
    template = CONTAINER_TYPES[GENERIC_TEMPLATE]
    tare = 250.0 * size[0]
    return dataclasses.replace(template, code=generic_code(size), description="generic box", size=size,
                               tare_mass=tare, max_gross_mass=max(template.max_gross_mass, tare))


def container_type(code: str) -> ContainerType:
    """Returns the type named `code` (an ISO code, or a generic box's "box:<l>,<w>,<h>"), or raises
    UnknownChoiceError listing the valid codes."""
    if code in CONTAINER_TYPES:
        return CONTAINER_TYPES[code]
    if code.startswith(GENERIC_PREFIX):
        try:
            return generic_box([float(v) for v in code[len(GENERIC_PREFIX):].split(",")])
        except ValueError:
            pass
    raise UnknownChoiceError("container type", code, sorted(CONTAINER_TYPES))
