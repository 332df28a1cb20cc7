"""The in-scene figures of a predictor: asked at every recorded step of Drake's hydroelastic run
of a scene (open loop: Drake's contact drives, the predictor is only asked), its contact point and
normal against Drake's centre of pressure. testbed.gates.in_scene judges them; the bench and
`testbed compare` (its verdict) both call this one function, so a model the bench rejects in a
scene fails compare's verdict on it too.
"""

from __future__ import annotations

from testbed import variants
from testbed.contact.surfaces import EXACT_LABEL_TOLERANCE_M
from testbed.scenario import Scenario, load_scenario
from testbed.simulation import run_scenario

# the scene summary's keys (testbed.effects.learned_contact: learned_vs_hydro_*) -> figure names
SUMMARY_KEYS = {"rows": "learned_vs_hydro_rows",
                "point_error_median_m": "learned_vs_hydro_point_error_median_m",
                "point_error_max_m": "learned_vs_hydro_point_error_max_m",
                "normal_error_median_deg": "learned_vs_hydro_normal_error_median_deg",
                "normal_error_max_deg": "learned_vs_hydro_normal_error_max_deg",
                "truth_gap_median_m": "learned_vs_hydro_truth_gap_median_m"}


def figures_from_summary(summary: dict, scene: str, duration: float, predictor: str,
                         truth_uncertainty_m: float | None = None) -> dict:
    """The in-scene figures (testbed.gates.in_scene's module docstring) from a hydroelastic-driven run's summary
    (testbed.simulation's result.summary with the learned_contact effect on)."""
    return {"scene": scene, "duration_s": float(duration), "predictor": predictor,
            **{name: summary.get(key) for name, key in SUMMARY_KEYS.items()},
            "truth_uncertainty_m": truth_uncertainty_m}



def in_scene_figures(scenario, predictor_spec: str, duration: float | None = None) -> dict:
    """The in-scene figures (testbed.gates.in_scene's module docstring) of predictor
    `predictor_spec` (a learned_contact.sources string) on `scenario` (a shipped scene's name, a
    scene file, or a loaded Scenario, which is not changed): the scene run for `duration` [s]
    (None: its own) with Drake hydroelastic contact driving it, no learned closed loop, and the
    learned_contact effect asking the predictor at every recorded step."""
    base = scenario if isinstance(scenario, Scenario) else load_scenario(str(scenario))

    def ask(s):
        s.effects.learned_dynamics = None  # Drake's own contact drives: the truth the predictor is asked beside
        s.effects.learned_contact.predictor = str(predictor_spec)

    s = variants.derive(base, variants.contact("hydroelastic"),
                        variants.effects_on(["contact_log", "shadow_contact", "learned_contact"]), ask)
    run_for = float(duration) if duration is not None else float(s.duration)
    summary = run_scenario(s, duration=run_for).summary
    return figures_from_summary(summary, s.name, run_for, str(predictor_spec), EXACT_LABEL_TOLERANCE_M)
