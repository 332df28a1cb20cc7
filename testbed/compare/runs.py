"""The twin run's kinds of one scene (truth, learned, point) and their recorded runs.

A kind keeps the scene's PHYSICS effects (testbed.effects.Role; contact, friction, wind,
crane, ...) and drops every recorder, observer and viewer, so its wall time is the cost
of the dynamics alone; each is a composition of testbed/variants.py's edits. The records
(testbed.simulation.Trajectory) come from the one sampled-run loop, record_run.
"""

from __future__ import annotations

from testbed import variants
from testbed.builder import build_scene
from testbed.simulation import Trajectory, record_run

KINDS = ("truth", "point", "learned")


def variant(scenario, kind: str, predictor: str | None = None):
    """A copy of `scenario` for kind 'truth' (the scene's own contact model), 'point'
    (Drake point contact) or 'learned' (learned_dynamics with `predictor`; None: the
    scene's own learned_dynamics config if it declares one, else "improved"). Every kind
    runs the containers at the learned law's modulus (law_modulus: 1e8 Pa unless the scene
    sets one), not the SDF's 1e9 Pa: like is compared with like (learned_dynamics.force_law.KAPPA_MODULUS
    is its fit, and the stiffest its explicit step takes at 1 ms)."""
    if kind not in KINDS:
        raise ValueError(f"unknown variant {kind!r}")
    edits = [variants.modulus(None), variants.physics_only(learned=False)]
    if kind == "point":
        edits.append(variants.contact("point"))
    elif kind == "learned":
        edits.append(variants.learned_loop(predictor, given=scenario.effects.learned_dynamics))
    return variants.derive(scenario, *edits)


def run_variant(scenario, duration: float, record_every: int, source="<scenario>", scene=None) -> Trajectory:
    """record_run of a built `scene` (or of `scenario`, built here) for `duration` [s],
    recording every `record_every` plant steps (testbed.simulation: a failing run ends
    early with `error` set; the records up to then are kept)."""
    return record_run(scene or build_scene(scenario, source), duration, record_every)
