"""Case kind `scene`: one scene under one contact model, with the learned comparison.

Gates: finite state, resting penetration, force balance on the ground at rest (not for
crane scenes: the ropes carry part of the load until the twistlocks release; nor for scenes
with a welded container: the weld carries the load, e.g. overhang_hold).
Sections: the predictor's worst case (near the verdict) and the table of scenes.
"""

from __future__ import annotations

from testbed import variants
from testbed.bodies.models import GROUND_NAME
from testbed.contact.surfaces import EXACT_LABEL_TOLERANCE_M
from testbed.document import Section, Text, table
from testbed.gates import Gate
from testbed.gates.in_scene import IN_SCENE_POINT_MEDIAN_M, KNOWN_IN_SCENE_LIMITS, point_error_gate  # noqa: F401
from testbed.physics import GRAVITY
from testbed.scenario import load_scenario, shipped_scenes
from testbed.simulation import run_scenario
from testbed.validation.cases import Case, CaseKind, ok_records, register

# Rest figures (force balance, resting penetration) are averaged over the last
# REST_WINDOW_S of the run: point contact hops between corners step to step, and
# 0.5 s holds several hops (the same window as tests/physics/test_physics_rest.py).
REST_WINDOW_S = 0.5
# At rest a container pair overlaps ~0.25 mm per contact under its own weight (sdf/README.md);
# 5 mm at rest means the contact is far too soft for stacking (9 contacts would sink 4.5 cm).
MAX_RESTING_PENETRATION_M = 0.005
FORCE_BALANCE_TOL = 0.01  # at rest, contact forces on the ground carry the total weight within 1%

# In-scene accuracy of the learned predictor, judged where it is trained to answer: the
# hydroelastic centre of pressure of scenes driven by hydroelastic contact. The bound, the
# pinned known limits and the gate are testbed.gates.in_scene's, shared with `testbed bench`
# and `testbed compare` (re-exported here under their old names).

MODELS = ("hydroelastic", "point")
SMOKE_DURATION_S = 0.8
DEFAULT_SCENES = ("two_stack", "five_stack", "bridge", "single_drop", "windy_stack", "nine_mixed_stack",
                  "crane_misaligned", "crane_hard_landing")


def scene_cases(scenes, models, duration) -> list[Case]:
    """Scene x contact model cases; duration None = each scene's own."""
    return [Case(f"scene-{s}-{m}", "scene", {"scene": s, "model": m, "duration": duration})
            for s in scenes for m in models]


def worst_learned(records: list[dict]) -> list[dict]:
    """The ok scene records with a learned point error, largest error first."""
    scored = [r for r in ok_records(records, "scene")
              if r["result"].get("learned_vs_hydro_point_error_max_m") is not None]
    return sorted(scored, key=lambda r: -r["result"]["learned_vs_hydro_point_error_max_m"])


