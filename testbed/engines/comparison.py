"""Drake's truth for an engine comparison: the modulus an engine is judged at and the scene's
dynamics alone (used by the scale study). The comparison itself (any engine, the learned loop,
Drake point against one Drake run) is testbed/compare: compare_candidates, compare_engine.
"""

from __future__ import annotations

from testbed import variants
from testbed.bodies.containers import HYDROELASTIC_MODULUS


def drake_modulus(scenario) -> float:
    """[Pa] the containers' hydroelastic modulus in the Drake truth an engine is judged against:
    the scene's effects.contact.hydroelastic_modulus, else the shipped SDF's."""
    contact = scenario.effects.contact
    given = contact.hydroelastic_modulus if contact is not None else None
    return HYDROELASTIC_MODULUS if given is None else float(given)


def engine_variant(scenario, kind: str):
    """The scene's dynamics alone (PHYSICS effects, no learned loop) for Drake's kind
    'truth' (its own contact model) or 'point', at the scene's own contact parameters."""
    point = [variants.contact("point")] if kind == "point" else []
    return variants.derive(scenario, variants.physics_only(learned=False), *point)
