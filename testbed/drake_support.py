"""What the installed Drake offers where the two supported releases differ.

The testbed runs on drake 1.51.1 (Python 3.10-3.11) and drake 1.58.0 (Python >= 3.12;
docs/drake-versions.md). Drake 1.57 removed the TAMSI discrete solver
(`discrete_contact_approximation: tamsi`), so what a scene, a sweep or a study may ask for
depends on the installed release. Each answer here is a feature test on the installed
pydrake (what it binds), not a comparison of version numbers; the version is named only in
messages.
"""

from __future__ import annotations

import functools
from importlib import metadata

TAMSI = "tamsi"  # Drake's name of the approximation (MultibodyPlantConfig.discrete_contact_approximation)


def drake_version() -> str:
    """The installed drake distribution's version, e.g. '1.58.0' (pydrake has no __version__)."""
    try:
        return metadata.version("drake")
    except metadata.PackageNotFoundError:
        return "unknown"


@functools.cache
def has_tamsi() -> bool:
    """Whether the installed Drake still has the TAMSI solver (removed in Drake 1.57): its
    DiscreteContactApproximation enum binds kTamsi."""
    from pydrake.multibody.plant import DiscreteContactApproximation

    return hasattr(DiscreteContactApproximation, "kTamsi")


def available(approximations) -> tuple[str, ...]:
    """`approximations` (Drake's names, in order) less those the installed Drake lacks ('tamsi'
    from Drake 1.57 on): what sweeps and study axes iterate over."""
    return tuple(a for a in approximations if a != TAMSI or has_tamsi())


def missing_approximation(approximation: str) -> str | None:
    """None when the installed Drake has `approximation`; else one line saying it does not,
    naming the installed version (for a ScenarioError or TestbedError)."""
    if approximation != TAMSI or has_tamsi():
        return None
    return (f"'{TAMSI}' is not available in the installed Drake {drake_version()} (Drake 1.57 removed the TAMSI solver; "
            f"Python 3.11 with drake 1.51.1 still has it, README 'Python and Drake versions')")