@register
class SceneCase(CaseKind):
    name = "scene"
    order = 10
    timing_keys = ("real_time_factor", "ms_per_sim_second")

    def cases(self, suite: str) -> list[Case]:
        if suite == "smoke":
            # long enough for the rest gates to mean something: the last REST_WINDOW_S of a
            # 0.8 s run starts after the first settling transient (measured: force balance
            # within 0.2% for both scenes and models at 0.6 s; at 0.05 s the bridge fails)
            return scene_cases(["two_stack", "bridge"], MODELS, SMOKE_DURATION_S)
        if suite == "default":
            return scene_cases(DEFAULT_SCENES, MODELS, None)
        if suite == "full":
            return scene_cases(sorted(shipped_scenes()), (*MODELS, "hydroelastic_with_fallback"), None)
        return []

    def run(self, scene: str, model: str, duration: float) -> dict:
        import numpy as np

        scenario = variants.derive(load_scenario(scene), variants.contact(model),
                                   variants.effects_on(["contact_log", "shadow_contact", "learned_contact"]))
        result = run_scenario(scenario, duration=duration)
        summary = dict(result.summary)
        c = result.tables["contacts"]
        ground = result.body_names.index(GROUND_NAME) if GROUND_NAME in result.body_names else -1
        weight = sum(s.total_mass() for s in scenario.containers if not s.fixed) * GRAVITY
        late = (c["time"] >= c["time"].max() - REST_WINDOW_S) & (c["a"] == ground) if len(c["time"]) else np.zeros(0, bool)
        steps = np.unique(c["step"][late]).size
        summary["ground_force_over_weight"] = float(c["fn"][late].sum() / steps / weight) if steps else float("nan")
        resting = c["time"] >= c["time"].max() - REST_WINDOW_S if len(c["time"]) else np.zeros(0, bool)
        summary["resting_penetration_m"] = float(max(0.0, -np.nanmin(c["phi"][resting]))) if np.any(resting) else 0.0
        summary["learned_available"] = True  # kept in the record: the learned_contact effect is always on here
        summary["welded_containers"] = sum(bool(s.fixed) for s in scenario.containers)
        return summary

    def gates(self, record: dict) -> list[Gate]:
        s, cid = record["result"], record["id"]
        gates = [
            Gate(f"{cid}: finite state", s["finite_state"], s["finite_state"], True, "", "no NaN or inf in the final state"),
            Gate(f"{cid}: resting penetration", s["resting_penetration_m"] < MAX_RESTING_PENETRATION_M,
                 s["resting_penetration_m"], MAX_RESTING_PENETRATION_M, "m",
                 f"largest penetration of any pair over the last {REST_WINDOW_S} s"),
        ]
        gates += self._in_scene_gates(record)
        if "crane" in s.get("effects", []):
            return gates  # the ropes carry part of the load until the twistlocks release
        if s.get("welded_containers"):
            return gates  # a welded container carries the load: the quay does not see the weight
        balance = s.get("ground_force_over_weight", float("nan"))
        gates.append(Gate(f"{cid}: force balance", abs(balance - 1.0) <= FORCE_BALANCE_TOL, balance,
                          [1 - FORCE_BALANCE_TOL, 1 + FORCE_BALANCE_TOL], "x weight",
                          f"mean normal force on the ground over the last {REST_WINDOW_S} s / total weight"))
        return gates

    @staticmethod
    def _in_scene_gates(record: dict) -> list[Gate]:
        """The learned predictor's in-scene point error median, for hydroelastic-driven
        scenes with container pairs (a known limit is judged against its pinned band)."""
        s, cid, params = record["result"], record["id"], record["params"]
        median = s.get("learned_vs_hydro_point_error_median_m")
        if params.get("model") != "hydroelastic" or median is None:
            return []
        return [point_error_gate(f"{cid}: learned point error in scene", median,
                                 truth_gap_m=s.get("learned_vs_hydro_truth_gap_median_m"),
                                 uncertainty_m=EXACT_LABEL_TOLERANCE_M, known=KNOWN_IN_SCENE_LIMITS.get(params["scene"]))]

    def sections(self, records: list[dict]) -> list[Section]:
        if not records:
            return []
        out = []
        worst = worst_learned(records)
        if worst:
            w = worst[0]["result"]
            out.append(Section(None, [Text(
                f"Predictor worst case: {worst[0]['id']}, point error {w['learned_vs_hydro_point_error_max_m'] * 1e3:.0f} mm "
                f"at step {w.get('learned_vs_hydro_point_error_worst_step')}.")], order=5))
        nan = float("nan")
        rows = [(r["id"], f"{s['real_time_factor']:.2f}", f"{s['max_penetration_m'] * 1e3:.2f}",
                 f"{s.get('shadow_cop_distance_max_m', nan) * 1e3:.0f}",
                 f"{s.get('learned_vs_hydro_point_error_median_m', nan) * 1e3:.1f}",
                 f"{s.get('learned_vs_hydro_point_error_p95_m', nan) * 1e3:.1f}",
                 f"{s.get('learned_vs_hydro_point_error_max_m', nan) * 1e3:.1f}",
                 f"{s.get('learned_vs_hydro_truth_gap_median_m', nan) * 1e3:.2g}",
                 f"{s.get('learned_vs_hydro_normal_error_max_deg', nan):.2f}")
                for r in records for s in [r["result"]]]
        out.append(Section("Scenes", [
            Text("Learned errors are against the hydroelastic centre of pressure and normal the predictor is trained "
                 "for (the driving model's, or the shadow's when a scene drives with point contact). Real-time factor = "
                 "simulated time / wall time (> 1: faster than real time). Shadow CoP disagreement: the distance between "
                 "the driving model's contact point and the shadow model's (point contact reports a corner of the "
                 "contact face for face-on-face contact, so metres on a stack)."),
            table(["case", "real-time factor", "max penetration [mm]", "shadow CoP disagreement max [mm]",
                   "learned point error median [mm]", "p95 [mm]", "max [mm]",
                   "truth gap: one-point rule vs exact, median [mm]", "learned normal error max [deg]"], rows),
        ], order=60))
        return out
