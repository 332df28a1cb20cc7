"""One ground truth for every candidate: `testbed compare SCENE --engine all`.

The learned comparison runs Drake at the learned law's modulus (1e8 Pa unless the scene
sets one) and `--engine mujoco` at the scene's own (the shipped SDF's 1e9 Pa), so their
figures are errors against different truths. `--engine all` has a learned candidate, so
compare_candidates puts the scene at the learned law's modulus (run_candidates.run_scenes)
and ONE Drake hydroelastic run at that modulus is the reference for every candidate from the
same initial state: Drake point contact, the learned closed loop (gated as usual) and every
other registered engine (testbed.engines.alternatives: MuJoCo with contact parameters matched
to that same Drake, its model.py following the scene's modulus; MuJoCo + learned, judged by the
closed-loop gates too). Every row's figures are compare_figures' against that one truth run,
with the separating-axis depth (SatDepth) for every row's penetration; wall times are per
simulated second [s], measured in this one process (compare.json `table`).
Adding an engine adds its row (testbed.compare.candidates.all_candidates builds the list,
testbed.compare.printed.format_table prints the table); this module keeps at_law_modulus.
"""

from __future__ import annotations

from testbed import variants


def at_law_modulus(scenario):
    """A copy of `scenario` whose containers are at the learned law's modulus
    (effects.contact.hydroelastic_modulus set), for every engine alike."""
    return variants.derive(scenario, variants.modulus(None))
